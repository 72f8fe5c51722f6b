"""Outside tester (issue 24): a stocky 1.8 m knight the add-on has not seen. One object: a skinned body with a
forward belly (one shell, Skin + Subdivision applied), a ponytail tube, a cape card, a pointed hat and a sword
held in the right hand (separate shells); a 9-bone armature with automatic weights (the sword weighted 1 to the
hand, as an artist would); a jump keyed over frames 1-48, then still until 96; a floor with a Collision modifier.

    blender -b --factory-startup --python-exit-code 1 -P scripts/outside_knight.py -- ZIP legacy OUT [opts]
    bpy-python scripts/outside_knight.py ZIP extension OUT [opts]
    (ZIP "-" and kind dev: the repository's add-on with $OPDEFORM_PYTHONPATH)
opts: particles=N (set before Enable), look=NAME (a look applied after Enable), +NAME=VALUE (an obj.opdeform
setting after Enable and the look, e.g. +damping_rate=12), soft (a Softness group painted 1 - Follow and picked, replayed at
Fleshy, Floppy, Floppy with Stiffness 0.3), looks (after the first playback: Subtle, Fleshy, Floppy from the Goal
panel's menu, each replayed), repaint (Follow: belly 1 by script, replay; belly back to 0.15 in Weight Paint
mode with the Set Weight operator, replay), counts=50,200,400 (Particles changed after playing, Build pressed
when the panel asks, replayed), bake (bake, compare with playback), save (frame 30 and the file into OUT; then
open=OUT reopens it), perparticle (after Enable and
the group: each particle's part, Follow, goal Hz, k and softness as the solver has them), inside (cape and hair vertices inside the body, frames 1-48),
render=F / side=F (Cycles CPU, 8
samples, frame F, the knight and the armature-only twin: OUT/knight_VIEW_F.png, OUT/knight_VIEW_F_twin.png).
The artist's order: Enable (Physics tab), tick Goal, pick the Follow group, play.
Every replay prints a ROW line (JSON): core (follow 1) / per part distance to the armature-only pose, loose
parts' secondary motion in % of 1.8 m during the jump, the largest distance 1 s after it stops, edge stretch,
floor penetration, base mesh kept, errors, CPU ms per frame of frame_set alone.
"""
import json, math, os, sys, time
import bpy, bmesh
import numpy as np
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import (armature, artist_enable, base, collision_floor, first_panels, install, link,  # noqa: E402
                       paint, parent_auto, reopen, reports, settings, skin_body, taper, tuned, twin_of, world)

ZIP, KIND, OUT, OPT = rig_parts.options()
FPS, FRAMES, STOP, HEIGHT = 24, 96, 48, 1.8

# the Skin modifier's skeleton: (position, radius); edges by index
NODES = [((0, 0, 0.92), 0.17), ((0, 0, 1.15), 0.19), ((0, 0, 1.38), 0.2), ((0, 0, 1.53), 0.07),
         ((0, 0, 1.66), 0.12)]
for sx in (1, -1):
    NODES += [((0.12 * sx, 0, 0.88), 0.09), ((0.14 * sx, 0, 0.5), 0.07), ((0.14 * sx, 0, 0.1), 0.055),
              ((0.14 * sx, -0.14, 0.05), 0.05), ((0.24 * sx, 0, 1.45), 0.075), ((0.33 * sx, 0, 1.18), 0.06),
              ((0.40 * sx, 0, 0.93), 0.045), ((0.42 * sx, -0.02, 0.84), 0.05)]
NODES.append(((0, 0, 1.71), 0.13))  # the top of the head
EDGES = [(0, 1), (1, 2), (2, 3), (3, 4), (4, len(NODES) - 1)]
for k in (5, 13):
    EDGES += [(0, k), (k, k + 1), (k + 1, k + 2), (k + 2, k + 3), (2, k + 4), (k + 4, k + 5), (k + 5, k + 6),
              (k + 6, k + 7)]

