"""The skin's rest above the floor and the colliders, with the particles' ellipsoids or the skin as the contact
shape (docs/contact.md, "Contact on the skin"; issue 27).

    PYTHONPATH=build/python python3 scripts/skin_contact.py [--quick]
    PYTHONPATH=build/python:scripts python3 scripts/skin_contact.py --blender   # the add-on in Debian's Blender
    PYTHONPATH=build/python python3 scripts/skin_contact.py --picture docs/images   # contact_skin.png
    PYTHONPATH=build/python python3 scripts/skin_contact.py --soft   # soft balls flattened on the floor

Blender's Suzanne (tests/reference/suzanne_subdivided.npz: 2.66 m wide, 7,958 vertices), the add-on's
defaults (materials.make_simulation: the default material, 1/24 s frames of materials.substeps_for(24) steps,
Graph.from_mesh, Skin of 4 neighbours), dropped with its lowest vertex 0.3 m above the floor (z = 0), onto a
sphere (radius 1 m at the origin) and onto a 30-degree plane ramp (friction 0.5, thickness 5 mm: the
colliders' defaults); 2 s (--quick: 1 s). Printed per scene and particle count, with the ellipsoids and with
the skin as the contact shape: the skin's closest approach to the collider over the run (signed distance,
< 0: inside) and its least distance over the last 0.5 s (on the floor it rests; off the top of the sphere
it rolls after 2-3 s, down the ramp it slides: mu 0.5 < tan 30 degrees), both without the push-out
(the skin as skinned), and the process time of a step, also with no collider (free fall: the cost's
baseline, as `scripts/bench colliders`'s "free").

--blender: the same drops in Debian's Blender with the add-on (one thread): Suzanne (primitive_monkey_add, 2.7 m,
a Subdivision of one level applied, 1,968 vertices), 100 and 1,000 particles, the add-on's defaults, onto its
Floor, a UV sphere (radius 1, 48 x 24) or a 30-degree ramp (an 8 m grid) with a Collision modifier (Outer
Thickness 0.02, Blender's default, and 0.08: the add-on keeps a quarter); the shown mesh's closest approach over 2 s (the sphere's distance
from its sampled mesh, as the add-on's collider) and its least distance over the last 0.5 s, with the skin (the
add-on's) and with the ellipsoids (``set_contact_skin(None)`` on the object's simulation).
"""

import argparse
import json
import os
import sys
import time

import numpy as np

if "--inside" not in sys.argv:
    import opdeform as od
    from opdeform import materials

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FPS = 24
SECONDS = 2  # before the body reaches the ramp's rim in Blender (an 8 m grid), or rolls off the sphere's top


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


def drop(kind, particles, shape):
    """(the simulation, its skin, substeps a frame) of a drop onto `kind` before its first step; shape
    "ellipsoids", "skin" or "none" (no collider)."""
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
    return sim, skin, steps


def settle(kind, particles, shape, seconds):
    """The simulation and skin of a drop after `seconds`."""
    sim, skin, steps = drop(kind, particles, shape)
    sim.step(int(seconds * FPS) * steps)
    return sim, skin


def section(v, tris, y):
    """The mesh's cut by the plane at y: segments (k, 2, 2) of (x, z)."""
    d = v[tris][:, :, 1] - y
    segments = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        cross = d[:, a] * d[:, b] < 0.0
        s = d[cross, a] / (d[cross, a] - d[cross, b])
        p = v[tris[cross, a]] + s[:, None] * (v[tris[cross, b]] - v[tris[cross, a]])
        segments.append((np.flatnonzero(cross), p[:, [0, 2]]))
    points = {}
    for faces, p in segments:
        for f, q in zip(faces, p):
            points.setdefault(f, []).append(q)
    return np.array([q[:2] for q in points.values() if len(q) >= 2])


