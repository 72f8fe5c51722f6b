"""Build's sweep (issue 24: no traceback on any mesh Build accepts), without Blender.

Each body is given to what the add-on's Build does, through its bpy-free core (blender/runtime.py's build and
configure): core.engine.Engine (Graph.from_mesh, the skin, the thin-part checks), checks.attached_pieces,
checks.vertex_pieces with small pieces of their own, core.settings.solver_settings (materials.stiffness_for,
Fleshy's 3 MPa at 24 fps, 10 substeps), Engine.configure, and, as on a rigged mesh (small pieces "own", the
"goal" size rule), set_goal with a painted Follow (0..1 with height, Shell Min 0.3) and set_regions with
Softness 0.15^(1 - Follow); then two frames (goto 3). Small pieces "attach" go as an unrigged mesh: the
"froude" size rule, no goal.

Bodies: opdeform.meshes' creature, character, capsule, bar, sheet, strand (straight and bowed), the bracket,
plate and two bars of tests/test_materials_calibration.py, the kitbash, studded body, button, hanging ear, card
and skirt of tests/test_loose_parts.py, Suzanne (tests/reference), two equal capsules apart, Blender's default
cube and plane. Each at every scale, particle count, graph mode and small-pieces choice (or ``--sample N`` of
those cases, drawn with ``--seed``).

Each case goes two ways: "build", the add-on's Build as above, and "direct", what a script does with the mesh as
given (Graph.from_mesh of the float64 vertices in their triangles' order, then materials.stiffness_for: the lead's
L bracket at 1.5 times, 200 particles, failed only this way). A run is "refused" when the input is turned down with
a clear report (EngineError; in "direct", a ValueError of Graph.from_mesh), "failed" on any other exception or
RuntimeWarning (numpy's NaN on the way), a non-finite or non-positive stiffness or a non-finite output. Prints one
line per run that did not pass, then the counts and each kind of failure with its first case.

    PYTHONPATH=build/python python3 scripts/calibration_sweep.py [--sample N] [--seed S] [--bodies a,b]
        [--scales 0.01,1.5] [--particles 20,200] [--modes auto,chain] [--small attach,own]
"""

import argparse
import random
import sys
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

import opdeform
from opdeform import meshes

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "tests")]
from opdeform_blender.core import checks, settings  # noqa: E402
from opdeform_blender.core.engine import GRAPH_MODES, Engine, EngineError  # noqa: E402
import test_loose_parts as loose  # noqa: E402
import test_materials_calibration as calibration  # noqa: E402

SCALES = (0.01, 0.3, 1.5, 3.0, 7.0, 100.0)
PARTICLES = (20, 50, 75, 100, 150, 200, 300, 400)
SMALL_PIECES = ("attach", "own")
FPS, SUBSTEPS = 24, 10
LOOK = settings.LOOKS[settings.DEFAULT_LOOK]


def two_capsules():
    a, t = meshes.capsule(radius=0.2, length=0.6)
    return np.vstack([a, a + [0.0, 1.0, 0.0]]), np.vstack([t, t + len(a)])


def default_cube():
    v = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return v, np.array([tri for a, b, c, d in quads for tri in ((a, b, c), (a, c, d))])


def suzanne():
    with np.load(ROOT / "tests" / "reference" / "suzanne_subdivided.npz") as f:
        return f["vertices"], f["triangles"]


def button():
    ball = meshes.capsule(radius=0.022, length=0.0, segments=12, rings=6, body=1)
    return loose.with_shell((ball[0] + (0.2, 0.0, 0.3), ball[1]))


BODIES = {
    "creature": meshes.creature,
    "character": meshes.character,
    "capsule": meshes.capsule,
    "bar": meshes.bar,
    "sheet": meshes.sheet,
    "strand": meshes.strand,
    "bowed_strand": lambda: meshes.strand(sag=0.2),
    "bracket": calibration.bracket,
    "plate": lambda: calibration.box((0.0, -0.25, -0.04), (1.0, 0.25, 0.04), 40, 20),
    "two_bars": calibration.two_bars,
    "kitbash": loose.kitbash,
    "studded": loose.studded,
    "button": button,
    "hanging_ear": lambda: loose.with_shell(loose.hanging_ear()),
    "card": lambda: loose.with_shell(loose.card()),
    "skirt": lambda: loose.with_shell(loose.skirt()),
    "suzanne": suzanne,
    "two_capsules": two_capsules,
    "cube": default_cube,
    "plane": lambda: meshes.sheet((2.0, 2.0), (1, 1)),
}


