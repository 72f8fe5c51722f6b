"""Tumbling particles in the add-on: tests/blender/suite_tumbling.py run inside Debian's Blender (3.4, Euler
orientation attribute) and the newest bpy module (quaternion attribute), one pytest test per suite test and
host, the way test_addon.py runs suite_addon."""

import pytest

from test_addon import HOSTS, host_missing, suite_names, suite_results


@pytest.fixture(scope="session")
def tumbling_tmp(tmp_path_factory):
    return tmp_path_factory.mktemp("tumbling")


@pytest.mark.parametrize("host", HOSTS)
@pytest.mark.parametrize("name", suite_names("suite_tumbling"))
def test_tumbling_in_blender(host, name, tumbling_tmp):
    why = host_missing(host)
    if why:
        pytest.skip(why)
    proc, records, _ = suite_results(host, "suite_tumbling", tumbling_tmp)
    rec = records.get(name)
    assert rec is not None, f"{name} did not report (exit {proc.returncode}):\n{proc.stdout[-4000:]}\n" \
                            f"{proc.stderr[-4000:]}"
    assert rec["ok"], f"[{rec['host']}] {rec['error']}"
