"""Outside tester (issue 24): a fat-bellied 1.6 m pig the add-on has not seen, trotting two strides and stopping
dead. One object: a body blocked out with the Skin modifier (+ Subdivision, applied) along a horizontal spine,
four short legs and a thin tail, its belly pushed 11 cm down and a jowl pushed down and out under the jaw; two
floppy ears made of metaball ellipsoids converted to mesh and joined in (separate shells). A 9-bone armature
(root, hips, spine, neck, head, tail, four legs) with automatic weights (any vertex they miss weighted 1 to the
head, tail or hips as an artist would); a trot keyed over frames 1-48 (two strides of 0.7 m, diagonal legs together, the
body bobbing twice a stride), then still until 96; a floor with a Collision modifier. Follow 1 on the core,
falling to 0.15 over the belly and the jowl, 1 -> 0.15 out to the ear tips, 1 -> 0.3 out along the tail.

    blender -b --factory-startup --python-exit-code 1 -P scripts/outside_pig.py -- - dev OUT [opts]
    bpy-python scripts/outside_pig.py - dev OUT [opts]      (both with OPDEFORM_PYTHONPATH=$PWD/build/python)
    (or ZIP legacy / ZIP extension: the packaged add-on installed as a new user does)
opts: particles=N (set before Enable), look=NAME (a look applied after Enable), +NAME=VALUE (an obj.opdeform setting
after Enable and the look, e.g. +damping_rate=12), floor=Z (the floor's height, 0: the hooves 4 mm over it; none: no
floor), bleed (the belly's push and paint not stopped at the legs: Follow 0.75-0.99 down the legs), trace=PART
(belly, jowl, ears or tail: its distance per frame, and the farthest vertex at the last frame), looks (Subtle,
Fleshy, Floppy from the look menu, each replayed), bake (after the first replay: bake, compare with playback, free),
save (frame 30 and the file into OUT, after the replays; then open=OUT reopens it: is frame 30 the simulated pose,
before and after a frame change?), render=F (Workbench, frame F, after every replay: a strip OUT/pig_LABEL_F.png,
the armature-only twin left and OPDeform right, side view above a 3/4 front view).
The artist's order: Enable (Physics tab), tick Goal, pick the Follow group, play. Every replay prints a ROW line
(JSON): the core's (Follow 1) largest distance to the armature-only pose, each loose part's largest distance
during the trot (mm and % of the body's length) and in the second after the stop (%), the largest from 1 s after
the stop and when each last moved 2 mm (s after the stop), edge stretch against the animated length, floor
penetration, base mesh kept, errors, CPU ms per frame of frame_set alone (ARMATURE ONLY: the same before Enable).
"""
import json, math, os, sys
import bpy
import numpy as np
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import (armature, artist_enable, base, bake_check, collision_floor, first_panels,  # noqa: E402
                       gauss, install, link, paint, parent_auto, reports, reshaped, settings, skin_body, taper,
                       tuned, twin_of, world)

ZIP, KIND, OUT, OPT = rig_parts.options()
FPS, FRAMES, STOP, STRIDE = 24, 96, 48, 24

# the Skin skeleton: spine from the rump (0) to the snout tip (8), tail 9-10, legs from node 12 on
NODES = [((0, 0.50, 0.62), 0.22), ((0, 0.28, 0.63), 0.30), ((0, 0.0, 0.63), 0.33), ((0, -0.28, 0.65), 0.30),
         ((0, -0.45, 0.68), 0.25), ((0, -0.57, 0.71), 0.21), ((0, -0.70, 0.73), 0.19), ((0, -0.84, 0.67), 0.12),
         ((0, -0.93, 0.65), 0.09), ((0, 0.76, 0.66), 0.045), ((0, 0.92, 0.60), 0.03)]
EDGES = [(k, k + 1) for k in range(8)] + [(0, 9), (9, 10)]
LEGS = {"leg.FL": (0.15, -0.33), "leg.FR": (-0.15, -0.33), "leg.HL": (0.15, 0.33), "leg.HR": (-0.15, 0.33)}
for x, y in LEGS.values():
    k = len(NODES)
    NODES += [((x, y, 0.44), 0.11), ((x, y, 0.22), 0.08), ((x, y, 0.05), 0.07)]
    EDGES += [(1 if y > 0 else 3, k), (k, k + 1), (k + 1, k + 2)]

BONES = [("root", (0, 0, 0), (0, -0.3, 0), None, False),
         ("hips", (0, 0.50, 0.63), (0, 0.0, 0.63), "root", True),
         ("spine", (0, 0.0, 0.63), (0, -0.45, 0.68), "hips", True),
         ("neck", (0, -0.45, 0.68), (0, -0.62, 0.72), "spine", True),
         ("head", (0, -0.62, 0.72), (0, -0.97, 0.65), "neck", True),
         ("tail", (0, 0.64, 0.65), (0, 0.94, 0.59), "hips", True)]
