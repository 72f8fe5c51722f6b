"""How deep one body's skin goes into another's in a ContactGroup (issue 27: "no skin vertex of one body goes
deeper than 2 % of its size into another, at 10 m/s and at rest; at 20 m/s at most 5 %"; docs/contact.md,
"Contact on the skin between bodies").

    PYTHONPATH=build/python:scripts python3 scripts/skin_pairs.py [--quick] [--shape ellipsoids|skin|both]

Pairs of like bodies in a ContactGroup (μ = 0.5 between them and on the floor at 0, thickness 5 mm):
- spheres: 0.6 m, 100 particles, the Rubber preset at 1/60 s (`materials.make_simulation`, the stacking bench's
  `preset_body`);
- blobs: the add-on tests' (`tests/test_addon_colliders.py`): 0.6 m spheres of 60 particles, k = 1e5, 1/24 s, 10
  iterations;
- bars: 0.6 x 0.3 x 0.3 m, 100 particles, k = 1e6, 1/60 s (the stacking bench's `bars`, tests/test_body_contact.py's
  head-on pair);
- Suzannes: Blender's (tests/reference/suzanne_subdivided.npz, 2.66 m, 7,958 vertices), as the spheres.
Scenes: "drop", the upper body dropped from 0.1 m above the lower one, which lies on the floor, 3 s (the deepest
over the run and over its last second, "at rest"); "10 m/s" and "20 m/s", head on without gravity or floor, the
upper body coming down at that speed from 0.1 m above the lower one, at rest, 0.5 s. Measured after every step:
each body's skin as skinned (Skin of 4 neighbours, no push-out) against the other's current skinned closed mesh
(a mesh collider's signed distance, resolution 64, as the add-on tests' `_skinned_overlap`); the deepest vertex
of either body inside the other, as a fraction of its size (`materials.body_size`: the rest mesh's largest
extent) and in cm, or "apart" and the skins' least distance. "ellipsoids": the members as they are (the
default); "skin": each member given `set_contact_skin(skin)`. `--quick`: the blobs and the bars only. `--cost`:
the process time of a group step with the upper body at rest on the lower one (2-3 s after the drop), per shape.
"""

import argparse
import os
import time

import numpy as np

import opdeform as od
from opdeform import materials, meshes
from benchmarks.stacking import bars, preset_body

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPEEDS = (10.0, 20.0)
DROP_SECONDS = 3
HEAD_ON_SECONDS = 0.5


def sphere():
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    return v - v.mean(axis=0), t


def suzanne():
    data = np.load(os.path.join(ROOT, "tests", "reference", "suzanne_subdivided.npz"))
    v = data["vertices"].astype(np.float64)
    return v - v.mean(axis=0), data["triangles"]


def rubber(v, t):
    return preset_body(v, t, 0.0, "Rubber")


def blob(v, t):
    sim = od.Simulation(od.Graph.from_mesh(v, t, particles=60), 1e5, dt=1 / 24)
    sim.set_floor(0.0, 0.5)
    return sim


def bar(v, t):
    sim = od.Simulation(od.Graph.from_mesh(v, t, particles=100), 1e6, dt=1 / 60)
    sim.set_floor(0.0, 0.5)
    return sim


BODIES = {"spheres": (sphere, rubber), "blobs": (sphere, blob), "bars": (lambda: bars()[:2], bar),
          "Suzannes": (suzanne, rubber)}


class Member:
    """A body of the pair, its rest lowest point at `z`: its simulation, skin, triangles and size."""

    def __init__(self, body, z, shape, falls):
        mesh, make = BODIES[body]
        v, t = mesh()
        v = v + (0.0, 0.0, z - v[:, 2].min())
        self.sim = make(v, t)
        if not falls:
            self.sim.clear_floor()
            self.sim.set_params(gravity=(0.0, 0.0, 0.0))
        self.skin = od.Skin(self.sim.graph, v)
        self.triangles = t
        self.size = materials.body_size(self.sim.graph)
        self.height = v[:, 2].max() - v[:, 2].min()
        if shape == "skin":
            self.sim.set_contact_skin(self.skin)

    def shown(self):
        return self.skin.deform_sim(self.sim, push_out=False)


