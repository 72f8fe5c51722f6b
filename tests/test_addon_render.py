"""scripts/render in every host of the matrix: the headless regression renders (Cycles CPU) match that Blender
version's reference images (tests/reference/<major.minor>/) and the baked vertices match the references shared
by every version (tests/reference/*_vertices.npz), within the tolerances render_scenes.py states.

Hosts: Debian's Blender 3.4.1 and the bpy modules of scripts/setup-bpy (4.2 LTS, 5.0.1, 5.2 LTS). A host that
is not installed skips, saying why; under CI a host that the set-up installs must run (test_addon.host_missing).
"""

import os
import subprocess
from pathlib import Path

import pytest

import opdeform
from test_addon import BPY_VERSIONS, ROOT, host_missing

RENDER_HOSTS = ("blender", *(f"bpy-{v}" for v in BPY_VERSIONS))


@pytest.mark.parametrize("host", RENDER_HOSTS)
def test_regression_renders_match_references(host, tmp_path):
    why = host_missing(host)
    if why:
        pytest.skip(why)
    build_dir = Path(opdeform.__file__).resolve().parent.parent.parent
    env = dict(os.environ, BUILD_DIR=str(build_dir), OPDEFORM_RENDER_NO_BUILD="1")
    env.pop("OPDEFORM_PYTHONPATH", None)
    proc = subprocess.run([str(ROOT / "scripts" / "render"), "--host", host, "--out", str(tmp_path)],
                          capture_output=True, text=True, env=env, cwd=str(ROOT), timeout=900)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert "within tolerance" in proc.stdout and "references " in proc.stdout, proc.stdout[-2000:]
    assert len(list(tmp_path.glob("*.png"))) == 6


def test_every_matrix_version_has_references():
    """A reference set per host version: 3.4 (Debian) and each bpy of the matrix."""
    reference = ROOT / "tests" / "reference"
    for version in ("3.4", *BPY_VERSIONS):
        names = sorted(p.name for p in (reference / version).glob("*.png"))
        assert names == [f"{scene}_{f:03d}.png" for scene, frames in (("bar", (1, 24, 48)),
                                                                        ("creature", (1, 20, 60)))
                         for f in frames], (version, names)
