"""Outside tester (issue 24): a 1.2 m fish of 9 mesh pieces the add-on has not seen, on a 6-bone armature with
automatic weights, swimming (body wave, dips to the floor) until frame 40 of 96, then still.

    blender -b --factory-startup --python-exit-code 1 -P scripts/outside_fish.py -- ZIP legacy OUT [opts]
    bpy-python scripts/outside_fish.py ZIP extension OUT [opts]
    (ZIP "-" and kind dev: the repository's add-on with $OPDEFORM_PYTHONPATH)
opts: turn (a 90-degree snap turn in 4 frames), scale=S (everything S times), unit=U (the scene's Unit Scale), dip=D (how far the swim dips, m; 0.14), look=Subtle|Fleshy|Floppy (picked from the Goal panel's menu after the group),
particles=N, repaint (Follow all 1 after playing, in Weight Paint, replay; repaint=script: set by a script in Object
Mode), relook=NAME (another look after
playing, replay), save (frame 30 and the file into OUT; then open=OUT reopens it), trace (frames 17-32: the barbels), noweights (leave the vertices automatic weights missed unweighted), bake (bake, then compare with playback).
The artist's order: Enable (Physics tab), tick Goal, pick the Follow group, [pick a look], play.
"""
import json, math, os, sys
import bpy, bmesh
import numpy as np
from mathutils import Vector, Matrix

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import (armature, artist_enable, base, install, link,  # noqa: E402
                       paint, parent_auto, reopen, reports, shells, twin_of, world)

ZIP, KIND, OUT, OPT = rig_parts.options()
S = float(OPT.get("scale", 1.0))
FPS, FRAMES, STOP = 24, 96, 40
TESTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "blender")


def place(bm, verts, loc, scale=(1, 1, 1), rot=Matrix()):
    m = Matrix.Translation(Vector(loc) * S) @ rot.to_4x4() @ Matrix.Diagonal((*[x * S for x in scale], 1))
    bmesh.ops.transform(bm, matrix=m, verts=verts)


def fish_mesh():
    """Body along y (head at -y), z up; body centre 0.32 m above the floor."""
    bm = bmesh.new()
    r = bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=1.0)
    place(bm, r["verts"], (0, 0, 0.32), (0.11, 0.5, 0.17))  # body: 1.0 m of the 1.2 m
    for sx in (1, -1):  # eyes: separate shells
        r = bmesh.ops.create_uvsphere(bm, u_segments=12, v_segments=8, radius=1.0)
        place(bm, r["verts"], (0.075 * sx, -0.36, 0.37), (0.03, 0.03, 0.03))
        # pectoral fins: one-sided planes, out and down
        r = bmesh.ops.create_grid(bm, x_segments=6, y_segments=4, size=0.5)
        place(bm, r["verts"], (0.19 * sx, -0.18, 0.22), (0.18, 0.12, 1), Matrix.Rotation(-0.5 * sx, 3, 'Y'))
        # barbels (whiskers): cards hanging forward from the mouth
        r = bmesh.ops.create_grid(bm, x_segments=1, y_segments=8, size=0.5)
        place(bm, r["verts"], (0.05 * sx, -0.6, 0.27), (0.01, 0.2, 1),
              Matrix.Rotation(0.3 * sx, 3, 'Z') @ Matrix.Rotation(0.4, 3, 'X'))
    # dorsal fin: a thin solid on the back
    n = len(bm.verts)
    r = bmesh.ops.create_cube(bm, size=1.0)
    bmesh.ops.subdivide_edges(bm, edges=list({e for v in r["verts"] for e in v.link_edges}), cuts=4, use_grid_fill=True)
    bm.verts.ensure_lookup_table()
    place(bm, bm.verts[n:], (0, 0.02, 0.56), (0.012, 0.3, 0.16))
    # tail fin: a one-sided vertical plane behind the body
    r = bmesh.ops.create_grid(bm, x_segments=8, y_segments=8, size=0.5)
    place(bm, r["verts"], (0, 0.6, 0.32), (0.34, 0.22, 1), Matrix.Rotation(math.pi / 2, 3, 'Y'))
    mesh = bpy.data.meshes.new("Fish")
    bm.to_mesh(mesh)
    bm.free()
    return link(bpy.data.objects.new("Fish", mesh))


