"""Outside tester 49 (issue 24), second creature: a tentacled blob ("Blob", 1.8 m tall), metaballs converted to mesh
(one fused shell): a squat body on the floor, four tentacles out sideways curling up, two antennae on top.
An 8-bone armature (root + body + 6 tentacle bones) with automatic weights; two hops (frames 1-32, 0.35 m) then a
quarter turn on the spot at constant speed (32-40) and a dead stop at 40, still to 96. Follow 1 on the body,
1 -> 0.15 along each tentacle and antenna (by distance from the body's surface). Floor with Collision.
    blender -b --factory-startup --python-exit-code 1 -P outside_blob.py -- - dev OUT [opts]   (as outside_chubby.py)
opts: repaint (Follow set to 1 everywhere after the first play, no Build, replayed), particles=N look=NAME
+NAME=VALUE looks bake save scrub open=OUT res=R (metaball resolution, 0.035) trace (each part's distance per frame
from the stop on)
"""
import math, os, sys
import bpy
import numpy as np
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import armature, collision_floor, install, link, paint, parent_auto, reports, twin_of

ZIP, KIND, OUT, OPT = rig_parts.options()
FPS, FRAMES, STOP = 24, 96, 40
CENTRE, BODY_R = Vector((0, 0, 0.62)), 0.55


def tentacle_path(k):
    """The k-th tentacle's points (root to tip): 0-3 sideways curling up, 4-5 antennae on top."""
    if k < 4:
        a = k * math.pi / 2 + math.pi / 4
        d = Vector((math.cos(a), math.sin(a), 0))
        return [CENTRE + d * (0.45 + 0.12 * i) + Vector((0, 0, 0.05 * i + 0.012 * i * i)) for i in range(8)]
    sx = 0.18 if k == 4 else -0.18
    return [CENTRE + Vector((sx * (1 + 0.12 * i), 0, 0.45 + 0.1 * i)) for i in range(8)]


def blob_mesh():
    mb = bpy.data.metaballs.new("Blob")
    mb.resolution = mb.render_resolution = float(OPT.get("res", 0.035))
    mb.threshold = 0.45
    e = mb.elements.new(type='ELLIPSOID')
    e.co, e.radius, e.size_x, e.size_y, e.size_z = CENTRE, 1.0, BODY_R, BODY_R, BODY_R * 0.95
    for k in range(6):
        for i, p in enumerate(tentacle_path(k)):
            b = mb.elements.new(type='BALL')
            b.co, b.radius = p, 0.26 - 0.014 * i
    ball = link(bpy.data.objects.new("Blob", mb))
    bpy.ops.object.select_all(action='DESELECT')
    ball.select_set(True)
    bpy.context.view_layer.objects.active = ball
    bpy.ops.object.convert(target='MESH')
    obj = bpy.context.view_layer.objects.active
    obj.name = "Blob"
    v = np.array([x.co for x in obj.data.vertices])
    v[:, 2] -= v[:, 2].min() - 0.004
    obj.data.vertices.foreach_set("co", v.ravel())
    obj.data.update()
    return obj


BONES = [("root", (0, 0, 0), (0, -0.3, 0), None, False), ("body", (0, 0, 0.2), (0, 0, 1.0), "root", True)]
for k in range(6):
    path = tentacle_path(k)
    BONES.append((f"tent{k}", tuple(path[0]), tuple(path[-1]), "body", True))


def animate(arm):
    pb = arm.pose.bones
    for b in pb:
        b.rotation_mode = 'XYZ'
    for f in range(1, STOP + 1):
        t = (f - 1) / 16
        z = 0.35 * abs(math.sin(math.pi * t)) if f <= 32 else 0.0
        turn = (math.pi / 2) * min(max((f - 32) / 8, 0.0), 1.0)
        arm.location = (0, 0, z)
        arm.rotation_euler = (0, 0, turn)
        arm.keyframe_insert("location", frame=f)
        arm.keyframe_insert("rotation_euler", frame=f)


def build_scene():
    rig_parts.empty_scene(FPS, FRAMES)
    obj = blob_mesh()
    v = np.array([x.co for x in obj.data.vertices])
    arm = armature("BlobRig", BONES, lambda b, p: False)
    parent_auto(obj, arm)
    missed = [x.index for x in obj.data.vertices if not any(g.weight > 0 for g in x.groups)]
    if missed:
        obj.vertex_groups["body"].add(missed, 1.0, 'REPLACE')
    animate(arm)
    c = np.array(CENTRE)
    r = np.linalg.norm((v - c) / (BODY_R, BODY_R, BODY_R * 0.95), axis=1)  # 1 on the body's ellipsoid
    out = np.clip((r - 1.05) / (r.max() - 1.05), 0, 1)
    follow = (1 - 0.85 * out).round(3)
    paint(obj, "Follow", follow)
    collision_floor()
    twin = twin_of(obj)
    tips = np.where(out >= 0.5)[0]
    parts = dict(tentacles=tips[v[tips, 2] < 1.15], antennae=tips[v[tips, 2] >= 1.15])
    print(f"BLOB {len(v)} vertices, {len(obj.data.polygons)} faces, shells "
          f"{np.unique(rig_parts.shells(obj), return_counts=True)[1].tolist()}, box {v.min(0).round(3).tolist()} "
          f"{v.max(0).round(3).tolist()}, missed weights {len(missed)}", {k: len(i) for k, i in parts.items()},
          "core", int((follow >= 0.999).sum()))
    return obj, twin, parts, follow


def repaint(shot):
    """The artist repaints Follow 1 everywhere (no Build), then plays again."""
    obj = shot.obj
    obj.vertex_groups["Follow"].add(list(range(len(obj.data.vertices))), 1.0, 'REPLACE')
    shot.play("repainted Follow 1")
    print("PANEL AFTER REPAINT", reports(shot.H.draw_panels())[:14])


def main():
    name = install(ZIP, KIND)
    import helpers as H
    H.ADDON = name
    obj, twin, parts, follow = build_scene()
    shot = rig_parts.PartsShot(obj, twin, parts, follow, H, FRAMES, STOP, FPS)
    rig_parts.artist_session(shot, H, OPT, OUT, (1, 12, 24, 36, 44, 60, 72, FRAMES),
                             repaint if "repaint" in OPT else None)


rig_parts.reopen(OPT["open"], ZIP, KIND, "Blob") if "open" in OPT else main()
