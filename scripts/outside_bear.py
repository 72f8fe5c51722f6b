"""Outside tester (issue 24): a chubby 1.3 m cartoon bear the add-on has not seen. One object: a skinned body
(Skin + Subdivision applied) with a round belly pushed forward and two cheeks pushed out, short thick arms and
legs; as separate shells a pair of round flat ears and a stubby tail ball; an 8-bone armature (7 deforming) with
automatic weights (the tail, which they miss, weighted to the hips); three hops keyed over frames 1-48 (0.15 m up,
0.2 m forward each), then still until 96; a floor with a Collision modifier. Follow 1 on the core, falling to
0.15 over the belly and the cheeks, 1 -> 0.15 up the ears, 1 -> 0.2 out along the tail.

    blender -b --factory-startup --python-exit-code 1 -P scripts/outside_bear.py -- - dev OUT [opts]
    bpy-python scripts/outside_bear.py - dev OUT [opts]      (both with OPDEFORM_PYTHONPATH=$PWD/build/python)
opts: particles=N (set before Enable), levels=N (the body's Subdivision levels, 2: 1,714 vertices in all), looks
(Subtle, Fleshy, Floppy from the look menu, each replayed; then Fleshy with Jiggle (Hz) 0), render=F (Workbench,
frame F, after every replay: OUT/bear_LABEL_VIEW_F.png, front and side, and the armature-only twin
OUT/bear_twin_VIEW_F.png), bake (after the first replay: bake, compare with playback, free).
The artist's order: Enable (Physics tab), tick Goal, pick the Follow group, play. Every replay prints a ROW line
(JSON): the core's (Follow 1) largest distance to the armature-only pose, each loose part's largest distance
during the hops (mm and % of the height), the largest 1 s after the motion stops, edge stretch, floor
penetration, base mesh kept, errors, CPU ms per frame of frame_set alone.
"""
import json, os, sys
import bpy, bmesh
import numpy as np
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import (armature, artist_enable, base, bake_check, collision_floor, first_panels,  # noqa: E402
                       gauss, install, link, paint, parent_auto, reports, reshaped, settings, skin_body, taper,
                       twin_of, world)

ZIP, KIND, OUT, OPT = rig_parts.options()
FPS, FRAMES, STOP = 24, 96, 48

NODES = [((0, 0, 0.45), 0.25), ((0, 0, 0.70), 0.31), ((0, 0, 0.92), 0.26), ((0, 0, 1.05), 0.16),
         ((0, 0, 1.17), 0.21), ((0, 0, 1.28), 0.17)]
for sx in (1, -1):
    NODES += [((0.14 * sx, 0, 0.38), 0.13), ((0.15 * sx, 0, 0.22), 0.11), ((0.15 * sx, 0, 0.08), 0.10),
              ((0.15 * sx, -0.08, 0.06), 0.08), ((0.27 * sx, 0, 0.95), 0.11), ((0.40 * sx, -0.02, 0.80), 0.095),
              ((0.46 * sx, -0.04, 0.67), 0.09)]
EDGES = [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5)]
for k in (6, 13):
    EDGES += [(0, k), (k, k + 1), (k + 1, k + 2), (k + 2, k + 3), (2, k + 4), (k + 4, k + 5), (k + 5, k + 6)]

BONES = [("root", (0, 0, 0), (0, 0.3, 0), None, False),
         ("hips", (0, 0, 0.40), (0, 0, 0.75), "root", True),
         ("spine", (0, 0, 0.75), (0, 0, 1.05), "hips", True),
         ("head", (0, 0, 1.05), (0, 0, 1.42), "spine", True),
         ("arm.L", (0.27, 0, 0.95), (0.46, -0.04, 0.67), "spine", True),
         ("arm.R", (-0.27, 0, 0.95), (-0.46, -0.04, 0.67), "spine", True),
         ("leg.L", (0.14, 0, 0.40), (0.15, 0, 0.06), "hips", True),
         ("leg.R", (-0.14, 0, 0.40), (-0.15, 0, 0.06), "hips", True)]