def parts_of(obj):
    """The pieces by where their shells lie (vertex indices per part)."""
    v = np.array([x.co for x in obj.data.vertices]) / S
    sh = shells(obj)
    body = np.bincount(sh).argmax()
    parts = {}
    for k in np.unique(sh):
        c = v[sh == k].mean(0)
        name = ("body" if k == body else "tailfin" if c[1] > 0.5 else "barbels" if c[1] < -0.5 else
                "dorsal" if c[2] > 0.45 else "pectoral" if abs(c[0]) > 0.15 else "eyes")
        parts.setdefault(name, []).extend(np.where(sh == k)[0].tolist())
    return {k: np.array(i) for k, i in parts.items()}


BONES = [("root", (0, 0.2, 0), (0, 0.5, 0), None, False),
         ("head", (0, -0.5, 0.32), (0, -0.25, 0.32), "root", True),
         ("spine1", (0, -0.25, 0.32), (0, 0.0, 0.32), "head", True),
         ("spine2", (0, 0.0, 0.32), (0, 0.25, 0.32), "spine1", True),
         ("tail1", (0, 0.25, 0.32), (0, 0.45, 0.32), "spine2", True),
         ("tail2", (0, 0.45, 0.32), (0, 0.7, 0.32), "tail1", True)]


def animate(arm):
    """Swims 1.5 m forward (-y) with a body wave (2 Hz) and a dip to 1 cm over the floor, stopped at frame STOP."""
    pb = arm.pose.bones
    for b in pb:
        b.rotation_mode = 'XYZ'
    for f in range(1, STOP + 1, 2):
        t = (f - 1) / FPS
        fade = 1.0 if f < STOP - 4 else 0.0
        pb["root"].location = (0, -1.5 * S * min(t / ((STOP - 1) / FPS), 1.0), -float(OPT.get("dip", 0.14)) * S * math.sin(math.pi * t / 1.6) * fade)
        pb["root"].keyframe_insert("location", frame=f)
        for k, name in enumerate(("spine1", "spine2", "tail1", "tail2")):
            pb[name].rotation_euler = (0, 0, 0.22 * (k + 1) / 2 * math.sin(2 * math.pi * 2 * t - 0.9 * k) * fade)
            pb[name].keyframe_insert("rotation_euler", frame=f)
    if "turn" in OPT:  # a snap turn: the root 90 degrees about z in 4 frames (20 -> 24)
        for f, a in ((20, 0), (24, 90), (STOP, 90)):
            pb["root"].rotation_euler = (0, 0, math.radians(a))
            pb["root"].keyframe_insert("rotation_euler", frame=f)
    for name in ("root", "spine1", "spine2", "tail1", "tail2"):  # held still from STOP
        pb[name].keyframe_insert("location" if name == "root" else "rotation_euler", frame=STOP)


def weights_fixed(obj, parts):
    """Automatic weights leave cards and fins without a group: weigh each unweighted vertex to its nearest bone,
    as an artist does. Returns how many vertices had none."""
    empty = [v.index for v in obj.data.vertices if not any(g.weight > 0 for g in v.groups)]
    bones = [(n, (Vector(h) + Vector(t)) * 0.5 * S) for n, h, t, _, d in BONES if d]
    for i in empty:
        co = obj.data.vertices[i].co
        name = min(bones, key=lambda b: (b[1] - co).length)[0]
        (obj.vertex_groups.get(name) or obj.vertex_groups.new(name=name)).add([i], 1.0, 'REPLACE')
    return len(empty)


def follow_map(obj, parts):
    """1 on the body and eyes; fins and barbels from 1 at the root to 0.1 at the tips."""
    v = np.array([x.co for x in obj.data.vertices]) / S
    w = np.ones(len(v))
    def fade(idx, dist):
        d = dist(v[idx])
        w[idx] = np.clip(1 - 0.9 * (d - d.min()) / (d.max() - d.min()), 0.1, 1)
    fade(parts["pectoral"], lambda p: np.abs(p[:, 0]))
    fade(parts["barbels"], lambda p: -p[:, 1])
    fade(parts["dorsal"], lambda p: p[:, 2])
    fade(parts["tailfin"], lambda p: p[:, 1])
    return w.round(3)


