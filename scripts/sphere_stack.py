"""Issue 27, (c) of docs/contact.md, "Stacks", stop 40: a 0.35 m (RADIUS) sphere dropped 5 cm onto a 0.5 m one on the
panel's Floor (both UV spheres of 32 x 16 segments, a materials preset at the add-on's panel defaults: 24 fps, 10
substeps, friction 0.5), through the add-on's bpy-free engine (scripts/one_pair.py's). Prints, every half second,
how far the upper's centre is aside of the lower's, the centres' heights, each sphere's kinetic and potential energy
(J) and their sum.

    PYTHONPATH=build/python python3 scripts/sphere_stack.py [SECONDS [PRESET [RADIUS]]]   (13, Flesh, 0.35: the upper's)
"""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent
sys.path[:0] = [str(ROOT), str(ROOT.parent / "tests"), str(ROOT.parent / "addon")]

from one_pair import engine, play  # noqa: E402
from test_addon_colliders import _octasphere  # noqa: E402

LINE = ("{:4.1f} s  aside {:.3f} m  centres {:.4f} / {:.4f} m  kinetic upper {:.2f} J, lower {:.2f} J  "
        "potential {:.1f} / {:.1f} J  sum {:.1f} J")


def main(seconds=13, preset="Flesh", radius=0.35):
    (vl, tl), (vu, tu) = _octasphere(0.5, 16), _octasphere(radius, 16)
    low, high = engine(vl, tl, 0.5, preset, seconds), engine(vu, tu, 1.0 + radius + 0.05, preset, seconds)

    def show(f, lower, upper, cl, cu):
        figures = (f / 24, np.linalg.norm(cu[:2] - cl[:2]), cu[2], cl[2], upper[0], lower[0], upper[1], lower[1],
                   sum(lower) + sum(upper))
        print(LINE.format(*figures), flush=True)

    play(low, high, seconds, 12, show)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(int(args[0]) if args else 13, args[1] if len(args) > 1 else "Flesh", float(args[2]) if len(args) > 2 else 0.35)