BONES += [(name, (x, y, 0.46), (x, y, 0.03), "spine" if y < 0 else "hips", True) for name, (x, y) in LEGS.items()]


def body_mesh():
    """Skin + Subdivision 2, applied; the belly pushed 11 cm down (not the legs below the body), the jowl 6 cm
    down and 3 cm out. The body and per vertex its belly and jowl weights (0..1)."""
    obj = skin_body("Pig", NODES, EDGES, int(OPT.get("levels", 2)))

    def push(v):
        near_leg = np.min([np.hypot(v[:, 0] - x, v[:, 1] - y) for x, y in LEGS.values()], axis=0) < 0.13
        leg = near_leg * np.clip((0.36 - v[:, 2]) / 0.08, 0, 1) * ("bleed" not in OPT)  # below the underside
        belly = gauss(v, (0, 0.0, 0.32), (0.24, 0.36, 0.16)) * (v[:, 2] < 0.6) * (np.abs(v[:, 0]) < 0.34) * (1 - leg)
        jowl = gauss(v, (0, -0.70, 0.55), (0.17, 0.10, 0.08)) * (v[:, 2] < 0.72)
        v[:, 2] -= 0.11 * belly + 0.06 * jowl
        v[:, 0] += 0.03 * jowl * np.sign(v[:, 0])
        return belly, jowl
    return (obj, *reshaped(obj, push))  # the hooves 4 mm over the floor


EAR_ROOT, EAR_LENGTH = (0.09, -0.64, 0.86), 0.26


def ears(obj):
    """Two floppy ears as a modeller makes them: a flat metaball ellipsoid each from the top of the head, hanging
    out, forward and down, converted to mesh and joined into the body (separate shells). Per ear its vertex
    indices and each vertex's parameter from the root (0) to the tip (1)."""
    mb = bpy.data.metaballs.new("Ears")
    mb.resolution = mb.render_resolution = 0.02
    for sx in (1, -1):
        e = mb.elements.new(type='ELLIPSOID')
        down = Vector((0.5 * sx, -0.7, -0.5)).normalized()
        e.co = Vector((sx * EAR_ROOT[0], EAR_ROOT[1], EAR_ROOT[2])) + 0.5 * EAR_LENGTH * down
        e.radius, e.size_x, e.size_y, e.size_z = 2.0, 0.085, 0.14, 0.03
        e.rotation = Vector((0, 1, 0)).rotation_difference(down)
    ball = link(bpy.data.objects.new("Ears", mb))
    n = len(obj.data.vertices)
    for x in bpy.context.scene.objects:
        x.select_set(x == ball)
    bpy.context.view_layer.objects.active = ball
    bpy.ops.object.convert(target='MESH')
    ear_obj = bpy.context.view_layer.objects.active
    ear_obj.select_set(True)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.join()
    v = np.array([x.co for x in obj.data.vertices])
    parts, param = {}, np.zeros(len(v))
    for name, sx in (("ear.L", 1), ("ear.R", -1)):
        ix = np.arange(n, len(v))[np.sign(v[n:, 0]) == sx]
        d = np.linalg.norm(v[ix] - (sx * EAR_ROOT[0], EAR_ROOT[1], EAR_ROOT[2]), axis=1)
        parts[name], param[ix] = ix, (d - d.min()) / (d.max() - d.min())
    return parts, param


def trot(f):
    """The trot at frame f: (forward metres, bob metres, leg swing phase in radians), still from STOP."""
    t = min(f - 1, STOP - 1) / STRIDE  # strides done
    ease = min(1.0, t / 0.25)  # the first quarter stride speeding up; the stop is dead
    moving = f < STOP
    return 0.7 * t, 0.035 * abs(math.sin(2 * math.pi * t)) * moving * ease, 2 * math.pi * t * moving


def animate(arm):
    """Two trot strides (frames 1-48): diagonal legs swing together (0.45 rad), the body bobs twice a stride and
    nods, the tail wags; from frame 48 on the same still pose."""
    pb = arm.pose.bones
    for b in pb:
        b.rotation_mode = 'XYZ'
    for f in range(1, STOP + 2, 2):
        forward, bob, ph = trot(f)
        pb["root"].location = (0, forward, bob)  # the root bone points -y: its local y is forward
        pb["spine"].rotation_euler = (0.04 * math.sin(2 * ph), 0, 0)
        pb["head"].rotation_euler = (0.12 * math.sin(2 * ph + 1.0), 0, 0)
        pb["tail"].rotation_euler = (0, 0, 0.4 * math.sin(ph))
        for name in LEGS:
            diagonal = 1 if name in ("leg.FL", "leg.HR") else -1
            pb[name].rotation_euler = (0.45 * diagonal * math.sin(ph), 0, 0)
        for b in pb:
            b.keyframe_insert("location" if b.name == "root" else "rotation_euler", frame=f)


