"""Jiggle that rides the animation (tests/blender/suite_character.py, issue 24), in Debian's Blender and in the
bpy module: see tests/test_addon.py for how the suites run."""

import pytest

from test_addon import HOSTS, check_suite_test, suite_names


@pytest.fixture(scope="session")
def character_tmp(tmp_path_factory):
    return tmp_path_factory.mktemp("character")


@pytest.mark.parametrize("host", HOSTS)
@pytest.mark.parametrize("name", suite_names("suite_character"))
def test_character_in_blender(host, name, character_tmp):
    check_suite_test(host, "suite_character", name, character_tmp)
