"""Calibration for any body: static droop under the same modulus at 50-400 particles (issue 24).

Each body is built with Graph.from_mesh at every particle count, given ``materials.stiffness_for(graph, Rubber)``
(Rubber's density; the character Jelly's), held where it is clamped (every mesh vertex of that region pinned)
and solved static under gravity; the droop is the mean drop of its tip region over a length. Bodies: a plate
1 x 0.5 x 0.08 m clamped at a short end, an L-shaped bracket (arms of 1.0 and 0.6 m, section 0.2 x 0.1 m,
lying flat, clamped at the end of its long arm), the 2 x 0.2 m tail, the character (``meshes.character()``)
held by its torso (the drop of its tail's tip and of its left ear's, over their lengths), and a two-box body
(two 1 x 0.1 x 0.1 m bars 0.3 m apart, one object, each clamped at x = 0).
Prints the droops, max/min across counts per body, the plate against Euler-Bernoulli and Kirchhoff
(cylindrical bending, nu = 0.3) theory at the body's effective E, and the calibration's cost (processor time,
the measure, and wall time beside it).
Options: --counts 50,100,200,400, --bodies plate,bracket, --calibration measured|bending|uniform,
--cost (the calibration's processor and wall time at 100 and 1,000 particles of the plate, the tail, the
bracket and the character), --parts (for the character's bodies: its head's drop, the part's axis root and tip
drops, and its tip region's drop as the head's rigid motion carries it and its own, part_drops).
"""

import argparse
import time

import numpy as np

import opdeform
from opdeform import materials, meshes

from .common import table

RUBBER = materials.PRESETS["Rubber"]
JELLY = materials.PRESETS["Jelly"]
G = 9.81


def _box(lo, hi, segments=(40, 20, 4)):
    """A closed box mesh from lo to hi (``meshes.bar`` scaled), ``segments`` divisions along x, y, z (y and
    z take the larger)."""
    v, t = meshes.bar(length=1.0, width=1.0, segments=segments[0], cross=max(segments[1:]))
    v = v + np.array([0.0, 0.5, 0.5])
    return v * (np.asarray(hi) - np.asarray(lo)) + np.asarray(lo), t


def plate():
    v, t = _box((0.0, -0.25, -0.04), (1.0, 0.25, 0.04), (40, 20, 20))
    return v, t, v[:, 0] <= 1e-9, v[:, 0] >= 1.0 - 1e-9, 1.0


def bracket():
    """An L lying flat: the long arm along x (0..1), the short arm along y at its far end (x 0.8..1, y 0..0.6);
    surface nets of the union of the two boxes."""
    arms = [((0.0, -0.1, 0.0), (1.0, 0.1, 0.1)), ((0.8, -0.1, 0.0), (1.0, 0.6, 0.1))]

    def distance(p):
        d = None
        for lo, hi in arms:
            c, h = (np.array(lo) + hi) / 2, (np.array(hi) - lo) / 2
            q = np.abs(p - c) - h
            box = np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)
            d = box if d is None else np.minimum(d, box)
        return d
    v, t = meshes._closed_surface(distance, np.array([-0.05, -0.15, -0.05]), np.array([1.05, 0.65, 0.15]), 0.02)
    return v, t, v[:, 0] <= v[:, 0].min() + 1e-3, v[:, 1] >= v[:, 1].max() - 0.02, 1.0 + 0.6


def tail():
    v, t = meshes.bar(length=2.0, width=0.2, segments=80, cross=4)
    return v, t, v[:, 0] <= 1e-9, v[:, 0] >= 2.0 - 1e-9, 2.0


def _character(part):
    """``meshes.character()`` held by its torso (the vertices nearest the body's capsule, in its middle 60 %),
    the tip of ``part`` (the vertices nearest its capsule, at its end)."""
    v, t = meshes.character()
    names = list(meshes.CHARACTER_PARTS)
    near = [_capsule(v, *meshes.CHARACTER_PARTS[name]) for name in names]
    own = np.argmin([d for d, _ in near], axis=0)
    along = near[names.index("body")][1]
    held = (own == names.index("body")) & (along > 0.2) & (along < 0.8)
    i = names.index(part)
    a, b = (np.array(x) for x in meshes.CHARACTER_PARTS[part][:2])
    return v, t, held, (own == i) & (near[i][1] >= 0.999), float(np.linalg.norm(b - a))


