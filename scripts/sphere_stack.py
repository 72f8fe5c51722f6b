"""Issue 27, (c) of docs/contact.md, "Stacks", stop 40: a 0.35 m sphere dropped 5 cm onto a 0.5 m one on the panel's
Floor (both UV spheres of 32 x 16 segments, a materials preset at the add-on's panel defaults: 24 fps, 10 substeps,
friction 0.5), through the add-on's bpy-free engine (scripts/one_pair.py's). Prints, every half second, how far the
upper's centre is aside of the lower's, the centres' heights, each sphere's kinetic and potential energy (J) and
their sum.

    PYTHONPATH=build/python python3 scripts/sphere_stack.py [SECONDS [PRESET]]   (13, Flesh)
"""

import sys
from pathlib import Path

import numpy as np

import opdeform

ROOT = Path(__file__).resolve().parent
sys.path[:0] = [str(ROOT), str(ROOT.parent / "tests"), str(ROOT.parent / "addon")]

from one_pair import energies, engine  # noqa: E402
from opdeform_blender.core import colliders, contact  # noqa: E402
from test_addon_colliders import _octasphere  # noqa: E402


def main(seconds=13, preset="Flesh"):
    (vl, tl), (vu, tu) = _octasphere(0.5, 16), _octasphere(0.35, 16)
    low, high = engine(vl, tl, 0.5, preset, seconds), engine(vu, tu, 1.0 + 0.35 + 0.05, preset, seconds)
    bodies = contact.Bodies()
    for f in range(1, seconds * 24 + 1):
        bodies.simulate(opdeform, [e.begin(f, surroundings=colliders.NOTHING) for e in (low, high)])
        if f % 12 == 0:
            (kl, pl), (ku, pu) = energies(low.sim), energies(high.sim)
            cl, cu = low.sim.positions.mean(axis=0), high.sim.positions.mean(axis=0)
            print(f"{f / 24:4.1f} s  aside {np.linalg.norm(cu[:2] - cl[:2]):.3f} m  centres {cu[2]:.4f} / {cl[2]:.4f} m  "
                  f"kinetic upper {ku:.2f} J, lower {kl:.2f} J  potential {pu:.1f} / {pl:.1f} J  "
                  f"sum {kl + ku + pl + pu:.1f} J", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(int(args[0]) if args else 13, args[1] if len(args) > 1 else "Flesh")