BONES = [("root", (0, 0, 0), (0, 0.3, 0), None, False),
         ("hips", (0, 0, 0.9), (0, 0, 1.15), "root", True),
         ("spine", (0, 0, 1.15), (0, 0, 1.5), "hips", True),
         ("head", (0, 0, 1.5), (0, 0, 1.8), "spine", True),
         ("arm.L", (0.24, 0, 1.45), (0.40, 0, 0.93), "spine", True),
         ("arm.R", (-0.24, 0, 1.45), (-0.40, 0, 0.93), "spine", True),
         ("hand.R", (-0.40, 0, 0.93), (-0.43, -0.03, 0.80), "arm.R", True),
         ("leg.L", (0.12, 0, 0.88), (0.14, 0, 0.08), "hips", True),
         ("leg.R", (-0.12, 0, 0.88), (-0.14, 0, 0.08), "hips", True)]


def body_mesh():
    """The Skin modifier on the skeleton, Subdivision 2, both applied; the belly pushed 13 cm forward (-y)."""
    obj = skin_body("Knight", NODES, EDGES, 2)
    me = obj.data
    v = np.array([x.co for x in me.vertices])
    bulge = np.exp(-((v[:, 2] - 1.08) / 0.14) ** 2 - (v[:, 0] / 0.17) ** 2) * (v[:, 1] < 0)
    v[:, 1] -= 0.13 * bulge
    v[:, 2] -= v[:, 2].min() - 0.004  # soles 4 mm over the floor
    me.vertices.foreach_set("co", v.ravel())
    me.update()
    return obj, bulge


def tube(bm, points, rx, ry, seg, up=(0, 1, 0)):
    """A closed tube through points with per-point radii rx, ry (two axes across it); its new vertices and the
    parameter 0..1 of each along the tube."""
    pts = [Vector(p) for p in points]
    verts, param = [], []
    for k, p in enumerate(pts):
        t = (pts[min(k + 1, len(pts) - 1)] - pts[max(k - 1, 0)]).normalized()
        a = t.cross(Vector(up)).normalized()
        b = a.cross(t)
        ring = [bm.verts.new(p + a * rx[k] * math.cos(2 * math.pi * j / seg) + b * ry[k] * math.sin(2 * math.pi * j / seg))
                for j in range(seg)]
        verts.append(ring)
        param += [k / (len(pts) - 1)] * seg
    for r0, r1 in zip(verts, verts[1:]):
        for j in range(seg):
            bm.faces.new((r0[j], r0[(j + 1) % seg], r1[(j + 1) % seg], r1[j]))
    bm.faces.new(verts[0][::-1])
    bm.faces.new(verts[-1])
    return [v for r in verts for v in r], param


def cape(bm):
    """An open card behind the back, shoulders (z 1.45) to the knees (z 0.5), curved around the back."""
    rows, cols = 16, 10
    grid = [[bm.verts.new((-0.26 + 0.52 * i / cols, 0.25 + 0.35 * (-0.26 + 0.52 * i / cols) ** 2, 1.45 - 0.95 * j / rows))
             for i in range(cols + 1)] for j in range(rows + 1)]
    for j in range(rows):
        for i in range(cols):
            bm.faces.new((grid[j][i], grid[j][i + 1], grid[j + 1][i + 1], grid[j + 1][i]))
    return [v for r in grid for v in r], [j / rows for j in range(rows + 1) for _ in range(cols + 1)]


