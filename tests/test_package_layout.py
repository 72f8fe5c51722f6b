"""The package's layout (issue 11): __init__ only re-exports, no module imports the package's __init__, the
intra-package imports (function-level ones included) form no cycle, and the version is defined once."""

import ast
import re
from pathlib import Path

import opdeform

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "python" / "opdeform"


def _modules():
    """module name -> parsed tree, for every .py file of the package."""
    return {path.stem: ast.parse(path.read_text(), str(path)) for path in sorted(PACKAGE.glob("*.py"))}


def _imports(tree, names):
    """(line, target) for every import of the package inside tree: target is a module of `names` (or _core),
    or "__init__" when a name is taken from the package itself."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.level == 1 or (node.module or "").split(".")[0] == "opdeform"):
            module = node.module if node.level == 1 else node.module.partition(".")[2]
            if module:
                found.append((node.lineno, module))
            else:  # from . import x: a submodule, or a name of __init__
                found += [(node.lineno, a.name if a.name in names else "__init__") for a in node.names]
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name.partition(".")[2] or "__init__") for a in node.names
                      if a.name.split(".")[0] == "opdeform"]
    return found


def test_no_module_imports_the_package_init():
    modules = _modules()
    names = set(modules) | {"_core"}
    bad = [f"{name}.py:{line}" for name, tree in modules.items() if name != "__init__"
           for line, target in _imports(tree, names) if target == "__init__"]
    assert not bad, f"imports from the package __init__: {bad}"


def test_intra_package_imports_have_no_cycle():
    modules = _modules()
    names = set(modules) | {"_core"}
    graph = {name: {t for _, t in _imports(tree, names)} for name, tree in modules.items()}
    unknown = {t for targets in graph.values() for t in targets} - names
    assert not unknown, f"imports of modules that are not in the package: {unknown}"
    state = {}

    def visit(name, path):
        state[name] = "open"
        for target in sorted(graph.get(name, ())):
            assert state.get(target) != "open", "import cycle: " + " -> ".join(path + [target])
            if target not in state:
                visit(target, path + [target])
        state[name] = "done"

    for name in graph:
        if name not in state:
            visit(name, [name])


def test_init_only_reexports():
    tree = _modules()["__init__"]
    allowed = (ast.Import, ast.ImportFrom, ast.Assign, ast.If, ast.Expr)
    assert all(isinstance(node, allowed) for node in tree.body), "__init__.py defines more than re-exports"
    assigned = {t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets}
    assert assigned <= {"__all__", "__version__"}


def test_public_names_stay():
    for name in opdeform.__all__ + ["__version__"]:
        assert hasattr(opdeform, name), name
    from opdeform import io, mesh, meshes, mpm, mpm_scenes, scenes  # noqa: F401

    assert opdeform.mesh.graph_from_mesh and opdeform.Graph.__module__ == "opdeform.graph"


def test_version_is_defined_once_in_meson_build():
    version = re.search(r"project\([^)]*?version:\s*'([^']+)'", (ROOT / "meson.build").read_text(), re.S).group(1)
    assert opdeform.__version__ == version
    assert not re.search(r"(?m)^version\s*=", (ROOT / "pyproject.toml").read_text())
    assert version not in (PACKAGE / "_core.c").read_text()
