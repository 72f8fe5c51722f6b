"""The package's layout (issue 11): __init__ only re-exports, no module imports the package's __init__, the
intra-package imports (function-level ones included) form no cycle and go down its layers (scripts/architecture
checks those: tests/test_architecture.py plants each fault), the public names stay, and the version is defined
once."""

import re
import subprocess
import sys
from pathlib import Path

import opdeform

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "python" / "opdeform"


def test_layout_is_checked_by_scripts_architecture():
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "architecture"), "--check", "--part", "package"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


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
