"""scripts/render: the headless regression renders (Cycles CPU in Debian's Blender) match the reference images
and baked vertices kept in tests/reference/ within the tolerances render_scenes.py states."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import opdeform
from test_addon import ROOT


@pytest.mark.skipif(shutil.which("blender") is None and not os.environ.get("CI"), reason="no Blender here")
def test_regression_renders_match_references(tmp_path):
    build_dir = Path(opdeform.__file__).resolve().parent.parent.parent
    env = dict(os.environ, BUILD_DIR=str(build_dir), OPDEFORM_RENDER_NO_BUILD="1")
    env.pop("OPDEFORM_PYTHONPATH", None)
    proc = subprocess.run([str(ROOT / "scripts" / "render"), "--out", str(tmp_path)], capture_output=True,
                          text=True, env=env, cwd=str(ROOT), timeout=900)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert "within tolerance" in proc.stdout
    assert len(list(tmp_path.glob("*.png"))) == 6
