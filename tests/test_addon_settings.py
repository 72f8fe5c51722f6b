"""Settings in the artist's units and the add-on's bounds (issues 14 and 15, items 4 and 5):
tests/blender/suite_settings.py inside Debian's Blender and inside the bpy module, one pytest test per test there
and per host (the runner of tests/test_addon.py)."""

import pytest

from test_addon import HOSTS, host_missing, suite_names, suite_results


@pytest.mark.parametrize("host", HOSTS)
@pytest.mark.parametrize("name", suite_names("suite_settings"))
def test_addon_settings(host, name, tmp_path_factory):
    if host_missing(host):
        pytest.skip(host_missing(host))
    proc, records, _ = suite_results(host, "suite_settings", tmp_path_factory.getbasetemp() / "settings")
    crashed = {"ok": False, "host": host, "error": f"no report from {name}: Blender exited with {proc.returncode} "
                                                   f"(a crash?)\n{proc.stdout[-4000:]}\n{proc.stderr[-4000:]}"}
    rec = records.get(name, crashed)
    assert rec["ok"], f"[{rec['host']}] {rec['error']}"