def build(v, t, particles, mode, small):
    """What Build does with the mesh (the module's docstring); returns the problems found (empty: none)."""
    e = Engine(opdeform, v, t, None, particles, mode, 4, small)
    checks.attached_pieces(opdeform, e.graph, e.rest, e.triangles, e.rest_local)
    rigged = small == "own"
    if rigged:
        checks.vertex_pieces(e.rest, e.triangles)
    units = settings.Units(solver_units=False, modulus=LOOK["modulus"], stiffness=0.0, density=LOOK["density"],
                           damping_rate=LOOK["damping_rate"], damping=0.0, tolerance=0.2, max_iterations=100,
                           iterations=10, substeps=SUBSTEPS, scaling="goal" if rigged else "froude")
    params, solver = settings.solver_settings(opdeform, e.graph, units, FPS, (0.0, 0.0, -9.81))
    k = np.asarray(params["stiffness"], dtype=np.float64)
    problems = []
    if not np.all(np.isfinite(k) & (k > 0.0)):
        problems.append(f"stiffness: {np.sum(~np.isfinite(k))} non-finite, {np.sum(k <= 0.0)} <= 0")
    e.configure(params, SUBSTEPS, None, 1, 48, solver)
    if rigged:
        z = e.rest_local[:, 2]
        follow = (z - z.min()) / max(float(np.ptp(z)), 1e-30)
        e.set_goal(0.0, follow, (0.0, 1.0), settings.SHELL_FOLLOW_MIN)
        e.set_regions(LOOK["soft_stiffness"] ** (1.0 - follow))
    out = e.goto(3)
    if not np.all(np.isfinite(out)):
        problems.append("frame 3: non-finite vertices")
    return problems


def cases(args):
    grid = [(b, s, n, m, p) for b in args.bodies for s in args.scales for n in args.particles for m in args.modes
            for p in args.small]
    if args.sample:
        grid = sorted(random.Random(args.seed).sample(grid, min(args.sample, len(grid))),
                      key=lambda c: list(BODIES).index(c[0]))
    return grid


def signature(exc):
    """A failure's kind: its type and message with the numbers taken out, and where it was raised."""
    words = " ".join("#" if any(ch.isdigit() for ch in w) else w for w in str(exc).split())
    where = traceback.extract_tb(exc.__traceback__)[-1]
    return f"{type(exc).__name__}: {words} ({Path(where.filename).name}:{where.name})"


def direct(v, t, particles, mode, small):
    """What a script does (the lead's L bracket at 1.5 times: issue 24): Graph.from_mesh of the mesh as given
    (float64, its triangles' order; Build's float32 and canonical order make another graph), then
    materials.stiffness_for; the problems found. A ValueError of Graph.from_mesh refuses the input."""
    try:
        g = opdeform.Graph.from_mesh(v, t, particles=particles, mode=mode, small_pieces=small)
    except ValueError as exc:
        raise EngineError(str(exc)) from None
    k = np.asarray(opdeform.materials.stiffness_for(g, LOOK["modulus"] * settings.MPA), dtype=np.float64)
    return [] if np.all(np.isfinite(k) & (k > 0.0)) else [f"stiffness: non-finite or <= 0 ({k.min()})"]


def attempt(path, v, t, *case):
    """(outcome: passed, refused or failed; its lines) of one path (build or direct) on one case."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # numpy's NaN on the way
            problems = path(v, t, *case)
    except EngineError as exc:
        return "refused", [str(exc)]
    except Exception as exc:  # noqa: BLE001 (what the sweep looks for)
        problems = [signature(exc)]
    return ("failed" if problems else "passed"), problems


def run(args):
    made, counts, kinds = {}, {}, {}
    t0 = time.process_time()
    for body, scale, *case in cases(args):
        if body not in made:
            made[body] = BODIES[body]()
        v, t = made[body]
        name = f"{body} scale={scale:g} particles={case[0]} mode={case[1]} small={case[2]}"
        for path in (build, direct):
            outcome, lines = attempt(path, np.asarray(v, dtype=np.float64) * scale, t, *case)
            counts[outcome] = counts.get(outcome, 0) + 1
            for line in lines:
                print(f"{outcome:8} {path.__name__:6} {name}: {line}", flush=True)
                if outcome == "failed":
                    kinds.setdefault(f"{path.__name__}: {line}", []).append(name)
    print(f"\n{sum(counts.values())} runs (build and direct), {time.process_time() - t0:.0f} s of "
          "processor time: " + ", ".join(f"{n} {k}" for k, n in sorted(counts.items())))
    for kind, where in sorted(kinds.items(), key=lambda x: -len(x[1])):
        print(f"{len(where):4d} x {kind}\n       first: {where[0]}")
    return 1 if counts.get("failed") else 0


def listed(kind, choices=None):
    def parse(text):
        values = [kind(x) for x in text.split(",")]
        if choices is not None and not set(values) <= set(choices):
            raise argparse.ArgumentTypeError(f"choose from {', '.join(map(str, choices))}")
        return values
    return parse


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bodies", type=listed(str, BODIES), default=list(BODIES))
    p.add_argument("--scales", type=listed(float), default=list(SCALES))
    p.add_argument("--particles", type=listed(int), default=list(PARTICLES))
    p.add_argument("--modes", type=listed(str, GRAPH_MODES), default=list(GRAPH_MODES))
    p.add_argument("--small", type=listed(str, SMALL_PIECES), default=list(SMALL_PIECES))
    p.add_argument("--sample", type=int, default=0, help="this many cases of the grid, drawn at random")
    p.add_argument("--seed", type=int, default=1)
    return run(p.parse_args())


if __name__ == "__main__":
    sys.exit(main())
