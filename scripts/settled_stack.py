"""Issue 27, docs/contact.md, "Stacks", stop 41: two 0.6 m spheres of a materials preset (the capsule of
tests/test_body_contact.py, 100 particles), the lower settled alone on the floor for 1 s, the upper dropped 0.1 m onto
it, in a ContactGroup (μ = 0.5) at RATE steps a second. Prints, each second, the upper's centre above the lower's, how
far aside, the upper's fastest particle and how far the centres' energy rose above its start at any step so far.
`canonical`: the capsule's triangles each started at its smallest vertex and sorted (a graph of another layout).

    PYTHONPATH=build/python python3 scripts/settled_stack.py [SECONDS [RATE [PRESET [canonical]]]]   (13, 24, Rubber)
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from opdeform import meshes  # noqa: E402
from test_body_contact import _preset_body, _stacked_seconds  # noqa: E402


def main(seconds=13, rate=24, preset="Rubber", order=""):
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    if order == "canonical":
        t = np.array([np.roll(f, -np.argmin(f)) for f in t])
        t = t[np.lexsort(t.T[::-1])]
    lower = _preset_body(v, t, 0.31, preset, rate=rate)
    lower.step(rate)
    upper = _preset_body(v, t, lower.positions[:, 2].mean() + 0.7, preset, rate=rate)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, seconds, rate), 1):
        print(f"{second:3d} s  above {above:.3f} m  aside {aside:.3f} m  fastest {fastest:.3f} m/s  "
              f"energy rise {rise:.1f} J", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(int(args[0]) if args else 13, int(args[1]) if len(args) > 1 else 24, args[2] if len(args) > 2 else "Rubber",
         args[3] if len(args) > 3 else "")