def picture(out):
    """Suzanne at rest (100 particles) on the floor (3 s) and on the sphere (2 s, before it rolls off) with its
    ellipsoids and with its skin as the contact shape: the skinned mesh (no push-out) cut through its lowest
    vertex, and the surface cut by the same plane."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    tris = suzanne()[1]
    fig, axes = plt.subplots(2, 2, figsize=(9, 6))
    for row, (kind, seconds) in enumerate((("floor", 3.0), ("sphere", 2.0))):
        for col, shape in enumerate(("ellipsoids", "skin")):
            sim, skin = settle(kind, 100, shape, seconds)
            v = skin.deform_sim(sim, push_out=False)
            gap = v[:, 2].min() if kind == "floor" else sim.collider_distances(v).min()
            low = v[np.argmin(v[:, 2] if kind == "floor" else sim.collider_distances(v))]
            ax = axes[row, col]
            cut = low[1] + 1e-4  # not through the vertex itself: the cut would miss its triangles
            ax.add_collection(LineCollection(section(v, tris, cut), colors="tab:blue", linewidths=1.0))
            if kind == "floor":
                ax.axhline(0.0, color="0.4")
            else:
                t = np.linspace(-np.pi, np.pi, 400)
                r = np.sqrt(max(1.0 - cut ** 2, 0.0))
                ax.plot(r * np.cos(t), r * np.sin(t), color="0.4")
            ax.set_xlim(low[0] - 0.5, low[0] + 0.5)
            ax.set_ylim(low[2] - 0.1, low[2] + 0.3)
            ax.set_aspect("equal")
            ax.set_title(f"{kind}, {shape}: the skin {round(100 * gap, 2) + 0.0:.2f} cm from it", fontsize=9)
    fig.suptitle("Suzanne (2.7 m, 100 particles) at rest, cut through its vertex nearest the surface (m)")
    fig.tight_layout()
    path = os.path.join(out, "contact_skin.png")
    fig.savefig(path, dpi=110)
    print("wrote", path)


def soft():
    """A 0.6 m ball (60 particles, 10 iterations) dropped 0.3 m on the floor, k = 1e4-1e6, at 1/24 and 1/240 s:
    the skin's rest above the floor after 4 s with the ellipsoids and with the skin, and the ball's height."""
    from opdeform import meshes
    v, t = meshes.capsule(radius=0.3, length=0.0)
    graph = od.Graph.from_mesh(v, t, particles=60)
    skin = od.Skin(graph, v)
    print("| k | step | skin above the floor (cm): ellipsoids | skin | height (m): ellipsoids | skin |")
    print("| --- | --- | --- | --- | --- | --- |")
    for k in (1e4, 1e5, 1e6):
        for fps in (24, 240):
            cells = []
            for shape in ("ellipsoids", "skin"):
                sim = od.Simulation(graph, k, dt=1.0 / fps)
                sim.set_floor(0.0, 0.5)
                start = graph.centers + (0, 0, 0.3 - v[:, 2].min())
                sim.set_state(start, np.tile(np.eye(3), (graph.n_particles, 1, 1)))
                if shape == "skin":
                    sim.set_contact_skin(skin)
                sim.step(4 * fps)
                cells.append(skin.deform_sim(sim, push_out=False)[:, 2])
            print(f"| {k:g} | 1/{fps} s | {round(100 * cells[0].min(), 2) + 0.0:.2f} | "
                  f"{round(100 * cells[1].min(), 2) + 0.0:.2f} | {np.ptp(cells[0]):.3f} | {np.ptp(cells[1]):.3f} |")


def run(kind, particles, shape, seconds):
    """(the skin's closest approach, its least distance over the last 0.5 s, ms a step) for shape
    "ellipsoids", "skin" or "none" (no collider: free fall, the cost's baseline)."""
    sim, skin, steps = drop(kind, particles, shape)
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


# -- inside Blender ------------------------------------------------------------------------------------------
BLENDER_SCENES = [(kind, thickness) for kind in ("floor", "sphere", "ramp")
                  for thickness in ((None,) if kind == "floor" else (0.02, 0.08))]


def _blender_drop(kind, thickness, particles, skin_shape):
    import bpy
    import helpers as H
    import suite_colliders
    H.fresh()
    normal = np.array([np.sin(np.radians(30.0)), 0.0, np.cos(np.radians(30.0))]) if kind == "ramp" else np.eye(3)[2]
    if kind != "floor":
        c = suite_colliders.collider(kind)
        c.collision.thickness_outer = thickness
        m = np.array(c.matrix_world)
        verts = np.array([v.co[:] for v in c.data.vertices]) @ m[:3, :3].T + m[:3, 3]
        c.data.calc_loop_triangles()
        tris = np.array([t.vertices[:] for t in c.data.loop_triangles], np.int32)
        if kind == "sphere":  # the distance from the sphere's mesh, sampled as the add-on's collider is
            probe = od.Simulation(od.Graph.from_mesh(verts, tris, particles=20), 1.0)
            probe.add_collider("mesh", vertices=verts, triangles=tris)
    bpy.ops.mesh.primitive_monkey_add()
    obj = bpy.context.active_object
    obj.modifiers.new("Subdivision", 'SUBSURF').levels = 1
    bpy.ops.object.modifier_apply(modifier="Subdivision")
    rest = np.array([v.co[:] for v in obj.data.vertices])
    above = 1.3 if kind == "sphere" else 0.3
    obj.location = tuple(normal * (above - (rest @ normal).min()))
    s = obj.opdeform
    s.particles, s.use_floor = particles, kind == "floor"
    bpy.ops.opdeform.enable(object=obj.name)
    assert s.built and not s.error, s.error
    if not skin_shape:
        engine = H.runtime().get(obj).engine
        engine.sim.set_contact_skin(None)
        engine.invalidate()
    gaps = []
    for f in range(1, SECONDS * FPS + 1):
        bpy.context.scene.frame_set(f)
        assert not s.error, s.error
        m = np.array(obj.matrix_world)
        shown = H.positions(obj).astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        gaps.append(float((shown @ normal).min() if kind != "sphere" else probe.collider_distances(shown).min()))
    return min(gaps), min(gaps[-FPS // 2:])


def _inside_blender(out_path):
    sys.path.insert(0, os.environ["OPDEFORM_PYTHONPATH"])
    global od
    import opdeform as od
    result = []
    for kind, thickness in BLENDER_SCENES:
        for particles in (100, 1000):
            row = [kind, thickness, particles]
            for skin_shape in (False, True):
                row += _blender_drop(kind, thickness, particles, skin_shape)
            result.append(row)
    with open(out_path, "w") as f:
        json.dump(result, f)
    print("SKIN_CONTACT", out_path)


def blender():
    from benchmarks.common import blender_json, out_dir
    data = os.path.join(out_dir("skin_contact"), "blender.json")
    rows = blender_json(os.path.abspath(__file__), "SKIN_CONTACT", data)
    if rows is None:
        return
    print("| scene | Outer Thickness (m) | particles | closest (cm): ellipsoids | skin | last 0.5 s (cm): ellipsoids "
          "| skin |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for kind, thickness, particles, c0, r0, c1, r1 in rows:
        print(f"| {kind} | {thickness or ''} | {particles} | {100 * c0:.2f} | {100 * c1:.2f} | {100 * r0:.2f} | "
              f"{100 * r1:.2f} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--blender", action="store_true")
    parser.add_argument("--picture", metavar="DIR")
    parser.add_argument("--soft", action="store_true")
    parser.add_argument("--particles", type=int, nargs="*", default=[100, 1000])
    parser.add_argument("--scenes", nargs="*", default=["floor", "sphere", "ramp"])
    args = parser.parse_args()
    if args.blender:
        blender()
        return
    if args.picture:
        picture(args.picture)
        return
    if args.soft:
        soft()
        return
    seconds = 1.0 if args.quick else SECONDS
    print("| scene | particles | closest (cm): ellipsoids | skin | last 0.5 s (cm): ellipsoids | skin | "
          "ms a step: no contact | ellipsoids | skin |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for kind in args.scenes:
        for particles in args.particles:
            (c0, r0, ms0), (c1, r1, ms1), (_, _, ms) = (run(kind, particles, shape, seconds)
                                                         for shape in ("ellipsoids", "skin", "none"))
            cm = [f"{round(100 * d, 2) + 0.0:.2f}" for d in (c0, c1, r0, r1)]  # + 0.0: no "-0.00"
            print(f"| {kind} | {particles} | {' | '.join(cm)} | {ms:.3f} | {ms0:.3f} | {ms1:.3f} |", flush=True)


if __name__ == "__main__" and "--inside" in sys.argv:
    sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
    _inside_blender(sys.argv[sys.argv.index("--inside") + 1])
elif __name__ == "__main__":
    main()
