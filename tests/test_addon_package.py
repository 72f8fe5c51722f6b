"""scripts/package: the self-contained wheel (manylinux_2_28 tag, CHOLMOD linked in, OpenBLAS copied in by
auditwheel, glibc 2.28 symbols at most) runs with the system's CHOLMOD, BLAS and LAPACK hidden in a private
mount namespace; the extension (built by Blender's own builder, one zip per platform) lists that wheel and
passes Blender's validator in every bpy of the matrix (4.2 LTS, 5.0.1, 5.2 LTS); the legacy zip vendors the
wheel's files. The legacy zip installs and runs in Debian's Blender 3.4, the extension in each bpy: both build,
play and bake (the smoke test of bpy 4.2 and 5.0), and a damaged compiled module gives the panel message and
error reports. The packages leave the shape-matching baseline out and carry meson.build's version, which the
add-on's sources repeat. The wheel's module passes the core's physics tests."""

import ast
import glob
import io
import json
import os
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

from test_addon import BLENDER_TESTS, ROOT, host_env, host_missing, run_host

ADDON = ROOT / "addon" / "opdeform_blender"
BPY_VERSIONS = ("4.2", "5.0", "5.2")  # scripts/setup-bpy's venvs
CACHE = Path.home() / ".cache" / "opdeform"
GLIBC_MAX = (2, 28)  # manylinux_2_28: Blender's own baseline
# the cross-built wheels (scripts/package_platform.py): wheel tag -> Blender's platform, with "_" for "-"
PLATFORMS = {"win_amd64": "windows_x64", "macosx_11_0_arm64": "macos_arm64", "macosx_10_13_x86_64": "macos_x64"}
# What a machine without SuiteSparse lacks: CHOLMOD, its orderings, BLAS, LAPACK, the Fortran runtime
HIDDEN = re.compile(r"^lib(cholmod|amd|camd|colamd|ccolamd|suitesparseconfig|metis|blas|lapack|openblas|"
                    r"gfortran|quadmath)\b")


def bpy_python(version):
    return CACHE / f"bpy-{version}-venv" / "bin" / "python"


def blender_ext(version):
    """The command line of Blender's extension tool (blender --command extension) in that bpy, or None."""
    found = glob.glob(str(CACHE / f"bpy-{version}-venv/lib/python3*/site-packages/bpy/*/scripts/addons_core/"
                          "bl_pkg/cli/blender_ext.py"))
    return [str(bpy_python(version)), found[0]] if found else None


def build_packages(out):
    """scripts/package into out: kind ("wheel", "extension", "legacy", each also + " " + a PLATFORMS tag) -> path.
    tests/conftest.py's session fixture `packages` calls it once for this file and tests/test_platforms.py."""
    proc = subprocess.run([str(ROOT / "scripts" / "package"), str(out)], capture_output=True, text=True,
                          cwd=str(ROOT), timeout=1200)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    found = {"wheel": list(out.glob("opdeform-*manylinux*.whl")), "legacy": list(out.glob("*-legacy-linux_x64.zip")),
             "extension": list(out.glob("opdeform_blender-*[0-9]-linux_x64.zip"))}
    for tag, platform in PLATFORMS.items():
        found["wheel " + tag] = list(out.glob(f"opdeform-*-{tag}.whl"))
        found["extension " + tag] = list(out.glob(f"opdeform_blender-*[0-9]-{platform}.zip"))
        found["legacy " + tag] = list(out.glob(f"opdeform_blender-*-legacy-{platform}.zip"))
    assert all(len(paths) == 1 for paths in found.values()), (found, proc.stdout)
    assert len(list(out.iterdir())) == len(found), sorted(p.name for p in out.iterdir())
    return {kind: paths[0] for kind, paths in found.items()}


def meson_version():
    proc = subprocess.run(["meson", "introspect", "--projectinfo", str(ROOT / "meson.build")], capture_output=True,
                          text=True, check=True, timeout=60)
    return json.loads(proc.stdout)["version"]


def bl_info_version(source):
    """bl_info["version"] read the way Blender reads it: statically, without running the file."""
    for node in ast.parse(source).body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", None) == "bl_info":
            return ".".join(map(str, ast.literal_eval(node.value)["version"]))
    return None


def glibc_versions(path):
    """The GLIBC_x.y symbol versions a shared object needs."""
    out = subprocess.run(["objdump", "-T", str(path)], capture_output=True, text=True, check=True).stdout
    return {tuple(map(int, v.split("."))) for v in re.findall(r"\(GLIBC_([0-9.]+)\)", out)}


def dynamic_section(path):
    return subprocess.run(["readelf", "-d", str(path)], capture_output=True, text=True, check=True).stdout


