"""Tumbling-particle demo (called by scripts/demo): the seed's two scenes, briefly, as PLY frames and renders.

run(out_dir) writes out_dir/flakes/, out_dir/plain_flakes/ (the same run as plain MLS-MPM, spin = 0: the
seed's Fig. 9 comparison) and out_dir/car/ (Fig. 11), one PLY per frame with x y z, the orientation
quaternion qw qx qy qz and the velocity, prints what happened in each, and renders a few frames of each
headless in Debian's Blender through the add-on (tests/blender/render_tumbling.py) into out_dir/*.png.
"""

import os
import shutil
import subprocess
import sys
import time

import numpy as np

from opdeform import mpm_scenes


def _turned_degrees(q, q0):
    return np.degrees(2.0 * np.arccos(np.clip(np.abs((q * q0).sum(axis=1)), 0.0, 1.0)))


def _run(scene, out_dir):
    world = scene.world
    q0, x0 = world.orientations, world.positions
    t = time.perf_counter()
    paths = scene.run(os.path.join(out_dir, scene.name))
    seconds = time.perf_counter() - t
    turned = _turned_degrees(world.orientations, q0)
    moved = np.linalg.norm(world.positions - x0, axis=1)
    stats = world.stats
    print(f"  {scene.name:13s} {world.n_particles} particles, {len(paths) - 1} frames at {scene.fps:g} fps "
          f"({stats['substeps']} substeps) in {seconds:.1f} s; turned: median {np.median(turned):.1f} deg, "
          f"max {turned.max():.1f} deg; moved: median {np.median(moved):.2f} m, max {moved.max():.2f} m; "
          f"highest {world.positions[:, 2].max():.2f} m")
    return paths


def run(out_dir, frames_scale=1.0):
    print("Tumbling particles (MLS-MPM, particle rotation from the polar decomposition of F)")
    for scene in (mpm_scenes.scattered_flakes(spin=1.0), mpm_scenes.scattered_flakes(spin=0.0),
                  mpm_scenes.car_collision()):
        scene.frames = max(2, int(scene.frames * frames_scale))
        _run(scene, out_dir)
    print(f"  PLY frames (x y z qw qx qy qz vx vy vz) under {os.path.abspath(out_dir)}")
    _render(out_dir)


def _render(out_dir):
    """Cycles renders of chosen frames through the add-on, in Debian's Blender (skipped without it)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    if shutil.which("blender") is None:
        print("  renders skipped: Blender is not installed (scripts/setup installs Debian's)")
        return
    import opdeform
    env = dict(os.environ, OPDEFORM_PYTHONPATH=os.path.dirname(os.path.dirname(os.path.abspath(opdeform.__file__))))
    env.pop("PYTHONPATH", None)
    t = time.perf_counter()
    proc = subprocess.run([os.path.join(root, "scripts", "blender"), "-b", "--factory-startup", "--python-exit-code",
                           "1", "-P", os.path.join(root, "tests", "blender", "render_tumbling.py"), "--",
                           os.path.abspath(out_dir)], capture_output=True, text=True, env=env, cwd=root)
    images = [line.split(" ", 1)[1] for line in proc.stdout.splitlines() if line.startswith("render: ")]
    if proc.returncode != 0:
        print(f"  render failed (exit {proc.returncode}):\n{(proc.stdout + proc.stderr)[-2000:]}")
        return
    print(f"  rendered {len(images)} frames headless (Cycles, CPU) in {time.perf_counter() - t:.0f} s: "
          f"{', '.join(os.path.basename(i) for i in images)}")


if __name__ == "__main__":
    run(sys.argv[1] if len(sys.argv) > 1 else os.path.join("out", "demo", "mpm"))
