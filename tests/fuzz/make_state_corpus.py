"""Seeds of the state-loading fuzz targets from real saved states (issue 28), written into
tests/fuzz/corpus/TARGET/seed-*: the bytes each target feeds to the loader it fuzzes.

    PYTHONPATH=build/python python3 tests/fuzz/make_state_corpus.py

- fuzz_mpm_state: ``mpm.World`` states (``World._core.save_state()``) of the world the target makes: the unit
  box, dx = 1/16, a floor at z = 0.1 and a sphere; snow, jelly and flakes, before and after steps and a
  collider move.
"""

import os

import numpy as np

from opdeform import mpm

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def fuzz_world():
    world = mpm.World((0, 0, 0), (1, 1, 1), 1 / 16, threads=1)
    world.add_floor(0.1)
    world.add_collider("sphere", radius=0.1, translation=(0.5, 0.5, 0.8))
    return world


def mpm_states():
    rng = np.random.default_rng(28)
    for k, material in enumerate((mpm.snow(), mpm.jelly(), mpm.flakes())):
        world = fuzz_world()
        n = 4 + 2 * k
        world.add_particles(0.4 + 0.2 * rng.random((n, 3)), material=material, particle_volume=1e-4,
                            orientations=mpm.random_orientations(n, seed=k), velocities=rng.normal(size=(n, 3)))
        yield f"{material.kind}-0", world._core.save_state()
        world.step(1 / 60)
        yield f"{material.kind}-1", world._core.save_state()
        world.add_particles(0.5 + 0.1 * rng.random((3, 3)), material=mpm.snow(hardening=3.0), particle_volume=2e-4)
        world.move_collider(1, (0.5, 0.5, 0.6))
        world.step(1 / 30)
        yield f"{material.kind}-2", world._core.save_state()
    yield "empty", fuzz_world()._core.save_state()


def write(target, seeds):
    folder = os.path.join(ROOT, target)
    os.makedirs(folder, exist_ok=True)
    for name, data in seeds:
        with open(os.path.join(folder, f"seed-{name}"), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    write("fuzz_mpm_state", mpm_states())
