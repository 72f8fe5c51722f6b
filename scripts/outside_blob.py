"""Outside tester 49 (issue 24), second creature: a tentacled blob ("Blob", 1.8 m tall), metaballs converted to mesh
(one fused shell): a squat body on the floor, four tentacles out sideways curling up, two antennae on top.
An 8-bone armature (root + body + 6 tentacle bones) with automatic weights; two hops (frames 1-32, 0.35 m) then a
quarter turn on the spot at constant speed (32-40) and a dead stop at 40, still to 96. Follow 1 on the body,
1 -> 0.15 along each tentacle and antenna (by distance from the body's surface). Floor with Collision.
    blender -b --factory-startup --python-exit-code 1 -P outside_blob.py -- - dev OUT [opts]   (as outside_chubby.py)
opts: repaint (Follow set to 1 everywhere after the first play, no Build, replayed), particles=N look=NAME
+NAME=VALUE looks bake save scrub open=OUT res=R (metaball resolution, 0.035)
"""
import json, math, os, sys
import bpy
import numpy as np
from mathutils import Vector, Euler

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import (armature, artist_enable, base, bake_check, collision_floor, first_panels, install,
                       link, paint, parent_auto, reports, settings, world, twin_of, tuned)

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
    angle = np.arctan2(v[tips, 1], v[tips, 0])
    parts = dict(tentacles=tips[v[tips, 2] < 1.15], antennae=tips[v[tips, 2] >= 1.15])
    print(f"BLOB {len(v)} vertices, {len(obj.data.polygons)} faces, shells "
          f"{np.unique(rig_parts.shells(obj), return_counts=True)[1].tolist()}, box {v.min(0).round(3).tolist()} "
          f"{v.max(0).round(3).tolist()}, missed weights {len(missed)}", {k: len(i) for k, i in parts.items()},
          "core", int((follow >= 0.999).sum()))
    return obj, twin, parts, follow


class Shot(rig_parts.Shot):
    def __init__(self, obj, twin, parts, follow, H):
        super().__init__(obj, twin, parts, follow >= 0.999, H)
        self.size = np.ptp(world(twin)[:, 2])
        self.follow = follow

    def frame(self, f):
        cpu = self.timed(f)
        a, b, d, st = self.against_twin()
        return cpu, dict(core=d[self.core].max(), stretch=st.max(), stretch999=np.percentile(st, 99.9), over=int((st > 1.5).sum()), stretch_edge=int(np.argmax(st)), low=a[:, 2].min(), low_twin=b[:, 2].min(),
                         nan=bool(np.isnan(a).any()), **{k: d[ix].max() for k, ix in self.parts.items()})

    def where(self, e):
        """The worst edge's vertices: rest position, Follow, and which part (or body)."""
        i = int(self.edges[0, e])
        part = [k for k, ix in self.parts.items() if i in ix]
        return dict(rest_len_mm=round(1e3 * (self.obj.data.vertices[i].co - self.obj.data.vertices[int(self.edges[1, e])].co).length, 2), co=[round(c, 3) for c in self.obj.data.vertices[i].co], follow=float(self.follow[i]),
                    part=part[0] if part else "body")

    def play(self, label):
        col, errors, cpu = self.played(FRAMES)
        s, fr = self.obj.opdeform, np.arange(1, FRAMES + 1)
        moving, after = fr <= STOP, fr >= STOP + FPS
        settle = {}
        for k in self.parts:
            late = np.where((fr > STOP) & (col[k] >= 2e-3))[0]
            settle[k] = round((fr[late[-1]] - STOP) / FPS, 2) if len(late) else 0.0
        row = dict(label=label, host=bpy.app.version_string, particles=s.particles, look=self.look(),
                   size_m=round(self.size, 3), core_mm=round(1e3 * col["core"].max(), 3),
                   moving_pct={k: round(100 * col[k][moving].max() / self.size, 2) for k in self.parts},
                   moving_mm={k: round(1e3 * col[k][moving].max(), 1) for k in self.parts},
                   after_1s_mm={k: round(1e3 * col[k][after].max(), 3) for k in self.parts},
                   settle_s_2mm=settle, stretch=round(col["stretch"].max(), 3),
                   stretch_p99_9=round(col["stretch999"].max(), 3),
                   edges_over_1_5x_worst_frame=int(col["over"].max()), edges=self.edges.shape[1],
                   stretch_frame=int(fr[np.argmax(col["stretch"])]),
                   stretch_at=self.where(col["stretch_edge"][np.argmax(col["stretch"])]),
                   floor_pen_mm=round(-1e3 * min(col["low"].min(), 0.0), 2),
                   lowest_twin_mm=round(1e3 * col["low_twin"].min(), 2), nan=bool(col["nan"].any()),
                   base_kept=bool(np.array_equal(base(self.obj), self.before)), errors=errors[:3],
                   cpu_ms_frame=round(1e3 * cpu / FRAMES, 2))
        print("ROW " + json.dumps(row, default=float), flush=True)
        print("PANEL", reports(self.H.draw_panels()))
        return row


def scrub(obj, shot):
    """The artist scrubs: frame 30 and 60 shown after a straight play, then 96 -> 30, 10 -> 60 (a jump ahead),
    1 -> 60 again: each against the straight play (mm) and the armature-only twin (mm)."""
    sc, ref = bpy.context.scene, {}
    for f in range(1, 61):
        sc.frame_set(f)
        if f in (30, 60):
            ref[f] = world(obj)
    for a, b in ((96, 30), (10, 60), (1, 60)):
        sc.frame_set(a)
        sc.frame_set(b)
        print(f"SCRUB {a}->{b} vs straight play mm", round(1e3 * np.abs(world(obj) - ref[b]).max(), 3),
              "vs armature-only mm", round(1e3 * np.abs(world(obj) - world(shot.twin)).max(), 3),
              "error", repr(obj.opdeform.error))


def main():
    name = install(ZIP, KIND)
    import helpers as H
    H.ADDON = name
    obj, twin, parts, follow = build_scene()
    shot = Shot(obj, twin, parts, follow, H)
    bpy.context.scene.frame_set(1)
    s = artist_enable(obj, OPT.get("particles"))
    tuned(s, OPT)
    first_panels(obj, H, settings(s))
    shot.play("default")
    if "repaint" in OPT:  # the artist repaints Follow 1 everywhere (no Build), then plays again
        obj.vertex_groups["Follow"].add(list(range(len(obj.data.vertices))), 1.0, 'REPLACE')
        shot.play("repainted Follow 1")
        print("PANEL AFTER REPAINT", reports(H.draw_panels())[:14])
    if "scrub" in OPT:
        scrub(obj, shot)
    if "bake" in OPT:
        bake_check(obj, H, OUT, (1, 12, 24, 36, 44, 60, 72, FRAMES))
    if "looks" in OPT:
        for look in ("Subtle", "Fleshy", "Floppy"):
            print("LOOK ->", look, bpy.ops.opdeform.apply_preset(preset=look), settings(s))
            shot.play(look)
    if "save" in OPT:
        rig_parts.save(obj, OUT)



rig_parts.reopen(OPT["open"], ZIP, KIND, "Blob") if "open" in OPT else main()
