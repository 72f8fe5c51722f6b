"""The Blender add-on (addon/opdeform_blender), tested inside Debian's Blender (``blender -b``) and inside the
newest ``bpy`` module from PyPI that installs here (scripts/setup-bpy puts it in its own venv).

Each host runs tests/blender/suite_addon.py once (tests/blender/runner.py prints one result line per test);
every test there is one pytest test here, per host. The compiled module reaches Blender through
$OPDEFORM_PYTHONPATH = the folder scripts/test puts on PYTHONPATH (<build>/python)."""

import ast
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

import opdeform

ROOT = Path(__file__).resolve().parent.parent
BLENDER_TESTS = ROOT / "tests" / "blender"
BPY_VENV = Path(os.environ.get("OPDEFORM_BPY_VENV", Path.home() / ".cache" / "opdeform" / "bpy-venv"))
BPY_PYTHON = BPY_VENV / "bin" / "python"
HOSTS = ("blender", "bpy")


def build_python_dir():
    return str(Path(opdeform.__file__).resolve().parent.parent)


def host_missing(host):
    """None when the host can run here, else why not (CI must have Debian's Blender)."""
    if host == "blender":
        if shutil.which("blender") is None:
            return None if os.environ.get("CI") else "Debian's blender is not installed (scripts/setup)"
        return None
    if not BPY_PYTHON.exists():
        return f"the bpy module is not installed ({BPY_VENV}; scripts/setup-bpy)"
    return None


def host_env(extra=None, with_module=True):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "OPDEFORM_PYTHONPATH")}
    if with_module:
        env["OPDEFORM_PYTHONPATH"] = build_python_dir()
    env.update(extra or {})
    return env


def run_host(host, script, args=(), env=None, timeout=600):
    if host == "blender":
        cmd = [str(ROOT / "scripts" / "blender"), "-b", "--factory-startup", "--python-exit-code", "1", "-P",
               str(script), "--", *args]
    else:
        cmd = [str(BPY_PYTHON), str(script), *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env or host_env(),
                          cwd=str(ROOT))


def suite_names(suite):
    tree = ast.parse((BLENDER_TESTS / f"{suite}.py").read_text())
    return [n.name for n in tree.body if isinstance(n, ast.FunctionDef) and n.name.startswith("test_")]


_results = {}


def suite_results(host, suite, tmp_root):
    key = (host, suite)
    if key not in _results:
        tmp = tmp_root / f"{host}-{suite}"
        tmp.mkdir(parents=True, exist_ok=True)
        proc = run_host(host, BLENDER_TESTS / "runner.py", [suite], host_env({"OPDEFORM_TEST_TMP": str(tmp)}))
        records = {}
        for line in proc.stdout.splitlines():
            if line.startswith("OPDEFORM_TEST "):
                rec = json.loads(line[len("OPDEFORM_TEST "):])
                records[rec["name"]] = rec
        _results[key] = (proc, records, tmp)
    return _results[key]


def check_suite_test(host, suite, name, tmp):
    """One test of a Blender suite in one host: skipped where the host is missing, else it must report ok."""
    why = host_missing(host)
    if why:
        pytest.skip(why)
    proc, records, _ = suite_results(host, suite, tmp)
    rec = records.get(name)
    assert rec is not None, f"{name} did not report (exit {proc.returncode}):\n{proc.stdout[-4000:]}\n" \
                            f"{proc.stderr[-4000:]}"
    assert rec["ok"], f"[{rec['host']}] {rec['error']}"


@pytest.fixture(scope="session")
def host_tmp(tmp_path_factory):
    return tmp_path_factory.mktemp("addon")


@pytest.mark.parametrize("host", HOSTS)
@pytest.mark.parametrize("name", suite_names("suite_addon"))
def test_addon_in_blender(host, name, host_tmp):
    check_suite_test(host, "suite_addon", name, host_tmp)


@pytest.mark.parametrize("host", HOSTS)
def test_mesh_cache_without_addon(host, host_tmp):
    """A .blend baked with the add-on renders its frames with the add-on absent: the Mesh Cache modifier alone
    reproduces every baked frame exactly (a render farm needs neither the add-on nor opdeform)."""
    why = host_missing(host)
    if why:
        pytest.skip(why)
    _, records, tmp = suite_results(host, "suite_addon", host_tmp)
    assert records.get("test_bake_for_other_process", {}).get("ok"), "the baking test failed"
    proc = run_host(host, BLENDER_TESTS / "check_meshcache.py", [str(tmp / "other.blend"), "Bar"],
                    host_env(with_module=False))
    assert proc.returncode == 0 and "MESHCACHE_OK" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-3000:]
