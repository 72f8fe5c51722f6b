"""Issue 27, a member resting on another on a single pair (docs/contact.md, "Stacks", stop 40): two subdivided
Suzannes at the add-on's panel defaults (a preset, Rubber the default's; 24 fps, 10 substeps; the Floor at 0,
friction 0.5), the upper dropped DROP m onto the lower, through the add-on's bpy-free engine. Prints, each second,
how far the upper's centre is aside of the lower's, the centres' heights, the particles' kinetic energy, the
potential energy of each (J) and the upper's fastest particle.

    PYTHONPATH=build/python python3 scripts/one_pair.py [SECONDS [DROP [PRESET]]]   (40, 0.98, Rubber)
"""

import sys
from pathlib import Path

import numpy as np

import opdeform

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "addon"))

from opdeform_blender.core import colliders, contact, settings  # noqa: E402
from opdeform_blender.core.engine import Engine  # noqa: E402


def engine(vertices, triangles, lift, preset, seconds):
    matrix = np.eye(4)
    matrix[2, 3] = lift
    e = Engine(opdeform, vertices, triangles, matrix, particles=100)
    u = settings.Units(False, stiffness=1e5, damping=0.0, max_iterations=100, iterations=10, substeps=10,
                       **settings.preset_values(opdeform.materials, preset))
    params, solver = settings.solver_settings(opdeform, e.graph, u, 24, (0.0, 0.0, -9.81))
    e.configure(params, substeps=10, floor=(0.0, 0.5), end=seconds * 24, solver=solver)
    return e


def energies(sim):
    m = sim.params["density"] * sim.graph.volumes
    return (m * 0.5 * (sim.velocities ** 2).sum(axis=1)).sum(), (m * 9.81 * sim.positions[:, 2]).sum()


def play(low, high, seconds, every, show):
    """Plays the two engines in a group for `seconds` at 24 fps; every `every` frames calls show(frame, (kinetic,
    potential) of the lower, of the upper, the lower's centre, the upper's)."""
    bodies = contact.Bodies()
    for f in range(1, seconds * 24 + 1):
        bodies.simulate(opdeform, [e.begin(f, surroundings=colliders.NOTHING) for e in (low, high)])
        if f % every == 0:
            show(f, energies(low.sim), energies(high.sim), low.sim.positions.mean(axis=0),
                 high.sim.positions.mean(axis=0))


def main(seconds=40, drop=0.98, preset="Rubber"):
    mesh = np.load(ROOT / "tests" / "reference" / "suzanne_subdivided.npz")
    z = mesh["vertices"][:, 2]
    lifts = (-z.min(), drop + z.max() - 2 * z.min())
    low, high = (engine(mesh["vertices"], mesh["triangles"], lift, preset, seconds) for lift in lifts)

    def show(f, lower, upper, cl, cu):
        (kl, pl), (ku, pu) = lower, upper
        print(f"{f // 24:3d} s  aside {np.linalg.norm(cu[:2] - cl[:2]):.3f} m  upper's centre {cu[2]:.4f} m  "
              f"lower's {cl[2]:.4f} m  kinetic {kl + ku:.2f} J  potential upper {pu:.1f} J, lower {pl:.1f} J  "
              f"fastest {np.abs(high.sim.velocities).max():.4f} m/s", flush=True)

    play(low, high, seconds, 24, show)

if __name__ == "__main__":
    args = sys.argv[1:]
    main(int(args[0]) if args else 40, float(args[1]) if len(args) > 1 else 0.98, args[2] if len(args) > 2 else "Rubber")
