"""The same compiled module (one abi3 binary) imports and runs inside Debian's Blender (Python 3.11)."""

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import opdeform

BLENDER = shutil.which("blender")


@pytest.mark.skipif(BLENDER is None and not os.environ.get("CI"), reason="Blender is not installed here")
def test_module_imports_inside_blender(tmp_path):
    assert BLENDER, "Blender is required in CI (scripts/setup installs Debian's blender)"
    tree = Path(opdeform.__file__).parent.parent
    script = tmp_path / "inside_blender.py"
    script.write_text(textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(tree)!r})
        import bpy, opdeform
        from opdeform import scenes
        sim = scenes.fig1_bar()
        sim.step(30)
        print("OPDEFORM", bpy.app.version_string, sys.version_info[:2], opdeform._core.__file__, scenes.tip_sag(sim))
    """))
    wrapper = Path(__file__).resolve().parent.parent / "scripts" / "blender"
    result = subprocess.run([str(wrapper), "-b", "--factory-startup", "--python-exit-code", "1", "-P", str(script)],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    line = next(l for l in result.stdout.splitlines() if l.startswith("OPDEFORM"))
    assert ".abi3.so" in line and str(tree) in line
    assert float(line.split()[-1]) > 0.0  # the bar sagged inside Blender too
    assert sys.version_info[:2] >= (3, 11)