def weight_leftovers(obj):
    """Vertices automatic weights missed weighted 1 to the head (the ears) or the nearest bone's deform group,
    as an artist does; how many per group."""
    done = {}
    for v in obj.data.vertices:
        if not any(g.weight > 0 for g in v.groups):
            g = "head" if v.co.y < -0.55 else ("tail" if v.co.y > 0.7 else "hips")
            obj.vertex_groups[g].add([v.index], 1.0, 'REPLACE')
            done[g] = done.get(g, 0) + 1
    return done


def follow_map(n, belly, jowl, ear_parts, tail, param):
    w = np.ones(n)
    w[:len(belly)] = 1 - 0.85 * np.clip(np.maximum(belly, jowl), 0, 1)
    w = taper(w, ear_parts, param, (("ear.L", 0.15), ("ear.R", 0.15)))
    return np.where(tail[0], np.minimum(w, 1 - 0.7 * tail[1]), w).round(3)


def tail_of(v, n_body):
    """The tail: the first n_body vertices (the skinned body) behind the rump (y > 0.70), and each vertex's
    parameter out to the tail's tip."""
    mask = (np.arange(len(v)) < n_body) & (v[:, 1] > 0.70)
    return mask, np.clip((v[:, 1] - 0.70) / (v[mask, 1].max() - 0.70), 0, 1)


class Shot(rig_parts.Shot):
    def __init__(self, obj, twin, parts, follow, H):
        super().__init__(obj, twin, parts, follow >= 0.999, H)
        tw = world(twin)
        self.size = np.ptp(tw[:, 1])
        self.follow = follow

    def frame(self, f):
        cpu = self.timed(f)
        a, b, d, st = self.against_twin()
        return cpu, dict(core=d[self.core].max(), stretch=st.max(), stretch_edge=int(np.argmax(st)),
                         low=a[:, 2].min(), low_twin=b[:, 2].min(), nan=bool(np.isnan(a).any()),
                         far=int(np.argmax(d)),
                         **{k: d[ix].max() for k, ix in self.parts.items()})

    def play(self, label):
        """Frames 1..FRAMES from the start; one ROW of figures."""
        col, errors, cpu = self.played(FRAMES)
        row = self.row(label, col, errors, cpu)
        print("ROW " + json.dumps(row, default=float))
        print("PANEL", reports(self.H.draw_panels()))
        if "trace" in OPT:
            print("TRACE", OPT["trace"], "mm per frame", np.round(1e3 * col[OPT["trace"]], 1).tolist())
            last = col["far"][-1]
            print("TRACE farthest vertex at frame", FRAMES, "rest", np.round(self.obj.data.vertices[last].co, 3)[:],
                  "follow", self.follow[last])
        if "render" in OPT:
            strip(int(OPT["render"]), label.replace(" ", "_"))
        return row

    def row(self, label, col, errors, cpu):
        """The ROW's figures from the per-frame columns."""
        s, fr = self.obj.opdeform, np.arange(1, FRAMES + 1)
        moving, after = fr <= STOP, fr >= STOP + FPS
        worst = int(np.argmax(col["stretch"]))
        e = col["stretch_edge"][worst]
        settle = {}
        for k in self.parts:
            late = np.where((fr > STOP) & (col[k] >= 2e-3))[0]
            settle[k] = round((fr[late[-1]] - STOP) / FPS, 2) if len(late) else 0.0
        return dict(label=label, host=bpy.app.version_string, particles=s.particles, look=self.look(),
                    size_m=round(self.size, 3), core_mm=round(1e3 * col["core"].max(), 3),
                    moving_mm={k: round(1e3 * col[k][moving].max(), 2) for k in self.parts},
                    moving_pct={k: round(100 * col[k][moving].max() / self.size, 2) for k in self.parts},
                    stop_pct={k: round(100 * col[k][(fr > STOP) & ~after].max() / self.size, 2) for k in self.parts},
                    after_1s_mm={k: round(1e3 * col[k][after].max(), 3) for k in self.parts},
                    settle_s_2mm=settle, stretch=round(col["stretch"].max(), 3), stretch_frame=int(fr[worst]),
                    stretch_follow=[float(self.follow[v]) for v in self.edges[:, e]],
                    floor_pen_mm=round(-1e3 * min(col["low"].min(), 0.0), 2),
                    lowest_mm=round(1e3 * col["low"].min(), 2), lowest_twin_mm=round(1e3 * col["low_twin"].min(), 2),
                    nan=bool(col["nan"].any()), base_kept=bool(np.array_equal(base(self.obj), self.before)),
                    errors=errors[:3], cpu_ms_frame=round(1e3 * cpu / FRAMES, 2))


