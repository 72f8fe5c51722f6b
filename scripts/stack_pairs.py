"""Issue 27's stacks, step by step (docs/contact.md, "Stacks", stop 44): every EVERY frames (24 a second) the upper's
centre aside of the lower's (m, and its x, y), each member's Kabsch turn from its start (degrees), the members'
mean velocities (m/s) and every pair between them that carries a force: its particles, normal force (N), friction
over normal force and its normal's angle from the vertical (degrees).

    PYTHONPATH=build/python python3 scripts/stack_pairs.py CASE [SECONDS [EVERY [PRESET]]]   (13, 24)

CASE: "monkeys", Blender's Suzanne as added (tests/reference/suzanne_as_added.npz, 507 vertices) dropped 1 m onto
another on the Floor through the add-on's bpy-free engine at its panel defaults (scripts/one_pair.py's; Rubber
unless PRESET); "spheres", two 0.5 m spheres, the upper dropped 5 cm, the same way (Stiff unless PRESET);
"creatures", the stacks bench's Rubber creatures at 240 steps a second (scripts/benchmarks/stacking.py).
"""

import sys
from pathlib import Path

import numpy as np

import opdeform

ROOT = Path(__file__).resolve().parent
sys.path[:0] = [str(ROOT), str(ROOT.parent / "tests")]

from benchmarks.stacking import preset_body, turn  # noqa: E402
from one_pair import engine  # noqa: E402
from opdeform import meshes  # noqa: E402
from opdeform_blender.core import colliders, contact  # noqa: E402
from test_addon_colliders import _octasphere  # noqa: E402


def addon_pair(meshes_and_lifts, preset, seconds):
    """The two engines of the add-on's panel and a stepper for one frame: (lower sim, upper sim, step, group)."""
    low, high = (engine(v, t, lift, preset, seconds) for v, t, lift in meshes_and_lifts)
    bodies, frame = contact.Bodies(), [0]

    def step():
        frame[0] += 1
        bodies.simulate(opdeform, [e.begin(frame[0], surroundings=colliders.NOTHING) for e in (low, high)])
        return next(iter(bodies.groups.values()))[1]
    return low.sim, high.sim, step


def bench_pair():
    """The stacks bench's creatures at 240 steps a second, stepped a frame (10 steps) at a time."""
    v, t = meshes.creature(24)
    lower, upper = preset_body(v, t, 0.0, "Rubber", rate=240), preset_body(v, t, 1.06, "Rubber", rate=240)
    group = opdeform.ContactGroup([lower, upper], friction=0.5)

    def step():
        group.step(10)
        return group
    return lower, upper, step


def case(name, preset, seconds):
    if name == "creatures":
        return bench_pair()
    if name == "monkeys":
        mesh = np.load(ROOT.parent / "tests" / "reference" / "suzanne_as_added.npz")
        v, t = mesh["vertices"], mesh["triangles"]
        z = v[:, 2]
        return addon_pair([(v, t, -z.min()), (v, t, 1.0 + z.max() - 2 * z.min())], preset or "Rubber", seconds)
    v, t = _octasphere(0.5, 16)
    return addon_pair([(v, t, 0.5), (v, t, 1.55)], preset or "Stiff", seconds)


def pairs_between(group, n):
    """The pairs between the two members that carry a force: (pairs, forces)."""
    pairs, forces = group.save_state()
    between = ((pairs[:, 0] < n) != (pairs[:, 1] < n)) & (forces[:, 0] > 0.0)
    return pairs[between], forces[between]


def main(name, seconds=13, every=24, preset=None):
    lower, upper, step = case(name, preset, seconds)
    rest = lower.positions.copy(), upper.positions.copy()
    for f in range(1, seconds * 24 + 1):
        group = step()
        if f % every:
            continue
        d = upper.positions.mean(axis=0)[:2] - lower.positions.mean(axis=0)[:2]
        cells = [f"{f / 24:5.2f} s  aside {np.linalg.norm(d):.3f} ({d[0]:.3f}, {d[1]:.3f})",
                 f"turn {turn(rest[0], lower.positions):.1f} / {turn(rest[1], upper.positions):.1f} deg",
                 f"v {np.round(lower.velocities.mean(axis=0), 2)} / {np.round(upper.velocities.mean(axis=0), 2)}"]
        pairs, forces = pairs_between(group, lower.graph.n_particles)
        for (a, b), q in zip(pairs, forces):
            cells.append(f"{a}-{b} N {q[0]:.0f} f/N {np.linalg.norm(q[1:4]) / q[0]:.2f} "
                         f"{np.degrees(np.arccos(min(abs(q[6]), 1.0))):.1f} deg")
        print("  ".join(cells), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], *(int(a) for a in args[1:3]), *args[3:4])
