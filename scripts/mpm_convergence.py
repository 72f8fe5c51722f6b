"""The MPM figures of issue 27 (docs/mpm.md, "The step and the wind control"), measured afresh.

step: a 0.3 m snow cube (the seed's Table 2, dx = 1/24, 2 particles per cell per axis) released at rest on a
      sticky floor; its height at 1 and 2 s per CFL number, then at fixed steps with transfer-only substeps
      (dt = 1e-12: a P2G + G2P that moves nothing in time) added after each, which change the height as
      much as halving the step does: the step dependence comes from the number of transfers per second;
      then its height at 1 s for five grid spacings and, at dx = 1/24, for five places of the floor between two
      grid nodes.
wind: the README's flake scene (mpm_scenes.scattered_flakes, 3000 flakes, first 0.5 s): the median turn of the
      flakes in the noise wind, the potential (curl-free) wind, a uniform wind and no wind, on three seeds;
      then the potential wind with flakes that have no stiffness, and with a tenth of the flakes.

Usage: PYTHONPATH=build/python python3 scripts/mpm_convergence.py [step] [wind]   (both by default; the step
part takes about 3 minutes of one core, the wind part about 1)
"""

import sys

import numpy as np

from opdeform import mpm, mpm_scenes

FLOOR = 0.1
DX = 1 / 24


def snow_block(cfl=0.4, dx=DX, floor=FLOOR):
    world = mpm.World((0, 0, 0), (1, 1, 1), dx, cfl=cfl, max_dt=1.0, threads=1)
    world.add_particles(mpm.fill_box((0.35, 0.35, floor), (0.65, 0.65, floor + 0.3), dx / 2), mpm.snow())
    world.add_floor(floor, contact="sticky")
    return world


def heights(world, floor=FLOOR):
    """(top, centroid) above the floor in mm: the 99th percentile and the mean of the particles' heights."""
    z = world.positions[:, 2] - floor
    return 1000 * np.percentile(z, 99), 1000 * z.mean()


def step_table():
    print("| CFL | substeps in 2 s | top at 1 s (mm) | centroid at 1 s | top at 2 s | centroid at 2 s | "
          "change of the top, centroid at 2 s from the row above |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    previous = None
    for cfl in (0.4, 0.2, 0.1):
        world = snow_block(cfl)
        row = []
        for _ in range(2):
            for _ in range(24):
                world.step(1 / 24)
            row += heights(world)
        change = "" if previous is None else f"{row[2] - previous[2]:+.1f}, {row[3] - previous[3]:+.1f}"
        previous = row
        print(f"| {cfl} | {world.stats['substeps']} | " + " | ".join(f"{h:.1f}" for h in row) + f" | {change} |",
              flush=True)


def grid_table():
    print("\n| dx (CFL 0.4) | the floor above the grid node below it (cells) | particles | top at 1 s (mm) | "
          "centroid at 1 s |")
    print("| --- | --- | --- | --- | --- |")
    rows = [(cells, FLOOR) for cells in (20, 24, 30, 32, 40)]
    rows += [(24, (4 + above) / 24) for above in (0.0, 0.2, 0.6, 0.8)]  # the floor moved between two nodes
    for cells, floor in rows:
        world = snow_block(dx=1 / cells, floor=floor)
        for _ in range(24):
            world.step(1 / 24)
        top, centroid = heights(world, floor)
        print(f"| 1/{cells} | {(floor * cells + 1e-9) % 1:.1f} | {world.n_particles} | {top:.1f} | {centroid:.1f} |",
              flush=True)


def transfer_table():
    print("\n| fixed step (s) | transfer-only substeps after each | transfers per second | top at 1 s (mm) | "
          "centroid at 1 s |")
    print("| --- | --- | --- | --- | --- |")
    for dt, extra in ((4e-4, 0), (4e-4, 1), (2e-4, 0), (4e-4, 3), (1e-4, 0)):
        world = snow_block()
        for _ in range(round(1.0 / dt)):
            world.substep(dt)
            for _ in range(extra):
                world.substep(1e-12)
        top, centroid = heights(world)
        print(f"| {dt:g} | {extra} | {round((1 + extra) / dt)} | {top:.1f} | {centroid:.1f} |", flush=True)


WINDS = {"noise": ("noise", {}, {}), "potential": ("potential", {}, {}),
         "uniform (potential, amplitude 0)": ("potential", {"amplitude": 0.0}, {}),
         "height profile only (noise, amplitude 0)": ("noise", {"amplitude": 0.0}, {}),
         "none (wind off)": ("off", {}, {}),
         "potential, flakes without stiffness (E = 1e-3)":
             ("potential", {}, {"material": mpm.flakes(young_modulus=1e-3)}),
         "potential, 300 flakes": ("potential", {}, {"count": 300})}


def flake_turn(seed, kind, changes, scene_changes):
    """The median turn (degrees) of the README's flakes in 0.5 s, with the scene's wind settings changed."""
    wind = "noise" if kind == "off" else kind
    world = mpm_scenes.scattered_flakes(threads=1, wind=wind, seed=seed, **scene_changes).world
    if kind == "off" or changes:
        settings = dict(velocity=(0.6, 0.2, 0.0), amplitude=1.5, wavelength=1.5, octaves=4, persistence=0.6,
                        drift=(0.4, 0.1), drag=10.0, ground=0.0, ref_height=2.0, exponent=0.4, seed=seed + 7)
        world.set_wind(kind, **{**settings, **changes})
    q0 = world.orientations
    for _ in range(12):
        world.step(1 / 24)
    dots = np.clip(np.abs((world.orientations * q0).sum(axis=1)), 0.0, 1.0)
    return np.degrees(np.median(2.0 * np.arccos(dots)))


def wind_table():
    seeds = (0, 1, 2)
    print("\n| wind | " + " | ".join(f"seed {s}: median turn (deg)" for s in seeds) + " | of the noise wind's |")
    print("| --- | " + " | ".join("---" for _ in seeds) + " | --- |")
    noise = None
    for name, (kind, changes, scene_changes) in WINDS.items():
        turns = np.array([flake_turn(seed, kind, changes, scene_changes) for seed in seeds])
        noise = turns if noise is None else noise
        ratios = ", ".join(f"{r:.3f}" for r in turns / noise)
        print(f"| {name} | " + " | ".join(f"{t:.3f}" for t in turns) + f" | {ratios} |", flush=True)


if __name__ == "__main__":
    parts = sys.argv[1:] or ["step", "wind"]
    if "step" in parts:
        step_table()
        transfer_table()
        grid_table()
    if "wind" in parts:
        wind_table()