def main():
    name = install(ZIP, KIND)
    sc = rig_parts.empty_scene(FPS, FRAMES)
    if "unit" in OPT:  # an artist in cm: Unit Scale 0.01 with scale=100
        sc.unit_settings.scale_length = float(OPT["unit"])
    obj = fish_mesh()
    parts = parts_of(obj)
    arm = armature("FishRig", BONES, lambda b, p: p != "root", S)
    parent_auto(obj, arm)
    unweighted = 0 if "noweights" in OPT else weights_fixed(obj, parts)
    animate(arm)
    follow = follow_map(obj, parts)
    paint(obj, "Follow", follow)
    bpy.ops.mesh.primitive_plane_add(size=20.0 * S)
    bpy.context.active_object.name = "Floor"
    bpy.context.active_object.modifiers.new("Collision", 'COLLISION')
    twin = twin_of(obj)
    sh = shells(obj)
    v0 = np.array([x.co for x in obj.data.vertices]) / S
    print("BOXES", {k: (v0[i].min(0).round(3).tolist(), v0[i].max(0).round(3).tolist()) for k, i in parts.items()})
    print(f"FISH scale {S}: {len(obj.data.vertices)} vertices, {len(np.unique(sh))} shells, unweighted after auto {unweighted}",
          {k: len(i) for k, i in parts.items()})
    before = base(obj)
    s = artist_enable(obj, OPT.get("particles"))
    if "look" in OPT:
        print("LOOK ->", bpy.ops.opdeform.apply_preset(preset=OPT["look"]))
    import helpers as H
    H.ADDON = name
    log = H.draw_panels()
    print("PANEL", reports(log))
    print("CUT", [c[0] for c in H.cut_texts(log)])
    print("SETTINGS", {k: getattr(s, k) for k in ("particles", "goal_min", "goal_max", "shell_follow_min", "sag",
                                                  "modulus", "damping_rate", "soft_stiffness") if hasattr(s, k)},
          "error", repr(s.error), "mods", [(m.name, m.type) for m in obj.modifiers])
    st_ = sys.modules[name + ".blender.state"].get(obj)
    if st_ is not None:  # particles per part: each particle's nearest vertex's part
        v0 = np.array([x.co for x in obj.data.vertices])
        part_of = np.empty(len(v0), object)
        for k, ix in parts.items():
            part_of[ix] = k
        near = [int(np.argmin(np.linalg.norm(v0 - c, axis=1))) for c in st_.engine.graph.centers]
        print("PARTICLES PER PART", {k: int(sum(part_of[i] == k for i in near)) for k in parts})
    core = np.where(follow >= 0.99)[0]
    free = np.where(follow < 0.99)[0]
    loose = np.concatenate([parts[k] for k in ("pectoral", "barbels", "dorsal", "tailfin")])
    edges = np.array([e.vertices[:] for e in obj.data.edges])
    size = 1.2 * S
    rows, shown = [], {}
    errors = []
    import time
    t0 = time.process_time()
    for f in range(1, FRAMES + 1):
        sc.frame_set(f)
        if s.error:
            errors.append((f, s.error))
        a, b = world(obj), world(twin)
        shown[f] = a
        d = np.linalg.norm(a - b, axis=1)
        i, j = edges.T
        st = np.linalg.norm(a[i] - a[j], axis=1) / np.linalg.norm(b[i] - b[j], axis=1)
        rows.append(dict(f=f, core=d[core].max(), all=d.max(), stretch=st.max(), lowest=a[:, 2].min(), lowest_twin=b[:, 2].min(),
                         lowest_loose=a[free, 2].min(), lowest_loose_twin=b[free, 2].min(),
                         **{k: d[ix].max() for k, ix in parts.items()},
                         **{k + "_stretch": st[np.isin(i, ix)].max() for k, ix in parts.items()}))
    cpu_ms = 1e3 * (time.process_time() - t0) / FRAMES  # with this script's own measuring
    col = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    fr = col["f"]
    moving, after = fr < STOP, fr >= STOP + FPS
    late = np.where((fr >= STOP) & (col["all"] > 2e-3 * S))[0]
    summary = dict(host=bpy.app.version_string, opts=OPT, vertices=len(follow), shells=int(len(np.unique(sh))),
                   particles=s.particles, size_m=size, core_mm=1e3 * col["core"].max(),
                   core_frame=int(fr[np.argmax(col["core"])]),
                   loose_moving_mm=1e3 * max(col[k][moving].max() for k in ("pectoral", "barbels", "dorsal", "tailfin")),
                   loose_pct=100 * max(col[k][moving].max() for k in ("pectoral", "barbels", "dorsal", "tailfin")) / size,
                   **{k + "_mm": 1e3 * col[k][moving].max() for k in parts},
                   **{k + "_stretch": col[k + "_stretch"].max() for k in parts},
                   after_1s_mm=1e3 * col["all"][after].max(),
                   settle_s=0.0 if len(late) == 0 else (fr[late[-1]] + 1 - STOP) / FPS,
                   stretch=col["stretch"].max(), stretch_frame=int(fr[np.argmax(col["stretch"])]),
                   lowest_mm=1e3 * col["lowest"].min(), lowest_twin_mm=1e3 * col["lowest_twin"].min(),
                   lowest_loose_mm=1e3 * col["lowest_loose"].min(), lowest_loose_twin_mm=1e3 * col["lowest_loose_twin"].min(), base_kept=bool(np.array_equal(base(obj), before)),
                   errors=errors[:3], cpu_ms_frame=cpu_ms)
    if "bake" in OPT:
        s.cache_directory = os.path.join(OUT, "cache")
        print("BAKE ->", bpy.ops.opdeform.bake())
        summary["baked"] = bool(s.baked)
        summary["bake_vs_play_mm"] = max(1e3 * np.abs(world(obj) - shown[f]).max()
                                         for f in (1, 12, 25, STOP, 70, FRAMES) if sc.frame_set(f) is None)
        print("BAKED PANEL", reports(H.draw_panels()))
    if "repaint" in OPT:  # the artist paints the Follow group all 1 after playing, then replays: nothing may move
        painted = OPT["repaint"] != "script"  # repaint=script: set by a script in Object Mode
        if painted:
            bpy.ops.object.mode_set(mode='WEIGHT_PAINT')  # as an artist paints: in Weight Paint mode
        obj.vertex_groups["Follow"].add(list(range(len(follow))), 1.0, 'REPLACE')
        if painted:
            obj.data.update()
            sc.frame_set(sc.frame_current)
            bpy.ops.object.mode_set(mode='OBJECT')
        summary["repaint_all1_mm"] = replay(sc, obj, twin, bpy.context.view_layer, H)
    if "relook" in OPT:  # the artist picks another look after playing, then replays
        print("RELOOK ->", bpy.ops.opdeform.apply_preset(preset=OPT["relook"]))
        summary["relook_all_mm"] = replay(sc, obj, twin, bpy.context.view_layer, H)
    if "save" in OPT:  # then: the same command with open=OUT
        rig_parts.save(obj, OUT)
    if "trace" in OPT:
        print("TRACE stretch", [round(float(x), 2) for x in col["barbels_stretch"][16:32]], "barbels mm",
              [round(1e3 * float(x)) for x in col["barbels"][16:32]])
        sc.frame_set(23)
        print("PANEL AT 23", reports(H.draw_panels())[-6:])
    print("SUMMARY " + json.dumps(summary))


def replay(sc, obj, twin, layer, H):
    """Frames 1..FRAMES again after a change; the largest distance from the armature-only pose (mm), with the
    panel's labels at frame 1 as the artist sees them after the change."""
    print("PANEL AFTER CHANGE", reports(H.draw_panels()))
    worst, per = 0.0, []
    for f in range(1, FRAMES + 1):
        sc.frame_set(f)
        d = 1e3 * np.linalg.norm(world(obj) - world(twin), axis=1).max()
        per.append(round(d, 2))
        worst = max(worst, d)
    print("REPLAY", per[:48:4], "error", repr(obj.opdeform.error))
    return worst


reopen(OPT["open"], ZIP, KIND, "Fish") if "open" in OPT else main()
