"""Suzanne against Blender's Soft Body and Cloth in one Blender run, goals and a collider on (issue 18).

Run by `scripts/bench addon` (benchmarks/addon.py) through common.blender_json: Debian's Blender, one thread
(`-t 1`). Suzanne (primitive_monkey_add, size 0.6, a Subdivision of 2 levels applied: 7,958 vertices) is
keyframed from z = 1.7 down to z = 1.25 over frames 1..40 (it then stays), so its chin sinks 0.05 m into a
UV sphere (radius 1 at the origin, 1,152 triangles) that carries a Collision modifier: the goal pulls it into
the sphere and the contact pushes it out. Gravity on, 24 fps, 60 frames.

- opdeform at 100 and 1,000 particles, stiffness 1e6, Goal on (strength 0.5, every vertex), Scene Colliders
  on; and the same without goal and colliders (for the cost of the two), each in a scene of its own.
- Soft Body: Goal on (Blender's defaults: every vertex at goal 0.7, stiffness 0.5), its default edges and
  collision with the sphere.
- Cloth: Blender's defaults, a pin group ("Goal", 0.7 on every vertex: goal springs of pin stiffness 1),
  collision with the sphere on (its default).

Blender simulates Soft Body only in the window's scene, so the run has two passes, each from a fresh file:
the opdeform scenes with Soft Body in the window's scene, then the same with Cloth. In each pass every frame
steps every scene in turn (interleaved); ms = process time of scene.frame_set, median of frames 2..60, and
its wall time in a second table; solver ms = the add-on's own sim.step time per frame (wall time: the add-on
measures no other). The ratios are taken inside one pass.
"""

import json
import os
import sys

HERE = os.path.abspath(__file__)
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
FRAMES = 60
PARTICLES = (100, 1000)
STIFFNESS = 1e6
GOAL = 0.7  # Soft Body's default goal weight; Cloth's pin weight
AIM = 50.0  # Soft Body / opdeform at 100 particles, goals and colliders on


def _suzanne(scene):
    import helpers as H
    obj = H.monkey_in(scene, 2)
    obj.location = (0.0, 0.0, 1.7)
    obj.keyframe_insert("location", frame=1)
    obj.location = (0.0, 0.0, 1.25)
    obj.keyframe_insert("location", frame=40)
    return obj


def _collider(scene):
    import helpers as H
    import suite_colliders
    H.move_to(suite_colliders.collider("sphere", name=f"Sphere {scene.name}"), scene)


def _opdeform(scene, particles, features):
    import bpy
    obj = _suzanne(scene)
    s = obj.opdeform
    s.particles, s.stiffness = particles, STIFFNESS
    s.use_goal, s.goal_strength = features, 0.5
    obj.opdeform_contact.use_colliders = features
    with bpy.context.temp_override(scene=scene):
        bpy.ops.opdeform.enable(object=obj.name)
    assert s.built and not s.error, s.error
    return obj


def _soft_body(scene):
    obj = _suzanne(scene)
    obj.modifiers.new("Softbody", 'SOFT_BODY')
    sb = obj.soft_body
    sb.use_goal, sb.goal_default = True, GOAL
    scene.frame_end = 250
    return obj


def _cloth(scene):
    obj = _suzanne(scene)
    group = obj.vertex_groups.new(name="Goal")
    group.add(list(range(len(obj.data.vertices))), GOAL, 'REPLACE')
    cloth = obj.modifiers.new("Cloth", 'CLOTH')
    cloth.settings.vertex_group_mass = "Goal"
    cloth.collision_settings.use_collision = True
    return obj


def _scenes(blender_kind):
    """{label: (scene, object)}: opdeform's variants in scenes of their own, Blender's solver in the window's."""
    import bpy
    sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
    import helpers as H
    H.fresh()
    out = {}
    for particles in PARTICLES:
        for features in (True, False):
            scene = bpy.data.scenes.new(f"opdeform {particles} {'goal+collider' if features else 'plain'}")
            _collider(scene)
            out[f"opdeform {particles}{'' if features else ' plain'}"] = (scene, _opdeform(scene, particles,
                                                                                           features))
    scene = bpy.context.scene
    _collider(scene)
    out[blender_kind] = (scene, _soft_body(scene) if blender_kind == "Soft Body" else _cloth(scene))
    return out, H


def _play(scenes, H):
    """The interleaved frames (helpers.play_interleaved) and each scene's vertex and particle counts."""
    out = H.play_interleaved(scenes, FRAMES)
    for label, (scene, obj) in scenes.items():
        engine = H.runtime().get(obj)
        out[label].update(vertices=len(obj.data.vertices),
                          particles=engine.engine.graph.n_particles if engine is not None else None)
    return out


def inside(out_path):
    import bpy
    result = {"host": f"Blender {bpy.app.version_string}", "frames": FRAMES}
    for kind in ("Soft Body", "Cloth"):
        scenes, H = _scenes(kind)
        result[kind] = _play(scenes, H)
        print(kind, json.dumps(result[kind]), flush=True)
    with open(out_path, "w") as f:
        json.dump(result, f)
    print("SUZANNE_BENCH", out_path)


def report(result):
    """Prints the tables and returns the aims (what, measured, aim, met) for common.print_aims."""
    from .common import table
    rows, walls, aims = [], [], []
    for kind in ("Soft Body", "Cloth"):
        r = result[kind]
        theirs = r[kind]["ms"]
        for particles in PARTICLES:
            on, off = r[f"opdeform {particles}"], r[f"opdeform {particles} plain"]
            rows.append((f"{particles} particles, {kind} pass", f"{on['ms']:.2f}", f"{on['solver_ms']:.3f}",
                         f"{off['ms']:.2f}", f"{on['ms'] / off['ms']:.2f}", f"{kind} {theirs:.1f}",
                         f"{theirs / on['ms']:.0f}x", f"{theirs / off['ms']:.0f}x"))
            walls.append((rows[-1][0], f"{on['wall_ms']:.2f}", f"{off['wall_ms']:.2f}",
                           f"{kind} {r[kind]['wall_ms']:.1f}", f"{r[kind]['wall_ms'] / on['wall_ms']:.0f}x"))
            if kind == "Soft Body" and particles == 100:
                aims.append((f"Suzanne ({on['vertices']:,} vertices, {result['frames']} frames), 100 particles, "
                             "goals + a collider, Soft Body / opdeform per frame", f"{theirs / on['ms']:.0f}x",
                             f">= {AIM:g}x", theirs / on["ms"] >= AIM))
    print(f"{result['host']}, one process, -t 1, frames interleaved; ms = process time of scene.frame_set, "
          f"median of frames 2..{result['frames']}; solver ms: the add-on's own sim.step time (wall)")
    table(rows, ["opdeform", "ms goal+collider", "solver ms", "ms plain", "goal+collider/plain",
                 "Blender ms (goal+collider)", "ratio", "ratio to plain"])
    print("\nthe same frames in wall time (ms)")
    table(walls, ["opdeform", "wall ms goal+collider", "wall ms plain", "Blender wall ms", "ratio"])
    return aims


if __name__ == "__main__" and "--inside" in sys.argv:
    inside(sys.argv[sys.argv.index("--inside") + 1])