def build_scene():
    rig_parts.empty_scene(FPS, FRAMES)
    obj, belly, jowl = body_mesh()
    ear_parts, param = ears(obj)
    v = np.array([x.co for x in obj.data.vertices])
    tail = tail_of(v, len(belly))
    body = np.arange(len(belly))
    arm = armature("PigRig", BONES, lambda b, p: b in ("spine", "neck", "head"))
    parent_auto(obj, arm)
    leftovers = weight_leftovers(obj)
    animate(arm)
    follow = follow_map(len(v), belly, jowl, ear_parts, tail, param)
    paint(obj, "Follow", follow)
    if OPT.get("floor") != "none":
        collision_floor()
        bpy.data.objects["Floor"].location.z = float(OPT.get("floor", 0.0))
    twin = twin_of(obj)
    parts = dict(belly=body[belly >= 0.3], jowl=body[jowl >= 0.3],
                 ears=np.concatenate([ear_parts["ear.L"], ear_parts["ear.R"]]), tail=np.where(tail[0])[0])
    shell, count = np.unique(rig_parts.shells(obj), return_counts=True)
    print(f"PIG {len(v)} vertices, {len(obj.data.polygons)} faces, shells (vertices) {count.tolist()}, loose vertices "
          f"at {v[shell[count == 1]].round(3).tolist()}, "
          f"box {v.min(0).round(3).tolist()} {v.max(0).round(3).tolist()}, leftovers weighted {leftovers}",
          {k: len(i) for k, i in parts.items()}, "core", int((follow >= 0.999).sum()),
          "follow min per part", {k: float(follow[i].min()) for k, i in parts.items()})
    return obj, twin, parts, follow


def strip(frame, label):
    """Workbench at frame F, side and 3/4 front, the cameras following the trot: the armature-only twin (left) and
    the pig (right) side by side in OUT/pig_LABEL_F.png."""
    sc = bpy.context.scene
    sc.frame_set(frame)
    sc.render.engine = 'BLENDER_WORKBENCH'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 520, 360, 100
    pig, twin = bpy.data.objects["Pig"], bpy.data.objects["Pig_twin"]
    y = -trot(frame)[0]
    tiles = []
    for eye, target in (((2.6, y, 0.45), (0, y, 0.45)), ((1.5, y - 2.1, 1.1), (0, y - 0.3, 0.45))):
        cam = link(bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam")))
        cam.location = Vector(eye)
        cam.rotation_euler = (Vector(target) - cam.location).to_track_quat('-Z', 'Y').to_euler()
        sc.camera = cam
        row = []
        for shown in (twin, pig):
            pig.hide_render, twin.hide_render = shown is twin, shown is pig
            sc.render.filepath = os.path.join(OUT, "tile.png")
            bpy.ops.render.render(write_still=True)
            img = bpy.data.images.load(sc.render.filepath)
            px = np.empty(len(img.pixels), np.float32)
            img.pixels.foreach_get(px)
            row.append(px.reshape(img.size[1], img.size[0], 4))
            bpy.data.images.remove(img)
        tiles.append(np.concatenate(row, axis=1))
        bpy.data.objects.remove(cam)
    pix = np.concatenate(tiles[::-1], axis=0)  # rows bottom-up: the side view on top
    out = bpy.data.images.new("strip", pix.shape[1], pix.shape[0], alpha=True)
    out.pixels.foreach_set(pix.ravel())
    out.filepath_raw, out.file_format = os.path.join(OUT, f"pig_{label}_{frame}.png"), 'PNG'
    out.save()
    os.remove(os.path.join(OUT, "tile.png"))
    pig.hide_render = twin.hide_render = False
    print("RENDER", out.filepath_raw)


def main():
    name = install(ZIP, KIND)
    import helpers as H
    H.ADDON = name
    obj, twin, parts, follow = build_scene()
    shot = Shot(obj, twin, parts, follow, H)
    print("ARMATURE ONLY: CPU ms per frame", round(1e3 * sum(map(shot.timed, range(1, FRAMES + 1))) / FRAMES, 2))
    bpy.context.scene.frame_set(1)
    s = artist_enable(obj, OPT.get("particles"))
    tuned(s, OPT)
    first_panels(obj, H, settings(s, "jiggle_hz"))
    shot.play("default")
    if "bake" in OPT:
        bake_check(obj, H, OUT, (1, 12, 24, 36, 48, 60, 72, FRAMES))
    if "looks" in OPT:
        for look in ("Subtle", "Fleshy", "Floppy"):
            print("LOOK ->", look, bpy.ops.opdeform.apply_preset(preset=look), settings(s, "jiggle_hz"))
            shot.play(look)
    if "save" in OPT:
        rig_parts.save(obj, OUT)


rig_parts.reopen(OPT["open"], ZIP, KIND, "Pig") if "open" in OPT else main()