def _capsule(p, a, b, ra, rb):
    """(distance of points p to a tapered capsule's surface, their parameter 0..1 along its axis)."""
    a, b = np.array(a), np.array(b)
    h = np.clip(((p - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(p - (a + h[:, None] * (b - a)), axis=1) - (ra + (rb - ra) * h), h


PARTS = {"character_tail": "tail", "character_ear": "ear.L"}  # the part whose tip each character body measures


def character_tail():
    return _character(PARTS["character_tail"])


def character_ear():
    return _character(PARTS["character_ear"])


def two_boxes():
    a, ta = _box((0.0, -0.2, 0.0), (1.0, -0.1, 0.1), (60, 4, 4))
    b, tb = _box((0.0, 0.1, 0.0), (1.0, 0.2, 0.1), (60, 4, 4))
    v, t = np.concatenate([a, b]), np.concatenate([ta, tb + len(a)]).astype(np.int32)
    return v, t, v[:, 0] <= 1e-9, v[:, 0] >= 1.0 - 1e-9, 1.0


BODIES = {"plate": plate, "bracket": bracket, "tail": tail, "character_tail": character_tail,
          "character_ear": character_ear, "two_boxes": two_boxes}


def droop(body, particles, calibration="measured", iterations=4000):
    """(droop of the tip region / the body's length, the graph's size used for E, calibration (processor, wall)
    seconds); the character under Jelly (under Rubber it droops 0.1-0.5 mm)."""
    sim, v, tip, length, cost = _solved(body, particles, calibration, iterations)
    drop = -(sim.skin_points(v[tip])[:, 2] - v[tip, 2]).mean()
    return float(drop / length), materials.body_size(sim.graph), cost


def _solved(body, particles, calibration, iterations):
    """(the static Simulation of ``body`` held as the bench holds it, its rest vertices, its tip vertices, its
    length, the calibration's (processor, wall) seconds)."""
    v, t, held, tip, length = BODIES[body]()
    material = JELLY if body.startswith("character") else RUBBER
    g = opdeform.Graph.from_mesh(v, t, particles=particles)
    k, cost = _timed(lambda: materials.stiffness_for(g, material.modulus, calibration=calibration))
    sim = opdeform.Simulation(g, k, density=material.density)
    opdeform.pin_vertices(sim, v, np.flatnonzero(held))
    sim.set_solver("chebyshev")
    sim.solve_static(iterations)
    return sim, v, tip, length, cost


def part_drops(body, particles, calibration="measured", iterations=4000):
    """Where a character part's droop comes from (mm, down): the head's translation (the mean drop of the closed
    mesh's grid cells within 0.2 m of the head's axis middle: their rigid motion's), the drop of the part's axis
    root and of its axis tip (skinned), the particles of the part (whose centres lie in the thin part of
    materials' grid that holds the point 3/4 along the axis), and the bench's tip region's drop as the head's
    best rigid motion (of those cells, turning included) moves it and less that (the part's own)."""
    sim, v, tip = _solved(body, particles, calibration, iterations)[:3]
    a, b = (np.array(x) for x in meshes.CHARACTER_PARTS[PARTS[body]][:2])
    grid = materials._Grid(*meshes.character())
    label = grid.appendages()
    cells = grid.centres(np.flatnonzero(grid.inside.ravel()))
    head = np.mean(meshes.CHARACTER_PARTS["head"][:2], axis=0)
    rest = cells[np.linalg.norm(cells - head, axis=1) < 0.2]
    moved = sim.skin_points(rest)
    axis = sim.skin_points(np.array([a, b]))
    mine = label[grid.cell_of((a + 0.75 * (b - a))[None])[0]]
    count = int((label[grid.cell_of(sim.graph.centers)] == mine).sum())
    carried = _rigidly_moved(rest, moved, v[tip])
    by_head = 1e3 * (v[tip] - carried).mean(axis=0)[2]
    own = 1e3 * (carried - sim.skin_points(v[tip])).mean(axis=0)[2]
    return 1e3 * (rest - moved).mean(axis=0)[2], 1e3 * (a - axis[0])[2], 1e3 * (b - axis[1])[2], count, by_head, own


def _rigidly_moved(rest, moved, points):
    """The rest ``points`` moved by the best rigid motion (least squares) of the points ``rest`` to ``moved``."""
    p, q = rest.mean(axis=0), moved.mean(axis=0)
    u, _, w = np.linalg.svd((moved - q).T @ (rest - p))
    turn = u @ np.diag([1.0, 1.0, np.linalg.det(u @ w)]) @ w
    return (points - p) @ turn.T + q


def plate_theory(size):
    """(Euler-Bernoulli, Kirchhoff cylindrical) droop of the plate's free end over its length at the E that
    stiffness_for gives a body of ``size``: w = q L^4 / (8 E I), I = b h^3 / 12 (Kirchhoff: E / (1 - nu^2))."""
    e = RUBBER.modulus * size / materials.REFERENCE_SIZE
    beam = RUBBER.density * G * 1.0 ** 4 * 12.0 / (8.0 * e * 0.08 ** 2)
    return beam, beam * (1.0 - 0.3 ** 2)


def _timed(fn):
    """(fn(), (processor seconds, wall seconds) it took)."""
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return out, (time.process_time() - cpu, time.perf_counter() - wall)


def cost(body, particles, calibration="measured"):
    """(processor, wall) seconds of the calibration of ``body`` at ``particles``."""
    v, t = BODIES[body]()[:2]
    g = opdeform.Graph.from_mesh(v, t, particles=particles)
    return _timed(lambda: materials.stiffness_for(g, RUBBER.modulus, calibration=calibration))[1]


def run(args):
    p = argparse.ArgumentParser(prog="scripts/bench calibration")
    p.add_argument("--counts", default="50,100,200,400")
    p.add_argument("--bodies", default=",".join(BODIES))
    p.add_argument("--calibration", default="measured", choices=materials.CALIBRATIONS)
    p.add_argument("--cost", action="store_true")
    p.add_argument("--parts", action="store_true")
    a = p.parse_args(args)
    counts = [int(c) for c in a.counts.split(",")]
    rows = []
    for body in a.bodies.split(","):
        found = [droop(body, n, a.calibration) for n in counts]
        d = [f[0] for f in found]
        row = [body] + [f"{100 * x:.2f} %" for x in d] + [f"{max(d) / min(d):.2f}"]
        row.append(" / ".join(f"{x / plate_theory(f[1])[0]:.2f}, {x / plate_theory(f[1])[1]:.2f}"
                              for x, f in zip(d, found)) if body == "plate" else "")
        slowest = max((f[2] for f in found), key=lambda c: c[0])
        rows.append(row + [f"{slowest[0]:.2f} s", f"{slowest[1]:.2f} s"])
        print(*rows[-1], flush=True)
    table(rows, ["body"] + [f"{n}" for n in counts] + ["max/min", "plate / EB, / Kirchhoff", "calib. cpu s",
                                                     "wall s"])
    print("calib. cpu s: the calibration's processor time at the count where it was longest; wall s: its wall time")
    if a.cost:
        for body in ("plate", "tail", "bracket", "character_tail"):
            for n in (100, 1000):
                cpu, wall = cost(body, n, a.calibration)
                print(f"cost {body} {n} particles: {cpu:.2f} s processor, {wall:.2f} s wall", flush=True)
    if a.parts:
        for body in (b for b in a.bodies.split(",") if b in PARTS):
            for n in counts:
                head, root, tip, count, by_head, own = part_drops(body, n, a.calibration)
                print(f"parts {body} {n} particles: head {head:.2f} mm, {PARTS[body]}'s axis root {root:.2f} mm, "
                      f"its tip {tip:.2f} mm (own {tip - root:.2f} mm), {count} particles; the tip region "
                      f"{by_head:.2f} mm as the head carries it, {own:.2f} mm its own", flush=True)
