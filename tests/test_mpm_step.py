"""How the MPM snow depends on the step (issue 27, docs/mpm.md "The step and the wind control").

A snow block settles higher at smaller steps, and what sets its height is the number of particle-grid
transfers per second, not the step: a transfer-only substep (dt = 1e-12) added after each step changes the
height as much as halving the step. The plasticity adds nothing in such a substep; the APIC transfer smooths
the velocities (its numerical viscosity acts once per transfer), and snow, whose plastic flow depends on its
path, keeps the difference. scripts/mpm_convergence.py measures the same on a larger block."""

import numpy as np

from opdeform import mpm

FLOOR = 0.125


def snow_block():
    """A 0.25 m snow cube of 512 particles resting on a sticky floor, dx = 1/16."""
    world = mpm.World((0, 0, 0), (1, 1, 1), 1 / 16, threads=1)
    world.add_particles(mpm.fill_box((0.375, 0.375, FLOOR), (0.625, 0.625, FLOOR + 0.25), 1 / 32), mpm.snow())
    world.add_floor(FLOOR, contact="sticky")
    return world


def centroid_after(dt, transfers_only, duration=0.5):
    """The block's mean height (mm) above the floor after `duration` s of steps dt, each followed by
    `transfers_only` substeps of 1e-12 s; and the world."""
    world = snow_block()
    for _ in range(round(duration / dt)):
        world.substep(dt)
        for _ in range(transfers_only):
            world.substep(1e-12)
    return 1000 * (world.positions[:, 2].mean() - FLOOR), world


def test_snow_height_follows_the_transfers_per_second_not_the_step():
    coarse, _ = centroid_after(2e-3, 0)
    coarse_twice_transferred, world = centroid_after(2e-3, 1)
    fine, _ = centroid_after(1e-3, 0)
    # Measured: 18.27 mm at 2e-3 s, 24.84 at 1e-3 s (+6.6 mm per halving), 24.72 at 2e-3 s with one
    # transfer-only substep after each step (0.12 mm from the halved step: 2 % of the halving's change).
    assert fine - coarse > 3.0
    assert abs(coarse_twice_transferred - fine) < 0.05 * (fine - coarse)
    # A transfer-only substep moves nothing in time and leaves the plastic state alone (measured 9e-13) while
    # the transfer damps the velocities: measured 4.4 mm/s of 257 mm/s, C 0.11 of 2.5 /s, and 1.8 % of the
    # kinetic energy (APIC's: ½ m (|v|² + Δx²/4 |C|²), all particles of one mass).
    jp, positions, velocities, energy = world.read("plastic_j"), world.positions, world.velocities, apic_energy(world)
    world.substep(1e-12)
    assert np.abs(jp - 1.0).max() > 0.1  # the snow did compact plastically
    assert np.abs(world.read("plastic_j") - jp).max() < 1e-10
    assert np.abs(world.positions - positions).max() < 1e-10
    assert np.abs(world.velocities - velocities).max() > 1e-3
    assert apic_energy(world) < 0.99 * energy


def apic_energy(world):
    """The particles' kinetic energy per unit of a particle's mass, the affine part included."""
    return 0.5 * ((world.velocities ** 2).sum() + world.dx ** 2 / 4 * (world.read("affine") ** 2).sum())
