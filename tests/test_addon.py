"""The Blender add-on (addon/opdeform_blender), tested inside Debian's Blender (``blender -b``) and inside the
newest ``bpy`` module from PyPI that installs here (scripts/setup-bpy puts it in its own venv); the other bpy
modules of the matrix (SMOKE_HOSTS: 4.2 LTS, 5.0) run a lighter smoke test (SMOKE, test_addon_smoke below).

Each host runs tests/blender/suite_addon.py once (tests/blender/runner.py prints one result line per test);
every test there is one pytest test here, per host. The compiled module reaches Blender through
$OPDEFORM_PYTHONPATH = the folder scripts/test puts on PYTHONPATH (<build>/python).

Hosts: "blender" (Debian's 3.4.1), "bpy" (the full suites: $OPDEFORM_BPY_VENV, else the newest venv of
scripts/setup-bpy), "bpy-X.Y" (the venv of bpy X.Y). A host that is not installed skips, saying why; under CI
($CI set) a bpy of the matrix must be installed unless scripts/setup-bpy recorded why it skipped it
(~/.cache/opdeform/bpy-X.Y.skipped): CI cannot pass with a host silently missing."""

import ast
import json
import os
import resource
import shutil
import subprocess
from pathlib import Path

import pytest

import opdeform

ROOT = Path(__file__).resolve().parent.parent
BLENDER_TESTS = ROOT / "tests" / "blender"
CACHE = Path.home() / ".cache" / "opdeform"
BPY_VERSIONS = ("4.2", "5.0", "5.2")  # scripts/setup-bpy's matrix, oldest first


def bpy_venv(version):
    return CACHE / f"bpy-{version}-venv"


def _newest_venv():
    found = [bpy_venv(v) for v in reversed(BPY_VERSIONS) if (bpy_venv(v) / "bin" / "python").exists()]
    return found[0] if found else bpy_venv(BPY_VERSIONS[-1])


BPY_VENV = Path(os.environ.get("OPDEFORM_BPY_VENV") or _newest_venv())
BPY_PYTHON = BPY_VENV / "bin" / "python"
HOSTS = ("blender", "bpy")
# the matrix's other bpy modules: the smoke test (SMOKE) and the regression renders, not the full suites
SMOKE_HOSTS = tuple(f"bpy-{v}" for v in BPY_VERSIONS if bpy_venv(v).resolve() != BPY_VENV.resolve())
# the smoke test in SMOKE_HOSTS: registration, the main path (build, play, bake, free, re-bake; bake equals
# playback), save and reload, every panel drawn, a goal with a Subdivision after OPDeform, a tumbling bake
SMOKE = {"suite_addon": ("test_register_unregister_twice", "test_build_play_bake_free_rebake",
                         "test_bake_equals_playback", "test_save_reload_continues", "test_panels_draw_in_every_state"),
         "suite_goals": ("test_subdivision_after_opdeform_plays_live",),
         "suite_tumbling": ("test_bake_plays_frames_with_orientation_and_instances",)}
# OPDEFORM_FULL_MATRIX=1 (scripts/test --long): SMOKE_HOSTS run every test of the suites instead
FULL_MATRIX = os.environ.get("OPDEFORM_FULL_MATRIX") == "1"
VMEM_BYTES = int(float(os.environ.get("OPDEFORM_BLENDER_VMEM_GB", "16")) * 2 ** 30)  # each Blender's ulimit -v


def build_python_dir():
    return str(Path(opdeform.__file__).resolve().parent.parent)


def host_python(host):
    """The interpreter of a bpy host."""
    return BPY_PYTHON if host == "bpy" else bpy_venv(host[4:]) / "bin" / "python"


def host_missing(host):
    """None when the host can run here, else why not. CI must have Debian's Blender, and every bpy of the matrix
    that scripts/setup-bpy did not skip with a recorded reason: there the test fails instead of skipping."""
    if host == "blender":
        if shutil.which("blender") is None:
            return None if os.environ.get("CI") else "Debian's blender is not installed (scripts/setup)"
        return None
    python = host_python(host)
    if python.exists():
        return None
    venv = python.parent.parent
    record = CACHE / (venv.name[:-len("-venv")] + ".skipped")
    if record.exists():
        return f"{host}: scripts/setup-bpy skipped it: {record.read_text().strip()}"
    if os.environ.get("CI"):
        pytest.fail(f"{host} is not installed ({venv}) and scripts/setup-bpy recorded no reason: CI must run it")
    return f"{host} is not installed ({venv}; scripts/setup-bpy)"


def _limit_memory():
    """ulimit -v for a Blender the tests start (never above a limit already set)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = VMEM_BYTES if hard == resource.RLIM_INFINITY else min(VMEM_BYTES, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))


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
        cmd = [str(host_python(host)), str(script), *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env or host_env(),
                          cwd=str(ROOT), preexec_fn=_limit_memory)


def suite_names(suite):
    tree = ast.parse((BLENDER_TESTS / f"{suite}.py").read_text())
    return [n.name for n in tree.body if isinstance(n, ast.FunctionDef) and n.name.startswith("test_")]


_results = {}


def suite_results(host, suite, tmp_root):
    key = (host, suite)
    if key not in _results:
        tmp = tmp_root / f"{host}-{suite}"
        tmp.mkdir(parents=True, exist_ok=True)
        names = list(SMOKE.get(suite, ())) if host in SMOKE_HOSTS and not FULL_MATRIX else []
        proc = run_host(host, BLENDER_TESTS / "runner.py", [suite, *names],
                        host_env({"OPDEFORM_TEST_TMP": str(tmp)}))
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


def _smoke_cases():
    suites = ("suite_addon", "suite_goals", "suite_tumbling", "suite_robustness") if FULL_MATRIX else SMOKE
    return [(suite, name) for suite in suites for name in (suite_names(suite) if FULL_MATRIX else SMOKE[suite])]


@pytest.mark.parametrize("host", SMOKE_HOSTS)
@pytest.mark.parametrize("suite,name", _smoke_cases())
def test_addon_smoke(host, suite, name, host_tmp):
    """The lighter matrix test: SMOKE's tests of the suites in the bpy modules that do not run them in full
    (every test of every suite with OPDEFORM_FULL_MATRIX=1)."""
    check_suite_test(host, suite, name, host_tmp)


def test_smoke_names_exist():
    for suite, names in SMOKE.items():
        assert set(names) <= set(suite_names(suite)), (suite, sorted(set(names) - set(suite_names(suite))))
