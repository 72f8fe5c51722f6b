"""Blender-side robustness (docs/hardening.md): tests/blender/suite_robustness.py inside Debian's Blender and
inside the bpy module, one pytest test per test there and per host (the runner of tests/test_addon.py)."""

import pytest

from test_addon import HOSTS, host_missing, suite_names, suite_results


@pytest.fixture(scope="session")
def robustness_tmp(tmp_path_factory):
    return tmp_path_factory.mktemp("robustness")


@pytest.mark.parametrize("host", HOSTS)
@pytest.mark.parametrize("name", suite_names("suite_robustness"))
def test_addon_robustness(host, name, robustness_tmp):
    why = host_missing(host)
    if why:
        pytest.skip(why)
    proc, records, _ = suite_results(host, "suite_robustness", robustness_tmp)
    rec = records.get(name)
    assert rec is not None, f"{name} did not report (exit {proc.returncode}: a crash?):\n{proc.stdout[-4000:]}\n" \
                            f"{proc.stderr[-4000:]}"
    assert rec["ok"], f"[{rec['host']}] {rec['error']}"
