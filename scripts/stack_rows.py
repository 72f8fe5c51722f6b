"""Issue 27, docs/contact.md "Stacks", stop 46: rows of the stacks bench (scripts/benchmarks/stacking.py's slabs, the
upper dropped 0.05 m onto the lower, RATIO its density over the lower's) alone, at RATE steps a second: the bench's
row (held 3-13 s?, least height above, most aside, fastest particle, CPU s), or with `--settled` the lower slab
settled alone on the floor for 1 s first (tests/test_body_contact.py's placement) and every second's height above /
aside / fastest particle / most the centres' kinetic and potential energy rose above the start (J).

    PYTHONPATH=build/python python3 scripts/stack_rows.py RATE PRESET:RATIO ... [--settled]
    e.g. scripts/stack_rows.py 24 Jelly:1/1000 Rubber:1/1000 Stiff:1/1000
"""

import sys
from fractions import Fraction
from pathlib import Path

ROOT = Path(__file__).resolve().parent
sys.path[:0] = [str(ROOT), str(ROOT.parent / "tests")]

from benchmarks.stacking import slab_rows  # noqa: E402
from opdeform import materials  # noqa: E402


def settled_seconds(preset, ratio, rate):
    """The lower slab settled 1 s first, then 13 s of the pair: one line of every second's figures."""
    import test_body_contact as t

    light = materials.PRESETS[preset].density
    lower, upper = t._on_a_settled_slab(preset, *((light / ratio, light) if ratio < 1 else (light, light * ratio)),
                                        rate)
    return " ".join(f"{s}:{above:.3f}/{aside:.3f}/{fastest:.3f}/{rise:+.0f}"
                    for s, (above, aside, fastest, rise) in enumerate(t._stacked_seconds(lower, upper, 13, rate), 1))


def main(args):
    settled = "--settled" in args
    args = [a for a in args if a != "--settled"]
    rate = int(args[0])
    for case in args[1:]:
        preset, ratio = case.split(":")
        ratio = float(Fraction(ratio))
        row = settled_seconds(preset, ratio, rate) if settled else " / ".join(slab_rows((preset,), (ratio,), rate)[0])
        print(f"{rate} Hz {preset} {case.split(':')[1]}: {row}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
