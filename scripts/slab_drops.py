"""Issue 27, docs/contact.md "Stacks", stop 42: the stacking bench's slab drops (scripts/benchmarks/stacking.py, a
slab of each preset dropped 0.05 m onto another in a ContactGroup, the upper RATIO times as dense) stepped one step
at a time for 4 s at RATE steps a second; prints the most the centres' kinetic and potential energy rose above the
placed start (J), the upper's alone, and the rise at 4 s.

    PYTHONPATH=build/python python3 scripts/slab_drops.py [RATE [RATIO ...]]   (240; 2 10 0.1 0.001)
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import opdeform  # noqa: E402
from benchmarks.stacking import preset_body, slab  # noqa: E402
from opdeform import materials  # noqa: E402


def energy(sim):
    """The kinetic and potential energy of sim's particles' centres (J)."""
    v2 = (sim.velocities ** 2).sum(axis=1)
    return (sim.params["density"] * sim.graph.volumes * (0.5 * v2 + 9.81 * sim.positions[:, 2])).sum()


def drop(preset, ratio, rate):
    v, t = slab()
    light = materials.PRESETS[preset].density
    lower_density, upper_density = (light, light * ratio) if ratio >= 1 else (light / ratio, light)
    lower = preset_body(v, t, 0.1, preset, lower_density, rate)
    upper = preset_body(v, t, 0.35, preset, upper_density, rate)
    group = opdeform.ContactGroup([lower, upper], friction=0.5)
    start, upper_start, most, upper_most = energy(lower) + energy(upper), energy(upper), -np.inf, -np.inf
    for _ in range(4 * rate):
        group.step(1)
        most = max(most, energy(lower) + energy(upper) - start)
        upper_most = max(upper_most, energy(upper) - upper_start)
    return most, upper_most, energy(lower) + energy(upper) - start


def main(rate=240, ratios=(2, 10, 0.1, 0.001)):
    for preset in ("Jelly", "Rubber", "Stiff"):
        for ratio in ratios:
            most, upper, end = drop(preset, ratio, rate)
            print(f"{preset:6s} ratio {ratio:g} at {rate} steps/s: most above start {most:+.1f} J "
                  f"(upper alone {upper:+.1f} J), at 4 s {end:+.1f} J", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(int(args[0]) if args else 240, tuple(float(a) for a in args[1:]) or (2, 10, 0.1, 0.001))