def depth(a, b):
    """How deep a's deepest skinned vertex is in b's skinned mesh, as a fraction of a's size (< 0: outside, the
    least distance)."""
    probe = od.Simulation(od.Graph.from_mesh(b.shown(), b.triangles, particles=8), 1e6)
    probe.add_collider("mesh", vertices=b.shown(), triangles=b.triangles, resolution=64)
    return -probe.collider_distances(a.shown()).min() / a.size


def deepest(members):
    """The deepest of either body into the other now (a fraction of its size; < 0: apart)."""
    a, b = members
    return max(depth(a, b), depth(b, a))


def pair(body, shape, falls):
    """The two members, the upper one's lowest point 0.1 m above the lower one's top, and their group."""
    lower = Member(body, 0.0, shape, falls)
    members = [lower, Member(body, lower.height + 0.1, shape, falls)]
    return members, od.ContactGroup([m.sim for m in members], friction=0.5)


def off(members):
    """Whether the upper body has left the lower one's top: its centre aside by more than half their size."""
    lower, upper = (m.sim.positions.mean(axis=0) for m in members)
    return np.linalg.norm((upper - lower)[:2]) > 0.5 * members[0].size


def drop(body, shape):
    """(deepest over the drop, over its last second, whether the upper body rolled off)."""
    members, group = pair(body, shape, True)
    steps = round(DROP_SECONDS / members[0].sim.params["dt"])
    worst, last = -np.inf, -np.inf
    for step in range(steps):
        group.step()
        d = deepest(members)
        worst = max(worst, d)
        last = max(last, d) if step >= steps - round(1.0 / members[0].sim.params["dt"]) else last
    return worst, last, off(members)


def head_on(body, shape, speed):
    """The deepest over HEAD_ON_SECONDS of the upper body coming down on the lower one at `speed`."""
    members, group = pair(body, shape, False)
    moving = members[1].sim
    moving.set_state(moving.positions, moving.rotations, np.tile((0.0, 0.0, -speed), (moving.graph.n_particles, 1)))
    worst = -np.inf
    for _ in range(round(HEAD_ON_SECONDS / moving.params["dt"])):
        group.step()
        worst = max(worst, deepest(members))
    return worst


def cell(c, size):
    return f"{100 * c:.1f} % ({100 * c * size:.1f} cm)" if c > 0.0 else f"apart ({-100 * c * size:.1f} cm)"


def row(body, shape):
    size = Member(body, 0.0, shape, True).size
    worst, last, rolled = drop(body, shape)
    cells = [cell(c, size) for c in (worst, last, *(head_on(body, shape, s) for s in SPEEDS))]
    cells[1] += ", rolled off" if rolled else ""
    return body, shape, f"{size:.2f} m", *cells


def cost(body):
    """Process time of a group step (ms) at rest on each other (steps 2-3 s of the drop), per contact shape."""
    out = []
    for shape in ("ellipsoids", "skin"):
        members, group = pair(body, shape, True)
        steps = round(1.0 / members[0].sim.params["dt"])
        group.step(2 * steps)
        clock = time.process_time()
        group.step(steps)
        out.append(f"{shape} {1e3 * (time.process_time() - clock) / steps:.3f} ms")
    return f"{body}: " + ", ".join(out) + (" (rolled off)" if off(members) else "")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the blobs and the bars only")
    parser.add_argument("--shape", choices=("ellipsoids", "skin", "both"), default="both")
    parser.add_argument("--cost", action="store_true", help="the process time of a group step at rest instead")
    args = parser.parse_args()
    if args.cost:
        for body in BODIES:
            print(cost(body), flush=True)
        return
    shapes = ("ellipsoids", "skin") if args.shape == "both" else (args.shape,)
    print("| bodies | contact shape | size | drop 0.1 m, deepest | at rest (last second) | 10 m/s | 20 m/s |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for body in ("blobs", "bars") if args.quick else tuple(BODIES):
        for shape in shapes:
            print("| " + " | ".join(row(body, shape)) + " |", flush=True)


if __name__ == "__main__":
    main()
