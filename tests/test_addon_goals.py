"""Goals and non-destructive output in Blender (tests/blender/suite_goals.py), in Debian's Blender and in the
bpy module: see tests/test_addon.py for how the suites run."""

import pytest

from test_addon import HOSTS, check_suite_test, suite_names


@pytest.fixture(scope="session")
def goals_tmp(tmp_path_factory):
    return tmp_path_factory.mktemp("goals")


@pytest.mark.parametrize("host", HOSTS)
@pytest.mark.parametrize("name", suite_names("suite_goals"))
def test_goals_in_blender(host, name, goals_tmp):
    check_suite_test(host, "suite_goals", name, goals_tmp)
