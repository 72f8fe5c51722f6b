"""The skin's rest above the floor and the colliders, with the particles' ellipsoids or the skin as the contact
shape (docs/contact.md, "Contact on the skin"; issue 27).

    PYTHONPATH=build/python python3 scripts/skin_contact.py [--quick]

Blender's Suzanne (tests/reference/suzanne_subdivided.npz: 2.66 m wide, 7,958 vertices), the add-on's
defaults (materials.make_simulation: the default material, 1/24 s frames of materials.substeps_for(24) steps,
Graph.from_mesh, Skin of 4 neighbours), dropped with its lowest vertex 0.3 m above the floor (z = 0), onto a
sphere (radius 1 m at the origin) and onto a 30-degree plane ramp (friction 0.5, thickness 5 mm: the
colliders' defaults); 3 s (--quick: 1 s). Printed per scene, particle count and shape: the skin's least
signed distance to the collider over the last 0.5 s (its rest: above > 0), its deepest dip over the run
(< 0: inside), both without the push-out (the skin as skinned), and the solver's ms a step (process time).
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


def scene(sim, kind, rest):
    """Places the collider (or floor); returns the rest vertices moved to start 0.3 m above it."""
    if kind == "floor":
        sim.set_floor(0.0, 0.5)
        return rest + (0, 0, 0.3 - rest[:, 2].min())
    if kind == "sphere":
        sim.add_collider("sphere", radius=1.0)
        return rest + (0, 0, 1.3 - rest[:, 2].min())
    s, c = np.sin(np.radians(30)), np.cos(np.radians(30))
    sim.add_collider("plane", normal=(-s, 0, c), friction=0.5)
    lowest = rest @ np.array([-s, 0, c])
    return rest + np.array([-s, 0, c]) * (0.3 - lowest.min())


def distances(sim, kind, skinned):
    return skinned[:, 2] if kind == "floor" else sim.collider_distances(skinned)


def run(kind, particles, skin_shape, seconds):
    rest, tris = suzanne()
    probe = od.Simulation(od.Graph.from_mesh(rest, tris, particles=4), 1.0)
    start = scene(probe, kind, rest)
    graph = od.Graph.from_mesh(start, tris, particles=particles)
    skin = od.Skin(graph, start)
    steps = materials.substeps_for(FPS)
    sim = materials.make_simulation(graph, dt=1.0 / (FPS * steps))
    scene(sim, kind, rest)
    if skin_shape:
        sim.set_contact_skin(skin)
    frames, settled, deepest, cpu = int(seconds * FPS), [], np.inf, 0.0
    for f in range(frames):
        t0 = time.process_time()
        sim.step(steps)
        cpu += time.process_time() - t0
        d = distances(sim, kind, skin.deform_sim(sim, push_out=False)).min()
        deepest = min(deepest, d)
        if f >= frames - FPS // 2:
            settled.append(d)
    return min(settled), deepest, 1e3 * cpu / (frames * steps)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--particles", type=int, nargs="*", default=[100, 1000])
    parser.add_argument("--scenes", nargs="*", default=["floor", "sphere", "ramp"])
    args = parser.parse_args()
    seconds = 1.0 if args.quick else 3.0
    print("| scene | particles | shape | skin's rest above (cm) | deepest dip (cm) | ms a step |")
    print("| --- | --- | --- | --- | --- | --- |")
    for kind in args.scenes:
        for particles in args.particles:
            for skin_shape in (False, True):
                rest, dip, ms = run(kind, particles, skin_shape, seconds)
                shape = "skin" if skin_shape else "ellipsoids"
                print(f"| {kind} | {particles} | {shape} | {100 * rest:.2f} | {100 * min(dip, 0.0):.2f} | {ms:.3f} |",
                      flush=True)


if __name__ == "__main__":
    main()
