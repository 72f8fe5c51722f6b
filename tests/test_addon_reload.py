"""A script reload (F8) reloads every module of the add-on: the add-on's MODULES lists every .py file of
addon/opdeform_blender, each after the add-on modules it imports at load time; and in Blender (3.4 and the bpy
module), tests/blender/check_reload.py changes every file of an installed copy, reloads the scripts the way
``bpy.ops.script.reload`` does and checks that every change was picked up and that the add-on still works."""

import ast
import shutil
import sys

import pytest

from test_addon import BLENDER_TESTS, HOSTS, ROOT, host_env, host_missing, run_host

PACKAGE = ROOT / "addon" / "opdeform_blender"
sys.path.insert(0, str(PACKAGE.parent))

import opdeform_blender  # noqa: E402  (outside Blender: MODULES only, nothing registered)


def _path(name):
    """The file of an add-on module named relative to the package ("core.loader"; "" is the package)."""
    path = PACKAGE.joinpath(*name.split(".")) if name else PACKAGE
    return path / "__init__.py" if path.is_dir() else path.with_suffix(".py")


def _module_names():
    """Every module of the add-on, named relative to the package."""
    out = set()
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        out.add(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return out


def _imported_at_load(name):
    """The add-on modules that module `name` imports at its top level (relative imports)."""
    path, modules = _path(name), _module_names()
    parts = name.split(".") if name else []
    package = parts if path.name == "__init__.py" else parts[:-1]
    found = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.ImportFrom) and node.level:
            base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else []))
            found.add(base)
            found.update(m for m in (f"{base}.{a.name}".lstrip(".") for a in node.names) if m in modules)
    return found - {""}


def test_reload_list_covers_every_module_in_dependency_order():
    listed = opdeform_blender.MODULES
    assert len(set(listed)) == len(listed), listed
    assert set(listed) == _module_names() - {""}, "MODULES must list every .py file of the add-on"
    for i, name in enumerate(listed):
        late = _imported_at_load(name) - set(listed[:i])
        assert not late, f"{name} imports {sorted(late)} at load time: list them before it in MODULES"


@pytest.mark.parametrize("host", HOSTS)
def test_script_reload_keeps_the_addon_working(host, tmp_path):
    why = host_missing(host)
    if why:
        pytest.skip(why)
    user = tmp_path / "user"
    shutil.copytree(PACKAGE, user / "addons" / "opdeform_blender", ignore=shutil.ignore_patterns("__pycache__"))
    env = host_env({"BLENDER_USER_SCRIPTS": str(user), "BLENDER_USER_CONFIG": str(tmp_path / "config"),
                    "OPDEFORM_TEST_TMP": str(tmp_path / "tmp")})
    proc = run_host(host, BLENDER_TESTS / "check_reload.py", [str(tmp_path)], env, timeout=300)
    assert proc.returncode == 0 and "RELOAD_OK" in proc.stdout, proc.stdout[-4000:] + proc.stderr[-4000:]
