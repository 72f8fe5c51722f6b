"""pytest set-up: the package comes from the meson build tree (scripts/test sets PYTHONPATH to
<build>/python); fail early with a clear message when it is missing. The session fixtures of the packages."""

import importlib.util
import zipfile

import pytest

if importlib.util.find_spec("opdeform") is None:
    raise RuntimeError("opdeform is not importable: run scripts/test, or scripts/build and set "
                       "PYTHONPATH=build/python")


# scripts/package's outputs and the Linux wheel's run of the core's tests, made once a session for
# tests/test_addon_package.py and tests/test_platforms.py (imported late: under Windows' CPython, which runs
# the wheel's tests, neither is used)
@pytest.fixture(scope="session")
def packages(tmp_path_factory):
    from test_addon_package import build_packages
    return build_packages(tmp_path_factory.mktemp("dist"))


@pytest.fixture(scope="session")
def wheel_dir(packages, tmp_path_factory):
    """The Linux wheel unpacked, as pip would install it."""
    where = tmp_path_factory.mktemp("wheel")
    with zipfile.ZipFile(packages["wheel"]) as z:
        z.extractall(where)
    return where


@pytest.fixture(scope="session")
def linux_wheel_tests(wheel_dir, tmp_path_factory):
    """(the finished process, its JUnit XML): test_addon_package.WHEEL_TESTS against the Linux wheel."""
    from test_addon_package import run_linux_wheel_tests
    junit = tmp_path_factory.mktemp("linux-wheel-tests") / "junit.xml"
    return run_linux_wheel_tests(wheel_dir, junit), junit