def add_parts(obj):
    """Ponytail, cape, hat and sword as separate shells of the body's mesh; vertex indices per part and each
    vertex's parameter from its attached end (0) to its free end (1)."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    n = len(bm.verts)
    parts, param = {}, np.zeros(n)
    pieces = {
        "hair": tube(bm, [(0, 0.12 + 0.015 * k, 1.72 - 0.05 * k) for k in range(8)],
                     [0.045 - 0.004 * k for k in range(8)], [0.035 - 0.003 * k for k in range(8)], 10, (1, 0, 0)),
        "cape": cape(bm),
        "hat": tube(bm, [(0, 0.01 * k, 1.66 + 0.045 * k) for k in range(8)], [0.17 * (1 - k / 7.5) for k in range(8)],
                    [0.17 * (1 - k / 7.5) for k in range(8)], 16),
        "sword": tube(bm, [(-0.43, -0.04 - 0.09 * k, 0.84 + 0.01 * k) for k in range(11)],
                      [0.028 if k else 0.07 for k in range(11)][:-1] + [0.004], [0.006] * 10 + [0.002], 4, (0, 0, 1)),
    }
    for name, (verts, t) in pieces.items():
        parts[name] = np.arange(n, n + len(verts))
        param = np.concatenate([param, t])
        n += len(verts)
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()
    return parts, param


def bump(f, a, b):
    """0 outside [a, b], a smooth hump of height 1 inside."""
    return math.sin(math.pi * (f - a) / (b - a)) ** 2 if a < f < b else 0.0


def animate(arm):
    """A jump: crouch lean (frames 2-12), take-off at 12, 0.4 m up at 22, landing at 32, landing lean 30-44, 0.5 m
    forward; arms swing up, legs tuck; still from frame 46 (keys to 48)."""
    pb = arm.pose.bones
    for b in pb:
        b.rotation_mode = 'XYZ'
    for f in range(1, STOP + 1, 2):
        air = 1 - ((f - 22) / 10) ** 2 if 12 < f < 32 else 0.0
        pb["root"].location = (0, -0.5 * min(max((f - 12) / 20, 0), 1), 0.4 * air)
        pb["spine"].rotation_euler = (0.3 * bump(f, 2, 14) + 0.35 * bump(f, 30, 46), 0, 0)
        for side in ("L", "R"):
            pb["arm." + side].rotation_euler = (-0.9 * bump(f, 8, 34), 0, 0)
            pb["leg." + side].rotation_euler = (-0.45 * air, 0, 0)
        pb["hand.R"].rotation_euler = (0.4 * bump(f, 14, 40), 0, 0)
        for b in pb:
            b.keyframe_insert("location" if b.name == "root" else "rotation_euler", frame=f)


def sword_rigid(obj, sword):
    """The sword weighted 1 to the hand only; the vertices automatic weights missed weighted to the nearest bone
    (as an artist does). Returns how many had no weight."""
    for g in obj.vertex_groups:
        g.remove([int(i) for i in sword])
    obj.vertex_groups["hand.R"].add([int(i) for i in sword], 1.0, 'REPLACE')
    empty = [v.index for v in obj.data.vertices if not any(g.weight > 0 for g in v.groups)]
    mids = [(n, (Vector(h) + Vector(t)) * 0.5) for n, h, t, _, d in BONES if d]
    for i in empty:
        co = obj.data.vertices[i].co
        name = min(mids, key=lambda b: (b[1] - co).length)[0]
        obj.vertex_groups[name].add([i], 1.0, 'REPLACE')
    return len(empty)


def follow_map(n, bulge, parts, param):
    """1 on the body and sword; 0.15 at the belly's front; hair and cape 1 at the top to 0.1 at the free end; the
    hat 1 at the brim to 0.3 at the tip."""
    w = np.ones(n)
    w[:len(bulge)] = 1 - 0.85 * bulge
    return taper(w, parts, param, (("hair", 0.1), ("cape", 0.1), ("hat", 0.3)))


class Shot(rig_parts.Shot):
    def __init__(self, obj, twin, parts, follow, H):
        super().__init__(obj, twin, parts, follow >= 0.99, H)
        self.shown = {}

    def play(self, label):
        """Frames 1..FRAMES from the start; one ROW of figures."""
        sc, s = bpy.context.scene, self.obj.opdeform
        rows, errors, cpu = [], [], 0.0
        for f in range(1, FRAMES + 1):
            t0 = time.process_time()
            sc.frame_set(f)
            cpu += time.process_time() - t0
            if s.error:
                errors.append((f, s.error))
            a, b = world(self.obj), world(self.twin)
            self.shown[f] = a
            d = np.linalg.norm(a - b, axis=1)
            i, j = self.edges
            st = np.linalg.norm(a[i] - a[j], axis=1) / np.linalg.norm(b[i] - b[j], axis=1)
            rows.append(dict(core=d[self.core].max(), all=d.max(), stretch=st.max(), low=a[:, 2].min(),
                             low_twin=b[:, 2].min(), **{k: d[ix].max() for k, ix in self.parts.items()}))
        col = {k: np.array([r[k] for r in rows]) for k in rows[0]}
        fr = np.arange(1, FRAMES + 1)
        moving, after = fr <= STOP, fr >= STOP + FPS
        late = np.where((fr >= STOP) & (col["all"] > 2e-3))[0]
        loose = ("belly", "hair", "cape", "hat")
        row = dict(label=label, host=bpy.app.version_string, particles=s.particles, look=self.look(),
                   core_mm=1e3 * col["core"].max(), core_frame=int(fr[np.argmax(col["core"])]),
                   **{k + "_mm": round(1e3 * col[k][moving].max(), 2) for k in self.parts},
                   loose_pct={k: round(100 * col[k][moving].max() / HEIGHT, 2) for k in loose},
                   after_1s_mm=1e3 * col["all"][after].max(),
                   after_1s_worst={k: round(1e3 * col[k][after].max(), 2) for k in self.parts},
                   settle_s=0.0 if len(late) == 0 else (fr[late[-1]] + 1 - STOP) / FPS,
                   stretch=col["stretch"].max(), stretch_frame=int(fr[np.argmax(col["stretch"])]),
                   floor_pen_mm=-1e3 * min(col["low"].min(), 0.0), lowest_mm=1e3 * col["low"].min(),
                   lowest_twin_mm=1e3 * col["low_twin"].min(),
                   base_kept=bool(np.array_equal(base(self.obj), self.before)), errors=errors[:3],
                   cpu_ms_frame=1e3 * cpu / FRAMES)
        print("ROW " + json.dumps(row, default=float))
        print("PANEL", reports(self.H.draw_panels()))
        return row


def build_scene(name):
    rig_parts.empty_scene(FPS, FRAMES)
    obj, bulge = body_mesh()
    parts, param = add_parts(obj)
    body = np.arange(len(bulge))
    parts = dict(core_body=body[bulge < 0.01], belly=body[bulge >= 0.05], **parts)
    arm = armature("KnightRig", BONES, lambda b, p: p in ("hips", "spine") and b in ("spine", "head"))
    parent_auto(obj, arm)
    unweighted = sword_rigid(obj, parts["sword"])
    animate(arm)
    follow = follow_map(len(obj.data.vertices), bulge, parts, param)
    paint(obj, "Follow", follow)
    collision_floor()
    twin = twin_of(obj)
    v = np.array([x.co for x in obj.data.vertices])
    print(f"KNIGHT {len(v)} vertices, box {v.min(0).round(3).tolist()} {v.max(0).round(3).tolist()}, "
          f"unweighted after auto {unweighted}", {k: len(i) for k, i in parts.items()})
    return obj, twin, parts, follow, bulge


VIEWS = {"render": ((3.0, -3.8, 1.6), (0.1, -0.3, 1.0)),  # 3/4 front: camera, target
         "side": ((4.5, -0.3, 1.3), (0, -0.3, 1.0))}  # from the knight's left


def render(frame, view):
    """Cycles, frame F: the simulated knight, then the armature-only twin alone, the same camera (moving the twin
    would move it off its armature's pivots): OUT/knight_VIEW_F.png and OUT/knight_VIEW_F_twin.png."""
    sc = bpy.context.scene
    eye, target = (Vector(x) for x in VIEWS[view])
    sc.frame_set(frame)
    cam = link(bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam")))
    cam.location = eye
    cam.rotation_euler = (target - cam.location).to_track_quat('-Z', 'Y').to_euler()
    sun = link(bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN')))
    sun.rotation_euler = (0.7, 0.2, 0.8)
    sun.data.energy = 3.0
    sc.camera, sc.render.engine = cam, 'CYCLES'
    sc.cycles.device, sc.cycles.samples, sc.cycles.use_denoising = 'CPU', 8, False
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 400, 400, 100
    knight, twin = bpy.data.objects["Knight"], bpy.data.objects["Knight_twin"]
    for shown, tail in ((knight, ""), (twin, "_twin")):
        knight.hide_render, twin.hide_render = shown is twin, shown is knight
        sc.render.filepath = os.path.join(OUT, f"knight_{view}_{frame}{tail}.png")
        t0 = time.time()
        bpy.ops.render.render(write_still=True)
        print("RENDER", sc.render.filepath, f"{time.time() - t0:.1f} s")
    knight.hide_render = twin.hide_render = False
    bpy.data.objects.remove(cam)
    bpy.data.objects.remove(sun)


def weight_paint_belly(obj, belly, value):
    """Weight Paint mode, vertex selection masking on the belly, Set Weight at the brush's weight."""
    bpy.context.view_layer.objects.active = obj
    obj.vertex_groups.active_index = obj.vertex_groups["Follow"].index
    sel = np.zeros(len(obj.data.vertices), bool)
    sel[belly] = True
    obj.data.vertices.foreach_set("select", sel)
    bpy.ops.object.mode_set(mode='WEIGHT_PAINT')
    obj.data.use_paint_mask_vertex = True
    ts = bpy.context.scene.tool_settings
    if hasattr(ts, "unified_paint_settings"):
        ts.unified_paint_settings.use_unified_weight = True
        ts.unified_paint_settings.weight = value
    try:
        print("WEIGHT_SET ->", bpy.ops.paint.weight_set())
    except Exception as e:  # report how the operator failed in this host
        print("WEIGHT_SET failed:", repr(e))
    bpy.ops.object.mode_set(mode='OBJECT')
    g = obj.vertex_groups["Follow"]
    got = np.array([g.weight(int(i)) for i in belly])
    print("BELLY FOLLOW after Weight Paint: min %.3f max %.3f" % (got.min(), got.max()))


def inside_body(obj, parts, frames):
    """Per frame: how many cape and hair vertices lie more than 5 mm inside the body shell (nearest body vertex,
    its normal), and the deepest (mm)."""
    from mathutils.kdtree import KDTree
    body = np.concatenate([parts["core_body"], parts["belly"]])
    for f in frames:
        bpy.context.scene.frame_set(f)
        ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        me = ev.to_mesh()
        nor = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("normal", nor)
        ev.to_mesh_clear()
        nor = nor.reshape(-1, 3) @ np.array(ev.matrix_world)[:3, :3].T
        a = world(obj)
        tree = KDTree(len(body))
        for k, i in enumerate(body):
            tree.insert(a[i], k)
        tree.balance()
        out = {}
        for name in ("cape", "hair"):
            depth = []
            for i in parts[name]:
                _, k, _ = tree.find(a[i])
                depth.append(-np.dot(a[i] - a[body[k]], nor[body[k]]))
            depth = np.array(depth)
            out[name] = (int((depth > 5e-3).sum()), round(1e3 * depth.max(), 1))
        print("INSIDE BODY frame", f, out)


def particles_per_part(name, obj, parts):
    """How many particles lie in each part (each particle by its nearest vertex)."""
    st = sys.modules[name + ".blender.state"].get(obj)
    if st is None:
        print("PARTICLES PER PART: no state")
        return
    v = np.array([x.co for x in obj.data.vertices])
    part_of = np.full(len(v), "between", object)
    for k, ix in parts.items():
        part_of[ix] = k
    near = [part_of[int(np.argmin(np.linalg.norm(v - c, axis=1)))] for c in st.engine.graph.centers]
    print("PARTICLES PER PART", {k: near.count(k) for k in (*parts, "between")})
    if "perparticle" in OPT:  # the maps reach the engine on a frame change
        bpy.context.scene.frame_set(bpy.context.scene.frame_current)
        per_particle(st.engine, near)


def per_particle(e, near):
    """Per particle as the solver has it: part, mesh piece, Follow (after Shell Min), its goal in Hz, the
    calibrated k before and after the Softness map, the map's scale, the jiggle rule's link softness, its volume."""
    import opdeform
    follow = e.goal_strength
    hz = opdeform.goal_frequency(follow)
    count = e.graph.n_particles
    given, k = (np.broadcast_to(x["stiffness"], (count,)) for x in (e._given, e._params))
    soft = np.ones(count) if e._softness is None else e._softness
    links = np.ones(count) if e._links is None else e._links
    piece = e.pieces()[1]
    for i in np.argsort(near, kind="stable"):
        print(f"PARTICLE {near[i]:9s} {i:4d} piece {piece[i]} follow {follow[i]:.3f} goal {hz[i]:8.2f} Hz "
              f"k {given[i]:.3e} -> {k[i]:.3e} softness {soft[i]:.3f} links {links[i]:.2e} "
              f"volume {e.graph.volumes[i]:.2e}")


def main():
    name = install(ZIP, KIND)
    import helpers as H
    H.ADDON = name
    obj, twin, parts, follow, bulge = build_scene(name)
    s = artist_enable(obj, OPT.get("particles"))
    tuned(s, OPT)
    first_panels(obj, H, settings(s, "region_damping"))
    particles_per_part(name, obj, parts)
    shot = Shot(obj, twin, parts, follow, H)
    shot.play("default")
    if "inside" in OPT:
        inside_body(obj, parts, range(1, STOP + 1, 3))
        inside_body(twin, parts, (26, 34))
    for view in VIEWS:
        if view in OPT:
            render(int(OPT[view]), view)
    if "bake" in OPT:
        s.cache_directory = os.path.join(OUT, "cache")
        print("BAKE ->", bpy.ops.opdeform.bake())
        sc = bpy.context.scene
        diff = max(1e3 * np.abs(world(obj) - shot.shown[f]).max() for f in (1, 12, 25, 40, 70, FRAMES)
                   if sc.frame_set(f) is None)
        print("BAKED", bool(s.baked), "bake vs playback mm", diff, "PANEL", reports(H.draw_panels()))
        print("FREE BAKE ->", bpy.ops.opdeform.free_bake())
    if "looks" in OPT:
        for look in ("Subtle", "Fleshy", "Floppy"):
            print("LOOK ->", look, bpy.ops.opdeform.apply_preset(preset=look), settings(s, "region_damping"))
            shot.play("look " + look)
        bpy.ops.opdeform.apply_preset(preset="Fleshy")
    if "repaint" in OPT:
        obj.vertex_groups["Follow"].add([int(i) for i in parts["belly"]], 1.0, 'REPLACE')
        shot.play("belly follow 1 (script)")
        weight_paint_belly(obj, parts["belly"], 0.15)
        shot.play("belly follow 0.15 (weight paint)")
    if "soft" in OPT:  # the artist paints a Softness group too (1 - Follow: 1 at the belly's front and the tips)
        paint(obj, "Softness", (1 - follow).round(3))
        s.softness_group = "Softness"
        shot.play("softness group, Fleshy")
        print("LOOK ->", bpy.ops.opdeform.apply_preset(preset="Floppy"), settings(s, "region_damping"))
        shot.play("softness group, Floppy")
        s.modulus = 0.3
        shot.play("softness group, Floppy, Stiffness 0.3")
    for n in [int(x) for x in OPT["counts"].split(",")] if "counts" in OPT else []:
        s.particles = n
        panel = reports(H.draw_panels())
        print("PANEL AFTER PARTICLES", n, panel)
        if any("Build" in t for t in panel):
            print("BUILD ->", bpy.ops.opdeform.build())
        particles_per_part(H.ADDON, obj, parts)
        shot.play(f"particles {n}")
    if "save" in OPT:
        rig_parts.save(obj, OUT)


reopen(OPT["open"], ZIP, KIND, "Knight") if "open" in OPT else main()