def body_mesh():
    """Skin + Subdivision (levels=, 2) applied; the belly pushed 12 cm forward (-y), the cheeks 5 cm out and
    forward. The body mesh and per vertex its belly and cheek weights (0..1)."""
    obj = skin_body("Bear", NODES, EDGES, int(OPT.get("levels", 2)))

    def push(v):
        belly = gauss(v, (0, -0.3, 0.68), (0.22, 0.3, 0.17)) * (v[:, 1] < -0.05)
        cheeks = sum(gauss(v, (0.14 * sx, -0.12, 1.13), (0.08, 0.1, 0.07)) for sx in (1, -1))
        v[:, 1] -= 0.12 * belly + 0.02 * cheeks
        v[:, 0] += 0.05 * cheeks * np.sign(v[:, 0])
        return belly, cheeks
    return (obj, *reshaped(obj, push))  # the soles 4 mm over the floor


def ball(bm, centre, radii, axis):
    """A UV sphere scaled by radii at centre; its vertices and each one's parameter 0..1 along axis (0: the end
    toward the body)."""
    made = bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=10, radius=1.0)["verts"]
    for x in made:
        x.co = Vector(c + r * p for c, r, p in zip(centre, radii, x.co))
    along = np.array([x.co[axis] for x in made])
    if axis == 1:
        along = -along if centre[1] < 0 else along
    return made, (along - along.min()) / (along.max() - along.min())


