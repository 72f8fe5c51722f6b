"""Settings in the artist's units and the add-on's bounds (issues 14 and 15, items 4 and 5):
tests/blender/suite_settings.py in Debian's Blender and in the bpy module: see tests/test_addon.py for how the
suites run."""

import pytest

from test_addon import HOSTS, check_suite_test, suite_names


@pytest.fixture(scope="session")
def settings_tmp(tmp_path_factory):
    return tmp_path_factory.mktemp("settings")


@pytest.mark.parametrize("host", HOSTS)
@pytest.mark.parametrize("name", suite_names("suite_settings"))
def test_settings_in_blender(host, name, settings_tmp):
    check_suite_test(host, "suite_settings", name, settings_tmp)
