"""Python packaging conventions: every public name of opdeform (and each public method and property of its
classes) has a docstring that help() shows; the type stubs (_core.pyi, py.typed) ship beside the compiled
module, name everything it defines and match the binding's argument parsing (scripts/stubs); the sdist leaves
the fuzz corpus and the test and documentation artefacts out, its description stands alone (no links), and
`pip install` of it builds no C tests and prints no warning."""

import importlib.machinery
import importlib.util
import inspect
import re
import subprocess
import tarfile
from pathlib import Path

import pytest

import opdeform
import opdeform._core as core

ROOT = Path(__file__).resolve().parent.parent
TOOLS = Path.home() / ".cache" / "opdeform" / "package-venv" / "bin" / "python"  # scripts/setup-package


def public_members(cls):
    return {n: v for n, v in vars(cls).items() if not n.startswith("_") and (callable(v) or isinstance(v, property))}


def test_every_public_name_has_a_docstring():
    missing = []
    for name in opdeform.__all__:
        obj = getattr(opdeform, name)
        if not (obj.__doc__ or "").strip() or (inspect.isclass(obj) and obj.__doc__ == type.__doc__):
            missing.append(name)
        if inspect.isclass(obj):
            missing += [f"{name}.{n}" for n, v in public_members(obj).items() if not (v.__doc__ or "").strip()]
    assert not missing, missing


def exported_symbols(path):
    """The dynamic symbols a shared object defines (nm -D --defined-only)."""
    out = subprocess.run(["nm", "-D", "--defined-only", str(path)], capture_output=True, text=True, check=True).stdout
    return sorted(line.split()[-1] for line in out.splitlines() if line.strip())


def test_compiled_module_exports_only_its_init():
    """python/opdeform/_core.map: the C core's od_* functions, linked in from static libraries, stay local."""
    assert exported_symbols(core.__file__) == ["PyInit__core"]


def test_stubs_ship_and_name_the_compiled_module():
    folder = Path(core.__file__).parent
    assert (folder / "py.typed").exists()
    stub = (folder / "_core.pyi").read_text()
    for name in (n for n in dir(core) if not n.startswith("_")):
        assert re.search(rf"^((class|def) {name}\b|{name}: )", stub, flags=re.M), name
        obj = getattr(core, name)
        if isinstance(obj, type) and not issubclass(obj, BaseException):
            block = stub.split(f"class {name}", 1)[1].split("\nclass ", 1)[0]
            for member in (n for n in vars(obj) if not n.startswith("_")):
                assert f"def {member}(" in block, f"{name}.{member}"


def stubs_checker():
    """scripts/stubs as a module: it checks _core.pyi against the binding's argument parsing."""
    loader = importlib.machinery.SourceFileLoader("stubs_checker", str(ROOT / "scripts" / "stubs"))
    module = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name, loader))
    loader.exec_module(module)
    return module


# A mistake each, planted in a copy of the stub: (the text replaced, its replacement, the name reported)
STUB_MISTAKES = [
    ("def step(self, steps: int, /) -> None: ...\n    # steps,",
     "def step(self, steps: float, /) -> None: ...\n    # steps,", "Simulation.step: steps: float"),
    ("def set_floor(self, height: float, friction: float, /) -> None: ...\n    def set_goal_",
     "def set_floor(self, height: float, /) -> None: ...\n    def set_goal_", "Simulation.set_floor: 1 parameters"),
    ("def read_pairs(self, pairs: Buffer, forces: Buffer, /)", "def read_pairs(self, pairs: Buffer, forces: Buffer)",
     "ContactGroup.read_pairs: not positional-only"),
    ('threads: int = ...) -> "Skin"', 'thread: int = ...) -> "Skin"', "Skin.__new__: parameters"),
    ("    def trace_length(self) -> int: ...\n", "", "Simulation.trace_length: not in _core.pyi")]


def test_stubs_match_the_bindings_argument_parsing():
    checker = stubs_checker()
    problems, count = checker.check()
    assert not problems and count > 90, problems
    text = (ROOT / "python" / "opdeform" / "_core.pyi").read_text()
    for old, new, reported in STUB_MISTAKES:
        assert text.count(old) == 1, old
        problems, _ = checker.check(text.replace(old, new))
        assert len(problems) == 1 and problems[0].startswith(reported), (reported, problems)


@pytest.fixture(scope="module")
def sdist(tmp_path_factory):
    if not TOOLS.exists():
        pytest.skip("the packaging venv is missing (scripts/setup-package)")
    out = tmp_path_factory.mktemp("sdist")
    proc = subprocess.run([str(TOOLS), "-c", f"import mesonpy; print(mesonpy.build_sdist({str(out)!r}))"],
                          cwd=str(ROOT), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out / proc.stdout.split()[-1]


def test_sdist_leaves_artefacts_out_and_describes_itself(sdist):
    with tarfile.open(sdist) as tar:
        names = tar.getnames()
        info = tar.extractfile(next(n for n in names if n.endswith("/PKG-INFO"))).read().decode()
    assert any(n.endswith("/csrc/arap/global_solve.c") for n in names)
    for left_out in ("/tests/fuzz/corpus/", "/tests/reference/", "/docs/images/"):
        assert not [n for n in names if left_out in n], left_out
    assert not [n for n in names if re.match(r"[^/]+/(build[^/]*|dist|out)/", n)]  # no build outputs
    description = info.split("\n\n", 1)[1]
    assert description.strip() == (ROOT / "docs" / "pypi.md").read_text().strip()
    assert "](" not in description and "http" not in description  # no links, relative or not


def test_pip_install_builds_no_tests_and_prints_no_warning(sdist, tmp_path):
    build = tmp_path / "build"
    proc = subprocess.run([str(TOOLS), "-m", "pip", "install", "--no-deps", "--no-build-isolation",
                           "--disable-pip-version-check", "--target", str(tmp_path / "site"),
                           f"-Cbuild-dir={build}", str(sdist)], capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert not re.search(r"warning", proc.stdout + proc.stderr, flags=re.I), proc.stdout + proc.stderr
    assert (tmp_path / "site" / "opdeform" / "_core.abi3.so").exists()
    assert (build / "build.ninja").exists() and not list(build.rglob("test_core*")), "the C tests were built"
