"""scripts/architecture --check on the three parts (docs/architecture.md): the real tree passes, and a copy with
a planted fault fails naming it: an import cycle (a function-level import too) or an upward import in the
add-on's blender/, a module in no layer, core/ importing blender/, a cycle and an __init__ that does more than
re-export in the package, a call cycle between the C core's modules (and not a call named in a comment or a
string)."""
import json
import os
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "scripts", "architecture")
FOLDERS = {"csrc": "csrc", "package": "python/opdeform", "addon": "addon/opdeform_blender"}


def check(*args):
    run = subprocess.run([sys.executable, SCRIPT, "--check", *args], capture_output=True, text=True)
    return run.returncode, run.stdout + run.stderr


def analysis(part, root=ROOT):
    out = subprocess.run([sys.executable, SCRIPT, "--json", "--part", part, "--root", str(root)],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out)[part]


def copy(tmp_path, part):
    """A copy of one part and docs/architecture.md under tmp_path, as --root reads it."""
    shutil.copytree(os.path.join(ROOT, FOLDERS[part]), tmp_path / FOLDERS[part],
                    ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "docs").mkdir()
    shutil.copy(os.path.join(ROOT, "docs", "architecture.md"), tmp_path / "docs")
    return tmp_path


def append(path, text):
    with open(path, "a") as f:
        f.write(text)


def test_real_tree_passes():
    rc, out = check()
    assert rc == 0, out


def test_an_untouched_copy_passes(tmp_path):
    for part in FOLDERS:
        rc, out = check("--root", str(copy(tmp_path / part, part)), "--part", part)
        assert rc == 0, out


def _lowest_and_importers(root):
    """The add-on's lowest module of blender/ and the modules that import it."""
    result = analysis("addon", root)
    lowest = "blender." + result["layers"][0][1][0]
    return lowest, sorted(a for a, b in result["edges"] if b == lowest and a.startswith("blender."))


def test_addon_function_level_import_cycle_fails(tmp_path):
    root = copy(tmp_path, "addon")
    lowest, importers = _lowest_and_importers(root)
    assert importers, "nothing imports the lowest module: pick another way to close a cycle"
    higher = importers[0]
    append(root / FOLDERS["addon"] / (lowest.replace(".", "/") + ".py"),
           f"\n\ndef _planted():\n    from . import {higher.split('.')[-1]}  # noqa: F401\n")
    rc, out = check("--root", str(root), "--part", "addon")
    assert rc == 1
    assert f"{lowest} imports {higher}, from a higher layer" in out, out
    assert any("import cycle" in line and lowest in line and higher in line for line in out.splitlines()), out


def _reaches(edges, start, goal):
    seen, todo = set(), [start]
    while todo:
        node = todo.pop()
        seen.add(node)
        todo += [b for a, b in edges if a == node and b not in seen]
    return goal in seen


def test_addon_upward_import_fails(tmp_path):
    root = copy(tmp_path, "addon")
    result = analysis("addon", root)
    lowest = "blender." + result["layers"][0][1][0]
    higher = ["blender." + m for _, members in result["layers"][1:] for m in members]
    # a higher module that does not lead back to the lowest: upward, but no cycle
    target = next(m for m in reversed(higher) if not _reaches(result["edges"], m, lowest))
    append(root / FOLDERS["addon"] / (lowest.replace(".", "/") + ".py"),
           f"\nfrom . import {target.split('.')[-1]}  # noqa: E402,F401\n")
    rc, out = check("--root", str(root), "--part", "addon")
    assert rc == 1 and f"{lowest} imports {target}, from a higher layer" in out, out
    assert "import cycle" not in out, out


def test_addon_module_in_no_layer_and_core_importing_blender_fail(tmp_path):
    root = copy(tmp_path, "addon")
    addon = root / FOLDERS["addon"]
    (addon / "blender" / "planted.py").write_text('"""A module no layer lists."""\n')
    append(addon / "core" / "frames.py", "\n\ndef _planted():\n    from ..blender import planted  # noqa: F401\n")
    rc, out = check("--root", str(root), "--part", "addon")
    assert rc == 1
    assert "blender.planted is in no layer" in out, out
    assert "core.frames imports blender.planted: core/ is below blender/" in out, out


def test_addon_module_in_two_layers_and_a_layer_of_a_missing_module_fail(tmp_path):
    root = copy(tmp_path, "addon")
    layers = analysis("addon", root)["layers"]
    lowest = layers[0][1][0]
    planted = tuple((name, tuple(members)) for name, members in layers) + (("extra", (lowest, "ghost")),)
    (root / FOLDERS["addon"] / "blender" / "__init__.py").write_text(f'"""Planted layers."""\nLAYERS = {planted!r}\n')
    rc, out = check("--root", str(root), "--part", "addon")
    assert rc == 1
    assert f"blender.{lowest} is in two layers ({layers[0][0]} and extra)" in out, out
    assert "layer extra lists blender.ghost, which is not a module" in out, out


def test_package_cycle_and_more_than_reexports_fail(tmp_path):
    root = copy(tmp_path, "package")
    package = root / FOLDERS["package"]
    append(package / "graph.py", "\n\ndef _planted():\n    from . import simulation  # noqa: F401\n")
    append(package / "__init__.py", "\n\ndef planted():\n    return 0\n")
    append(package / "io.py", "\n\ndef _planted_init():\n    from . import Graph  # noqa: F401\n")
    rc, out = check("--root", str(root), "--part", "package")
    assert rc == 1
    assert "graph imports simulation, from its own layer, listed after it" in out, out
    assert any("import cycle" in line and "graph -> simulation" in line for line in out.splitlines()), out
    assert "__init__.py defines more than re-exports" in out, out
    assert "io imports its own package's __init__" in out, out


def test_c_call_cycle_fails(tmp_path):
    root = copy(tmp_path, "csrc")
    step = root / "csrc" / "arap" / "step.c"
    # named in a comment, a string and a static function of its own: not calls of body_contact.c
    append(step, '\n// od_BodyContact_Step(s, sims, 1, def)\nstatic const char* od_Planted(void)\n{\n'
                 '\treturn "od_BodyContact_Step(";\n}\n')
    rc, out = check("--root", str(root), "--part", "csrc")
    assert rc == 0, out
    append(step, "\nod_Status od_PlantedStep(od_Sim* sim)\n{\n"
                 "\treturn od_BodyContact_Step(&sim->selfPairs, &sim, 1, &sim->selfDef);\n}\n")
    rc, out = check("--root", str(root), "--part", "csrc")
    assert rc == 1
    assert "csrc: call cycle:" in out and "arap/step -> arap/body_contact (od_BodyContact_Step)" in out, out


def test_stale_docs_fail(tmp_path):
    root = copy(tmp_path, "package")
    (root / FOLDERS["package"] / "goals.py").write_text(
        '"""A new first sentence."""\n' + (root / FOLDERS["package"] / "goals.py").read_text())
    rc, out = check("--root", str(root), "--part", "package")
    assert rc == 1 and "docs/architecture.md is stale" in out, out
