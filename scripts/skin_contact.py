"""The skin's rest above the floor and the colliders, with the particles' ellipsoids or the skin as the contact
shape (docs/contact.md, "Contact on the skin"; issue 27).

    PYTHONPATH=build/python python3 scripts/skin_contact.py [--quick]

Blender's Suzanne (tests/reference/suzanne_subdivided.npz: 2.66 m wide, 7,958 vertices), the add-on's
defaults (materials.make_simulation: the default material, 1/24 s frames of materials.substeps_for(24) steps,
Graph.from_mesh, Skin of 4 neighbours), dropped with its lowest vertex 0.3 m above the floor (z = 0), onto a
sphere (radius 1 m at the origin) and onto a 30-degree plane ramp (friction 0.5, thickness 5 mm: the
colliders' defaults); 3 s (--quick: 1 s). Printed per scene and particle count, with the ellipsoids and with
the skin as the contact shape: the skin's closest approach to the collider over the run (signed distance,
< 0: inside) and its least distance over the last 0.5 s (on the floor it rests; off the top of the sphere
it rolls after about 3 s, down the ramp it slides: mu 0.5 < tan 30 degrees), both without the push-out
(the skin as skinned), and the process time of a step, also with no collider (free fall: the cost's
baseline, as `scripts/bench colliders`'s "free").
"""

import argparse
import os
import time

import numpy as np

import opdeform as od
from opdeform import materials

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FPS = 24


def suzanne():
    data = np.load(os.path.join(ROOT, "tests", "reference", "suzanne_subdivided.npz"))
    return data["vertices"].astype(np.float64), data["triangles"]


def scene(sim, kind, rest, place=True):
    """Places the collider (or floor; none unless `place`); returns the rest vertices moved to start 0.3 m above
    it."""
    if kind == "floor":
        if place:
            sim.set_floor(0.0, 0.5)
        return rest + (0, 0, 0.3 - rest[:, 2].min())
    if kind == "sphere":
        if place:
            sim.add_collider("sphere", radius=1.0)
        return rest + (0, 0, 1.3 - rest[:, 2].min())
    s, c = np.sin(np.radians(30)), np.cos(np.radians(30))
    if place:
        sim.add_collider("plane", normal=(-s, 0, c), friction=0.5)
    lowest = rest @ np.array([-s, 0, c])
    return rest + np.array([-s, 0, c]) * (0.3 - lowest.min())


def distances(sim, kind, skinned):
    return skinned[:, 2] if kind == "floor" else sim.collider_distances(skinned)


def run(kind, particles, shape, seconds):
    """(the skin's closest approach, its least distance over the last 0.5 s, ms a step) for shape
    "ellipsoids", "skin" or "none" (no collider: free fall, the cost's baseline)."""
    rest, tris = suzanne()
    probe = od.Simulation(od.Graph.from_mesh(rest, tris, particles=4), 1.0)
    start = scene(probe, kind, rest)
    graph = od.Graph.from_mesh(start, tris, particles=particles)
    skin = od.Skin(graph, start)
    steps = materials.substeps_for(FPS)
    sim = materials.make_simulation(graph, dt=1.0 / (FPS * steps))
    scene(sim, kind, rest, shape != "none")
    if shape == "skin":
        sim.set_contact_skin(skin)
    frames, settled, closest, cpu = int(seconds * FPS), [], np.inf, 0.0
    for f in range(frames):
        t0 = time.process_time()
        sim.step(steps)
        cpu += time.process_time() - t0
        d = distances(sim, kind, skin.deform_sim(sim, push_out=False)).min() if shape != "none" else np.inf
        closest = min(closest, d)
        if f >= frames - FPS // 2:
            settled.append(d)
    return closest, min(settled), 1e3 * cpu / (frames * steps)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--particles", type=int, nargs="*", default=[100, 1000])
    parser.add_argument("--scenes", nargs="*", default=["floor", "sphere", "ramp"])
    args = parser.parse_args()
    seconds = 1.0 if args.quick else 3.0
    print("| scene | particles | closest (cm): ellipsoids | skin | last 0.5 s (cm): ellipsoids | skin | "
          "ms a step: no contact | ellipsoids | skin |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for kind in args.scenes:
        for particles in args.particles:
            (c0, r0, ms0), (c1, r1, ms1), (_, _, ms) = (run(kind, particles, shape, seconds)
                                                         for shape in ("ellipsoids", "skin", "none"))
            print(f"| {kind} | {particles} | {100 * c0:.2f} | {100 * c1:.2f} | {100 * r0:.2f} | {100 * r1:.2f} | "
                  f"{ms:.3f} | {ms0:.3f} | {ms1:.3f} |", flush=True)


if __name__ == "__main__":
    main()
