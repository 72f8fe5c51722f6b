"""MPM's SVDs eight particles at a time (csrc/base/svd4.c, AVX2 on x86-64) against the scalar od_Svd3
(OPDEFORM_NO_AVX2=1): the snow block of `scripts/bench mpm`, the README's scattered flakes and the car through a
layer of flakes give the same trajectories bit for bit (positions, velocities, orientations, deformation
gradients, affine matrices, plastic volume change) on every thread count. The 4-wide kernel itself is checked
matrix by matrix in tests/c/test_svd4.c."""

import numpy as np
import pytest

import fresh_process

FIELDS = ("positions", "velocities", "orientations", "deformation", "affine", "plastic_j")

# name: (code that makes `world` and `on_frame`, frames, frame length)
SCENES = {
    # the snow block of scripts/benchmarks/_mpm_runner.py, small: hits the floor, so the snow turns plastic
    "snow": ("""
world = mpm.World((0, 0, 0), (1, 1, 1), 1 / 24, walls="separate", threads=THREADS)
a = (np.arange(12) + 0.5) / 48
x, y, z = np.meshgrid(0.375 + a, 0.375 + a, 0.2 + a, indexing="ij")
pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
world.add_particles(pts, mpm.snow(), particle_volume=48.0 ** -3, velocities=np.broadcast_to([0, 0, -1.0], pts.shape))
on_frame = None
""", 12, 1 / 60),
    "flakes": ("scene = mpm_scenes.scattered_flakes(count=1500, threads=THREADS)", 12, 1 / 24),
    "car": ("scene = mpm_scenes.car_collision(count=2000, threads=THREADS)", 8, 1 / 24),
}
RUN = """
if "scene" in globals():
    world, on_frame = scene.world, scene.on_frame
for frame in range(FRAMES):
    if on_frame:
        on_frame(frame, world)
    world.step(DT)
    world.update_orientations()
"""


def run_scene(name, avx2, threads=1):
    """The scene's fields after its frames, as one float64 array per field, in a fresh process."""
    setup, frames, dt = SCENES[name]
    code = ("import numpy as np\nfrom opdeform import mpm, mpm_scenes\n" + setup.replace("THREADS", str(threads))
            + RUN.replace("FRAMES", str(frames)).replace("DT", repr(dt))
            + f"\nwrite_out(world.n_particles, [world.read(f) for f in {FIELDS!r}])\n")
    n, data = fresh_process.run(code, OPDEFORM_NO_AVX2="0" if avx2 else "1")
    widths = (3, 3, 4, 9, 9, 1)
    out, at = {}, 0
    for field, width in zip(FIELDS, widths):
        out[field] = data[at:at + n * width].reshape(n, width)
        at += n * width
    assert at == len(data)
    return out


@pytest.mark.parametrize("name", sorted(SCENES))
def test_the_4_wide_svd_gives_the_scalar_trajectories(name):
    scalar, wide = run_scene(name, avx2=False), run_scene(name, avx2=True)
    moved = np.abs(scalar["positions"] - run_scene(name, avx2=False, threads=2)["positions"]).max()
    assert moved == 0.0  # and the thread count changes nothing either
    for field in FIELDS:
        assert np.isfinite(scalar[field]).all()
        np.testing.assert_array_equal(wide[field], scalar[field], err_msg=field)
    # the scenes exercise the SVD: the snow turns plastic, the flakes and the car's layer turn
    if name == "snow":
        assert (scalar["plastic_j"] < 1.0 - 1e-3).any()
    assert (np.abs(scalar["orientations"][:, 0]) < 0.999).any()

