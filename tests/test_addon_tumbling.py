"""Tumbling particles in the add-on: tests/blender/suite_tumbling.py run inside Debian's Blender (3.4, Euler
orientation attribute) and the newest bpy module (quaternion attribute), one pytest test per suite test and
host, the way test_addon.py runs suite_addon."""

import pytest

from test_addon import HOSTS, check_suite_test, suite_names


@pytest.fixture(scope="session")
def tumbling_tmp(tmp_path_factory):
    return tmp_path_factory.mktemp("tumbling")


@pytest.mark.parametrize("host", HOSTS)
@pytest.mark.parametrize("name", suite_names("suite_tumbling"))
def test_tumbling_in_blender(host, name, tumbling_tmp):
    check_suite_test(host, "suite_tumbling", name, tumbling_tmp)