def add_parts(obj):
    """Two ears on top of the head and a tail ball behind the hips, separate shells; vertex indices per part and
    each vertex's parameter from the body (0) to the free end (1)."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    top = max(x.co.z for x in bm.verts)
    parts = {}
    pieces = {"ear.L": ball(bm, (0.13, 0.0, top - 0.02), (0.075, 0.03, 0.075), 2),
              "ear.R": ball(bm, (-0.13, 0.0, top - 0.02), (0.075, 0.03, 0.075), 2),
              "tail": ball(bm, (0.0, 0.26, 0.40), (0.06, 0.07, 0.06), 1)}
    bm.verts.index_update()  # bmesh reuses the slots of the spheres' merged poles: indices only now
    param = np.zeros(len(bm.verts))
    for name, (made, t) in pieces.items():
        parts[name] = np.array([x.index for x in made])
        param[parts[name]] = t
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()
    return parts, param


def hop(f):
    """Phase 0..1 within a hop of 16 frames (three hops from frame 1), or None after the third."""
    return None if f >= STOP else ((f - 1) % 16) / 16


def animate(arm):
    """Each hop: crouch (phase 0-0.25), air 0.25-0.75 (0.15 m up, 0.2 m forward), land and crouch 0.75-1; arms
    swing up in the air, the spine leans on landing; still from frame 48."""
    pb = arm.pose.bones
    for b in pb:
        b.rotation_mode = 'XYZ'
    for f in range(1, STOP + 1, 2):
        p = hop(f)
        k = (f - 1) // 16 if p is not None else 3
        air = max(0.0, 1 - ((p - 0.5) / 0.25) ** 2) if p is not None else 0.0
        crouch = max(0.0, 1 - abs(p - 0.875) / 0.125) + max(0.0, 1 - p / 0.2) * (k > 0) if p is not None else 0.0
        forward = min(k + (min(max((p - 0.25) / 0.5, 0), 1) if p is not None else 0), 3)
        pb["root"].location = (0, -0.2 * forward, 0.15 * air)
        pb["spine"].rotation_euler = (0.25 * crouch, 0, 0)
        for side, sx in (("L", 1), ("R", -1)):
            pb["arm." + side].rotation_euler = (-0.8 * air, 0, 0.3 * sx * air)
            pb["leg." + side].rotation_euler = (-0.3 * air + 0.2 * crouch, 0, 0)
        for b in pb:
            b.keyframe_insert("location" if b.name == "root" else "rotation_euler", frame=f)


def weight_leftovers(obj):
    """Vertices automatic weights missed (the tail) weighted 1 to the hips, as an artist does; how many."""
    empty = [v.index for v in obj.data.vertices if not any(g.weight > 0 for g in v.groups)]
    obj.vertex_groups["hips"].add(empty, 1.0, 'REPLACE')
    return len(empty)


def follow_map(n, belly, cheeks, parts, param):
    w = np.ones(n)
    w[:len(belly)] = 1 - 0.85 * np.clip(np.maximum(belly, cheeks), 0, 1)
    return taper(w, parts, param, (("ear.L", 0.15), ("ear.R", 0.15), ("tail", 0.2)))


class Shot(rig_parts.Shot):
    def __init__(self, obj, twin, parts, follow, H):
        super().__init__(obj, twin, parts, follow >= 0.999, H)
        self.part_of = np.full(len(follow), "between", object)
        for k, ix in parts.items():
            self.part_of[ix] = k
        tw = world(twin)
        self.height = tw[:, 2].max() - tw[:, 2].min()

    def frame(self, f):
        cpu = self.timed(f)
        a, b, d, st = self.against_twin()
        i, j = self.edges
        worst = int(np.argmax(st))
        parts_st = {k: st[(self.part_of[i] == k) | (self.part_of[j] == k)].max() for k in self.parts}
        return cpu, dict(core=d[self.core].max(), all=d.max(), stretch=st.max(),
                         stretch_at=f"{self.part_of[i[worst]]} {np.round(b[i[worst]], 2).tolist()} "
                                    f"{1e3 * np.linalg.norm(b[i[worst]] - b[j[worst]]):.1f} mm", low=a[:, 2].min(),
                         low_twin=b[:, 2].min(), nan=bool(np.isnan(a).any()),
                         belly_shift=(a - b)[self.parts["belly"]].mean(0),
                         **{k: d[ix].max() for k, ix in self.parts.items()},
                         **{"stretch " + k: v for k, v in parts_st.items()})

    def play(self, label):
        """Frames 1..FRAMES from the start; one ROW of figures."""
        s = self.obj.opdeform
        col, errors, cpu = self.played(FRAMES)
        fr = np.arange(1, FRAMES + 1)
        moving, after = fr <= STOP, fr >= STOP + FPS
        loose = [k for k in self.parts if k != "core_body"]
        row = dict(label=label, host=bpy.app.version_string, particles=s.particles, look=self.look(),
                   jiggle_hz=round(s.jiggle_hz, 3), height_m=round(self.height, 3),
                   core_mm=round(1e3 * col["core"].max(), 3),
                   moving_mm={k: round(1e3 * col[k][moving].max(), 2) for k in loose},
                   moving_pct={k: round(100 * col[k][moving].max() / self.height, 2) for k in loose},
                   after_1s_mm={k: round(1e3 * col[k][after].max(), 3) for k in self.parts},
                   stretch=round(col["stretch"].max(), 3), stretch_frame=int(fr[np.argmax(col["stretch"])]),
                   stretch_at=col["stretch_at"][np.argmax(col["stretch"])],
                   stretch_per_part={k: round(col["stretch " + k].max(), 3) for k in self.parts},
                   floor_pen_mm=round(-1e3 * min(col["low"].min(), 0.0), 2),
                   lowest_mm=round(1e3 * col["low"].min(), 2), lowest_twin_mm=round(1e3 * col["low_twin"].min(), 2),
                   nan=bool(col["nan"].any()), base_kept=bool(np.array_equal(base(self.obj), self.before)),
                   errors=errors[:3], cpu_ms_frame=round(1e3 * cpu / FRAMES, 2))
        print("ROW " + json.dumps(row, default=float))
        print("BELLY SHIFT mm (y, z) per frame", np.round(1e3 * np.array(col["belly_shift"])[:, 1:], 1).tolist())
        print("PANEL", reports(self.H.draw_panels()))
        bpy.context.scene.frame_set(row["stretch_frame"])
        print("PANEL AT THE STRETCH FRAME", row["stretch_frame"], reports(self.H.draw_panels()))
        if "render" in OPT:
            render(int(OPT["render"]), label.replace(" ", "_"))
        return row


def build_scene():
    rig_parts.empty_scene(FPS, FRAMES)
    obj, belly, cheeks = body_mesh()
    parts, param = add_parts(obj)
    body = np.arange(len(belly))
    parts = dict(core_body=body[(belly < 0.01) & (cheeks < 0.01)], belly=body[belly >= 0.3],
                 cheeks=body[cheeks >= 0.3], ears=np.concatenate([parts["ear.L"], parts["ear.R"]]),
                 tail=parts["tail"])
    arm = armature("BearRig", BONES, lambda b, p: p in ("hips", "spine") and b in ("spine", "head"))
    parent_auto(obj, arm)
    unweighted = weight_leftovers(obj)
    animate(arm)
    follow = follow_map(len(obj.data.vertices), belly, cheeks,
                        {"ear.L": parts["ears"][:len(parts["ears"]) // 2],
                         "ear.R": parts["ears"][len(parts["ears"]) // 2:], "tail": parts["tail"]}, param)
    paint(obj, "Follow", follow)
    collision_floor()
    twin = twin_of(obj)
    v = np.array([x.co for x in obj.data.vertices])
    print(f"BEAR {len(v)} vertices, box {v.min(0).round(3).tolist()} {v.max(0).round(3).tolist()}, "
          f"unweighted after auto {unweighted}", {k: len(i) for k, i in parts.items()},
          "follow min per part", {k: float(follow[i].min()) for k, i in parts.items()})
    return obj, twin, parts, follow


VIEWS = {"front": ((1.5, -2.3, 1.1), (0, -0.45, 0.7)), "side": ((2.6, -0.45, 0.8), (0, -0.45, 0.7))}


def render(frame, label):
    """Workbench, frame F, a 3/4 front and a side view: the bear (OUT/bear_LABEL_VIEW_F.png), once the
    armature-only twin alone (OUT/bear_twin_VIEW_F.png)."""
    sc = bpy.context.scene
    sc.frame_set(frame)
    sc.render.engine = 'BLENDER_WORKBENCH'
    sc.render.resolution_x = sc.render.resolution_y = 480
    sc.render.resolution_percentage = 100
    bear, twin = bpy.data.objects["Bear"], bpy.data.objects["Bear_twin"]
    for view, (eye, target) in VIEWS.items():
        cam = link(bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam")))
        cam.location = Vector(eye)
        cam.rotation_euler = (Vector(target) - cam.location).to_track_quat('-Z', 'Y').to_euler()
        sc.camera = cam
        shots = [(bear, f"bear_{label}_{view}_{frame}.png")]
        if not os.path.exists(os.path.join(OUT, f"bear_twin_{view}_{frame}.png")):
            shots.append((twin, f"bear_twin_{view}_{frame}.png"))
        for shown, name in shots:
            bear.hide_render, twin.hide_render = shown is twin, shown is bear
            sc.render.filepath = os.path.join(OUT, name)
            bpy.ops.render.render(write_still=True)
            print("RENDER", sc.render.filepath)
        bpy.data.objects.remove(cam)
    bear.hide_render = twin.hide_render = False


def main():
    name = install(ZIP, KIND)
    import helpers as H
    H.ADDON = name
    obj, twin, parts, follow = build_scene()
    s = artist_enable(obj, OPT.get("particles"))
    first_panels(obj, H, settings(s, "jiggle_hz"))
    shot = Shot(obj, twin, parts, follow, H)
    shot.play("default")
    if "bake" in OPT:
        bake_check(obj, H, OUT, (1, 16, 24, 40, 70, FRAMES))
    if "looks" in OPT:
        for look in ("Subtle", "Fleshy", "Floppy"):
            print("LOOK ->", look, bpy.ops.opdeform.apply_preset(preset=look), settings(s, "jiggle_hz"))
            shot.play(look)
        bpy.ops.opdeform.apply_preset(preset="Fleshy")
        s.jiggle_hz = 0.0
        print("JIGGLE 0", settings(s, "jiggle_hz"))
        shot.play("Fleshy jiggle 0")


main()