def test_wheel_tag_and_contents(packages):
    name = packages["wheel"].name
    assert re.fullmatch(rf"opdeform-{re.escape(meson_version())}-cp311-abi3-(manylinux_2_\d+_x86_64\.)*"
                        r"manylinux_2_28_x86_64\.whl", name), name
    with zipfile.ZipFile(packages["wheel"]) as z:
        names = z.namelist()
    assert "opdeform/_core.abi3.so" in names and "opdeform/__init__.py" in names
    libs = [n for n in names if n.startswith("opdeform.libs/") and not n.endswith("/")]
    assert len(libs) == 1 and re.fullmatch(r"opdeform\.libs/libscipy_openblas-[0-9a-f]+\.so", libs[0]), libs
    assert not [n for n in names if "shape_matching" in n or "cholmod" in n.lower()], names


def test_wheel_needs_glibc_2_28_and_no_system_library(wheel_dir):
    core = wheel_dir / "opdeform" / "_core.abi3.so"
    objects = [core, *(wheel_dir / "opdeform.libs").iterdir()]
    for so in objects:
        versions = glibc_versions(so)
        assert versions and max(versions) <= GLIBC_MAX, (so.name, sorted(versions)[-3:])
    section = dynamic_section(core)
    needed = set(re.findall(r"\(NEEDED\).*\[(.+)\]", section))
    system = {"libc.so.6", "libm.so.6", "libpthread.so.0", "ld-linux-x86-64.so.2"}
    assert needed - system == {objects[1].name}, needed
    assert "$ORIGIN/../opdeform.libs" in section
    symbols = subprocess.run(["objdump", "-T", str(core)], capture_output=True, text=True, check=True).stdout
    assert "cholmod_factorize" not in symbols  # linked in, hidden: neither needed from nor offered to others
    # python/opdeform/_core.map: the module offers its init function only (not the C core's od_* functions)
    defined = subprocess.run(["nm", "-D", "--defined-only", str(core)], capture_output=True, text=True,
                             check=True).stdout
    assert [line.split()[-1] for line in defined.splitlines() if line.strip()] == ["PyInit__core"], defined


def hidden_libraries():
    """The real files of the system's SuiteSparse, BLAS, LAPACK and Fortran runtime (ldconfig's cache)."""
    cache = subprocess.run(["ldconfig", "-p"], capture_output=True, text=True, check=True).stdout
    found = re.findall(r"^\s*(\S+) \(.*x86-64.*\) => (\S+)$", cache, flags=re.M)
    return sorted({os.path.realpath(path) for name, path in found if HIDDEN.match(name)})


RUN_A_STEP = """
import ctypes, sys
import numpy as np
try:
    ctypes.CDLL("libcholmod.so.3")
    sys.exit("the system CHOLMOD is still visible")
except OSError as exc:
    print("hidden:", exc)
import opdeform
assert opdeform.__file__.startswith(sys.argv[1]), opdeform.__file__
n = 40
centers = np.c_[(np.arange(n) + 0.5) * 0.1, np.zeros(n), np.zeros(n)]
sim = opdeform.Simulation(opdeform.Graph(centers, np.tile([0.05, 0.1, 0.1], (n, 1)),
                                         np.c_[np.arange(n - 1), np.arange(1, n)]), stiffness=1e9)
sim.add_position_constraint((0.0, 0.0, 0.0))
for factorization, threads in (("simplicial", 1), ("supernodal", 2)):  # AMD; METIS ordering and OpenBLAS
    sim.set_solver(threads=threads, factorization=factorization)
    sim.step(5)
tip = sim.positions[-1]
assert np.all(np.isfinite(tip)) and tip[2] < -0.01, tip
print("STEP_OK", tip, sim.counters["factorizations"])
"""


def test_wheel_runs_with_the_system_cholmod_hidden(wheel_dir):
    """In a private mount namespace, /dev/null is bind-mounted over every file of the system's SuiteSparse,
    BLAS and LAPACK (dlopen of libcholmod.so.3 then fails, which the child checks); the unpacked wheel still
    imports and simulates with both of CHOLMOD's paths."""
    if shutil.which("unshare") is None or subprocess.run(["unshare", "-m", "true"]).returncode != 0:
        pytest.skip("no private mount namespace here (unshare -m needs root or user namespaces)")
    hide = hidden_libraries()
    assert any("libcholmod" in p for p in hide), "the system CHOLMOD is not installed: nothing to hide"
    script = 'for f in "${@:3}"; do mount --bind /dev/null "$f" || exit 3; done; exec "$1" -c "$2" "$0"'
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LD_LIBRARY_PATH", "LD_PRELOAD")}
    env["PYTHONPATH"] = str(wheel_dir)
    proc = subprocess.run(["unshare", "-m", "bash", "-c", script, str(wheel_dir), sys.executable, RUN_A_STEP,
                           *hide], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0 and "STEP_OK" in proc.stdout, proc.stdout + proc.stderr
    assert "hidden:" in proc.stdout


# The core's tests, run again on the wheel's module: it is compiled by another compiler (zig's clang, for glibc
# 2.28) than the build tree's (gcc), which read undefined behaviour otherwise: every mesh collider's distances
# were wrong in the shipped add-on, one axis of its samples cut to the mesh's origin (2026-11-24; docs/packaging.md).
# Every test that needs neither Blender nor the build tree; the wheel leaves the shape-matching baseline out.
WHEEL_TESTS = ("test_acceleration.py", "test_api_edges.py", "test_arguments.py", "test_batch.py",
               "test_body_contact.py", "test_busy.py", "test_contact.py", "test_core.py", "test_features.py",
               "test_forces.py", "test_fork.py", "test_goals.py", "test_interrupt.py", "test_io.py",
               "test_loose_parts.py", "test_mesh_graph.py", "test_mpm.py", "test_pickle.py", "test_properties.py",
               "test_settings.py", "test_shot.py", "test_skinning.py", "test_soak.py", "test_stability.py",
               "test_threads.py")
WHEEL_LEAVES_OUT = "test_interrupt.py::test_ctrl_c_stops_shape_matching"


def wheel_tests(python, junit, names=None):
    """The command line that runs WHEEL_TESTS (or those names) in `python` (a list), writing pytest's JUnit XML
    to junit."""
    return [*python, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={junit}", "--deselect",
            "tests/" + WHEEL_LEAVES_OUT, *("tests/" + name for name in names or WHEEL_TESTS)]


def run_linux_wheel_tests(wheel_dir, junit):
    """WHEEL_TESTS against the unpacked wheel: the finished process (its JUnit XML in junit). Run once a session
    (tests/conftest.py's fixture `linux_wheel_tests`): tests/test_platforms.py compares Windows' outcomes to it."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LD_LIBRARY_PATH", "LD_PRELOAD")}
    env["PYTHONPATH"] = str(wheel_dir)
    where = subprocess.run([sys.executable, "-c", "import opdeform; print(opdeform.__file__)"], capture_output=True,
                           text=True, env=env, timeout=60)
    assert where.stdout.startswith(str(wheel_dir)), where.stdout + where.stderr
    return subprocess.run(wheel_tests([sys.executable], junit), capture_output=True, text=True, env=env,
                          timeout=900, cwd=str(ROOT))


def test_the_wheel_passes_the_core_physics_tests(linux_wheel_tests):
    proc, _ = linux_wheel_tests
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]


def test_legacy_zip_vendors_the_wheel(packages):
    with zipfile.ZipFile(packages["wheel"]) as w, zipfile.ZipFile(packages["legacy"]) as z:
        names = set(z.namelist())
        assert {"opdeform_blender/__init__.py", "opdeform_blender/vendor/__init__.py"} <= names
        assert "bl_info" in z.read("opdeform_blender/__init__.py").decode()
        for name in w.namelist():
            if not name.startswith("opdeform-") and not name.endswith("/"):  # the package's files, no .dist-info
                assert z.read("opdeform_blender/vendor/" + name) == w.read(name), name


def test_legacy_zip_names_its_folders(packages):
    """Blender's Install removes an installed add-on's folder before extracting only when the zip has an entry
    for it (bl_operators/userpref.py: root names, found without a path separator); without one it extracted the
    files over the loaded compiled module (Blender 3.4: a bus error on Install again)."""
    with zipfile.ZipFile(packages["legacy"]) as z:
        names = z.namelist()
    assert [n for n in names if os.sep not in os.path.normpath(n)] == ["opdeform_blender/"]
    for name in names:
        parent = name.rstrip("/").rpartition("/")[0]
        assert not parent or parent + "/" in names, name


def test_extension_lists_the_wheel(packages):
    wheel = packages["wheel"].name
    with zipfile.ZipFile(packages["extension"]) as z:
        names = set(z.namelist())
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
        assert z.read("wheels/" + wheel) == packages["wheel"].read_bytes()
    generated = manifest["build"]["generated"]  # what Blender reads in a split build's zip
    assert generated["wheels"] == ["./wheels/" + wheel]
    assert generated["platforms"] == ["linux-x64"] and manifest["license"] == ["SPDX:GPL-3.0-or-later"]
    assert manifest["id"] == "opdeform_blender" and len(manifest["permissions"]["files"]) <= 64
    assert "__init__.py" in names and not [n for n in names if "vendor/" in n or "__pycache__" in n]


@pytest.mark.parametrize("target", ["source", "extension", *(f"extension {tag}" for tag in PLATFORMS)])
@pytest.mark.parametrize("version", BPY_VERSIONS)
def test_blender_validator(packages, version, target):
    """`blender --command extension validate` of that bpy accepts the add-on's source folder and each platform's
    zip (linux-x64, windows-x64, macos-arm64, macos-x64)."""
    why = host_missing(f"bpy-{version}")  # under CI, fails when the set-up installed it without saying why not
    if why:
        pytest.skip(why)
    ext = blender_ext(version)
    assert ext is not None, f"bpy {version} has no blender_ext.py (bl_pkg)"
    path = ADDON if target == "source" else packages[target]
    proc = subprocess.run([*ext, "validate", str(path)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "Success" in proc.stdout, proc.stdout + proc.stderr


def test_packages_leave_the_baseline_out(packages):
    with zipfile.ZipFile(packages["wheel"]) as z:
        assert b"ShapeMatching" not in z.read("opdeform/_core.abi3.so")
    with zipfile.ZipFile(packages["legacy"]) as z:
        assert not [n for n in z.namelist() if "shape_matching" in n]


def test_versions_are_meson_builds(packages):
    """meson.build's project(version:) is the version: the add-on's bl_info and manifest repeat it (Blender
    reads both statically), and the packages are named and stamped with it."""
    version = meson_version()
    assert bl_info_version((ADDON / "__init__.py").read_text()) == version
    assert tomllib.loads((ADDON / "blender_manifest.toml").read_text())["version"] == version
    for kind, suffix, prefix in (("legacy", "legacy-linux_x64", "opdeform_blender/"), ("extension", "linux_x64", "")):
        assert packages[kind].name == f"opdeform_blender-{version}-{suffix}.zip"
        with zipfile.ZipFile(packages[kind]) as z:
            assert bl_info_version(z.read(prefix + "__init__.py").decode()) == version
            assert tomllib.loads(z.read(prefix + "blender_manifest.toml").decode())["version"] == version


def _rewrite_zip(src, out, change):
    """A copy of the zip src (a path or a file object) with change(name, data) applied to every member."""
    with zipfile.ZipFile(src) as z, zipfile.ZipFile(out, "w") as dst:
        for item in z.infolist():
            dst.writestr(item, change(item.filename, z.read(item)))


def _broken_copy(path, tmp_path):
    """The same package whose compiled module cannot load (wrong bytes: another platform, a bad copy); in the
    extension, inside its wheel."""

    def change(name, data):
        if name.endswith("_core.abi3.so"):
            return b"\x7fELF not really a shared object"
        if name.endswith(".whl"):
            buffer = io.BytesIO()
            _rewrite_zip(io.BytesIO(data), buffer, change)
            return buffer.getvalue()
        return data

    out = tmp_path / path.name
    _rewrite_zip(path, out, change)
    return out


HOSTS = [("blender", "legacy")] + [(f"bpy-{v}", "extension") for v in BPY_VERSIONS]


@pytest.mark.parametrize("host,kind", HOSTS)
@pytest.mark.parametrize("expect", ["ok", "broken"])
def test_installs_and_runs(packages, host, kind, expect, tmp_path):
    """The smoke test: install the package into an empty user folder, enable, build, play, bake."""
    why = host_missing(host)  # "blender" or "bpy-X.Y"; under CI a host the set-up installs must be there
    if why:
        pytest.skip(why)
    zip_path = packages[kind] if expect == "ok" else _broken_copy(packages[kind], tmp_path)
    user = tmp_path / "user"
    (user / "config").mkdir(parents=True)
    env = host_env({"BLENDER_USER_SCRIPTS": str(user), "BLENDER_USER_RESOURCES": str(user),
                    "BLENDER_USER_CONFIG": str(user / "config")}, with_module=False)
    args = [str(zip_path), kind, expect]
    if host == "blender":
        proc = run_host(host, BLENDER_TESTS / "check_package.py", args, env)
    else:
        proc = subprocess.run([str(bpy_python(host[4:])), str(BLENDER_TESTS / "check_package.py"), *args],
                              capture_output=True, text=True, timeout=600, env=env, cwd=str(ROOT))
    assert f"PACKAGE_OK {kind} {expect}" in proc.stdout, proc.stdout[-4000:] + proc.stderr[-4000:]
    # every host exits cleanly, bpy 4.2 included (it crashed at exit before the add-on kept its modules
    # alive for Python's finalization: __init__.py _keep_modules_alive)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
