"""Outside tester (issue 24): a Rigify-style bird the add-on has not seen, installed from a zip into empty user folders.

    blender -b --factory-startup --python-exit-code 1 -P scripts/outside_bird.py -- ZIP legacy OUT [opts]
    bpy-python scripts/outside_bird.py ZIP extension OUT [opts]
    (ZIP "-" and kind dev: the repository's add-on with $OPDEFORM_PYTHONPATH)
opts: scale=S (the whole rig S times 2 m tall), nonuniform (armature object scaled 1.3,1,0.7), empty (armature
parented to a moving, turning empty), spin (root turns 360 deg in 2 frames; spin=N in N), teleport (root jumps 2 m in one frame),
subsurf (Subdivision after OPDeform), shapekey (an animated shape key on the belly), dense=N (subdivide to about N
vertices), particles=N (before Enable), frames=N (shot length), look=NAME, late (Enable first, then pick), two (a second mesh on the same
armature, both enabled), bake, reopen, render, trace, fps=N (scene fps changed after 30 frames played).
"""
import json, math, os, sys
import bpy, bmesh
import numpy as np
from mathutils import Vector, Matrix

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rig_parts import base, install, link, paint, parent_auto, shells, twin_of, world  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
ZIP, KIND, OUT = args[:3]
OPT = {}
for a in args[3:]:
    k, _, v = a.partition("=")
    OPT[k] = v if v else True
S = float(OPT.get("scale", 1.0))
FPS = 24
SPIN = 2 if OPT.get("spin") in (None, True) else int(OPT["spin"])
FRAMES = int(OPT.get("frames", 96))
os.makedirs(OUT, exist_ok=True)
TESTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "blender")


def add(bm, geom_verts, matrix):
    bmesh.ops.transform(bm, matrix=matrix, verts=geom_verts)


def bird_mesh():
    bm = bmesh.new()
    def sphere(loc, scale, u=24, v=16):
        r = bmesh.ops.create_uvsphere(bm, u_segments=u, v_segments=v, radius=1.0)
        add(bm, r["verts"], Matrix.Translation(Vector(loc) * S) @ Matrix.Diagonal((*[x * S for x in scale], 1)))
    def box(loc, scale, cuts=3):
        r = bmesh.ops.create_cube(bm, size=1.0)
        ed = list({e for f in r["verts"] for e in f.link_edges})
        bmesh.ops.subdivide_edges(bm, edges=ed, cuts=cuts, use_grid_fill=True)
        vs = [v for v in bm.verts if not v.tag and v.select is False]
        return r
    sphere((0, 0, 0.95), (0.38, 0.42, 0.42))             # body
    sphere((0, -0.12, 0.85), (0.3, 0.3, 0.3), 16, 12)   # belly (intersecting, forward)
    sphere((0, -0.28, 1.5), (0.2, 0.2, 0.2))             # head
    for sx in (1, -1):                                   # legs: cylinders
        r = bmesh.ops.create_cone(bm, cap_ends=True, segments=12, radius1=0.05 * S, radius2=0.05 * S, depth=0.6 * S)
        add(bm, r["verts"], Matrix.Translation(Vector((0.15 * sx, 0, 0.35)) * S))
        r = bmesh.ops.create_cube(bm, size=1.0)          # feet
        add(bm, r["verts"], Matrix.Translation(Vector((0.15 * sx, -0.1, 0.04)) * S) @ Matrix.Diagonal((0.12 * S, 0.3 * S, 0.08 * S, 1)))
        if "solid" in OPT:  # wing: a closed thin box
            tmp = bmesh.new()
            bmesh.ops.create_cube(tmp, size=1.0)
            bmesh.ops.subdivide_edges(tmp, edges=tmp.edges[:], cuts=5, use_grid_fill=True)
            add(tmp, tmp.verts[:], Matrix.Translation(Vector((0.62 * sx, 0.05, 1.05)) * S) @ Matrix.Diagonal((0.5 * S, 0.5 * S, 0.02 * S, 1)))
            me = bpy.data.meshes.new("tmp"); tmp.to_mesh(me); tmp.free(); bm.from_mesh(me); bpy.data.meshes.remove(me)
        else:  # wing: a plate (open sheet, 0.5 m x 0.5 m)
            r = bmesh.ops.create_grid(bm, x_segments=8, y_segments=6, size=0.5)
            add(bm, r["verts"], Matrix.Translation(Vector((0.62 * sx, 0.05, 1.05)) * S) @ Matrix.Diagonal((0.5 * S, 0.5 * S, 1, 1)))
    for k in range(5):                                   # crest: hair cards on the head
        r = bmesh.ops.create_grid(bm, x_segments=1, y_segments=6, size=0.5)
        m = (Matrix.Translation(Vector((-0.08 + 0.04 * k, -0.25 + 0.02 * k, 1.83)) * S) @ Matrix.Rotation(0.3 * (k - 2), 4, 'Y')
             @ Matrix.Rotation(math.pi / 2, 4, 'X') @ Matrix.Diagonal((0.04 * S, 0.3 * S, 1, 1)))
        add(bm, r["verts"], m)
    for k in range(3):                                   # tail feathers: cards at the back
        r = bmesh.ops.create_grid(bm, x_segments=2, y_segments=6, size=0.5)
        m = (Matrix.Translation(Vector((-0.1 + 0.1 * k, 0.6, 0.9)) * S) @ Matrix.Rotation(-0.5, 4, 'X')
             @ Matrix.Rotation(0.25 * (k - 1), 4, 'Z') @ Matrix.Diagonal((0.08 * S, 0.45 * S, 1, 1)))
        add(bm, r["verts"], m)
    mesh = bpy.data.meshes.new("Bird")
    bm.to_mesh(mesh)
    bm.free()
    for p in mesh.polygons:
        p.use_smooth = True
    return link(bpy.data.objects.new("Bird", mesh))


BONES = {  # name: head, tail, parent, deform
    "root": ((0, 0, 0), (0, 0.5, 0), None, False),
    "torso": ((0, 0.3, 0.95), (0, 0.6, 0.95), "root", False),
    "MCH-spine": ((0, 0, 0.6), (0, 0, 0.9), "torso", False),
    "DEF-spine": ((0, 0, 0.6), (0, 0, 0.95), "MCH-spine", True),
    "DEF-spine.001": ((0, 0, 0.95), (0, 0, 1.25), "DEF-spine", True),
    "DEF-spine.002": ((0, -0.1, 1.25), (0, -0.2, 1.38), "DEF-spine.001", True),
    "ORG-spine": ((0, 0, 0.6), (0, 0, 1.25), "torso", False),
    "DEF-head": ((0, -0.25, 1.38), (0, -0.3, 1.75), "DEF-spine.002", True),
    "MCH-head": ((0, -0.25, 1.38), (0, -0.3, 1.6), "DEF-spine.002", False),
    "head_ctrl": ((0, -0.6, 1.5), (0, -0.8, 1.5), "torso", False),
    "DEF-crest": ((0, -0.26, 1.75), (0, -0.26, 2.1), "DEF-head", True),
    "DEF-tail": ((0, 0.35, 0.95), (0, 0.8, 0.75), "DEF-spine", True),
    "MCH-wing_parent.L": ((0.3, 0, 1.1), (0.35, 0, 1.2), "DEF-spine.001", False),
    "MCH-wing_parent.R": ((-0.3, 0, 1.1), (-0.35, 0, 1.2), "DEF-spine.001", False),
    "DEF-wing.L": ((0.35, 0.05, 1.05), (0.85, 0.05, 1.05), "MCH-wing_parent.L", True),
    "DEF-wing.R": ((-0.35, 0.05, 1.05), (-0.85, 0.05, 1.05), "MCH-wing_parent.R", True),
    "wing_ctrl.L": ((0.35, 0.2, 1.3), (0.6, 0.2, 1.3), "torso", False),
    "wing_ctrl.R": ((-0.35, 0.2, 1.3), (-0.6, 0.2, 1.3), "torso", False),
}
for sx, side in ((1, "L"), (-1, "R")):
    BONES.update({
        f"DEF-thigh.{side}": ((0.15 * sx, 0, 0.75), (0.15 * sx, -0.04, 0.4), "DEF-spine", True),
        f"DEF-shin.{side}": ((0.15 * sx, -0.04, 0.4), (0.15 * sx, 0, 0.08), f"DEF-thigh.{side}", True),
        f"DEF-foot.{side}": ((0.15 * sx, 0, 0.08), (0.15 * sx, -0.25, 0.04), f"DEF-shin.{side}", True),
        f"foot_ik.{side}": ((0.15 * sx, 0, 0.08), (0.15 * sx, -0.25, 0.08), "root", False),
        f"knee_pole.{side}": ((0.15 * sx, -0.6, 0.4), (0.15 * sx, -0.7, 0.4), "root", False),
        f"ORG-thigh.{side}": ((0.15 * sx, 0, 0.75), (0.15 * sx, -0.04, 0.4), "ORG-spine", False),
    })


def armature():
    arm = link(bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig")))
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    for name, (h, t, p, d) in BONES.items():
        b = arm.data.edit_bones.new(name)
        b.head, b.tail = Vector(h) * S, Vector(t) * S
        b.use_deform = d
    for name, (h, t, p, d) in BONES.items():
        if p:
            arm.data.edit_bones[name].parent = arm.data.edit_bones[p]
    bpy.ops.object.mode_set(mode='OBJECT')
    pb = arm.pose.bones
    for side in "LR":
        c = pb[f"DEF-shin.{side}"].constraints.new('IK')
        c.target, c.subtarget, c.chain_count = arm, f"foot_ik.{side}", 2
        c.pole_target, c.pole_subtarget, c.pole_angle = arm, f"knee_pole.{side}", -math.pi / 2
        c = pb[f"DEF-foot.{side}"].constraints.new('COPY_ROTATION')
        c.target, c.subtarget = arm, f"foot_ik.{side}"
        c = pb[f"MCH-wing_parent.{side}"].constraints.new('COPY_ROTATION')
        c.target, c.subtarget, c.mix_mode, c.target_space, c.owner_space = arm, f"wing_ctrl.{side}", 'ADD', 'LOCAL', 'LOCAL'
    c = pb["MCH-head"].constraints.new('DAMPED_TRACK')
    c.target, c.subtarget = arm, "head_ctrl"
    c = pb["DEF-head"].constraints.new('COPY_ROTATION')
    c.target, c.subtarget, c.influence = arm, "MCH-head", 0.8
    c = pb["DEF-spine"].constraints.new('COPY_LOCATION')
    c.target, c.subtarget, c.use_offset = arm, "MCH-spine", True
    c.target_space = c.owner_space = 'LOCAL'
    return arm


def key(pb, path, frame, value, index=None):
    if index is None:
        setattr(pb, path, value)
        pb.keyframe_insert(path, frame=frame)
    else:
        getattr(pb, path)[index] = value
        pb.keyframe_insert(path, index=index, frame=frame)


def animate(arm):
    pb = arm.pose.bones
    # two hops forward (torso up and down, feet planted then moving), head glance, wing flaps; still from 40
    for f, y, z in ((1, 0, 0), (8, -0.25, 0.3), (14, -0.5, -0.08), (20, -0.5, 0), (27, -0.75, 0.3), (33, -1.0, -0.08), (40, -1.0, 0)):
        key(pb["torso"], "location", f, (0, y * S, z * S))  # torso along +y: local axes = world axes
    for side in "LR":
        for f, y, z in ((1, 0, 0), (6, 0, 0), (10, -0.5, 0.2), (14, -0.5, 0), (25, -0.5, 0), (29, -1.0, 0.2), (33, -1.0, 0)):
            key(pb[f"foot_ik.{side}"], "location", f, (0, -y * S, z * S))
        pb[f"wing_ctrl.{side}"].rotation_mode = 'XYZ'
        for f, a in ((1, 0), (8, 50), (11, -30), (14, 40), (17, 0), (40, 0)):
            key(pb[f"wing_ctrl.{side}"], "rotation_euler", f, (math.radians(a), 0, 0))
    for f, x in ((1, 0), (16, 0), (20, 0.7), (24, -0.7), (28, 0), (40, 0)):
        key(pb["head_ctrl"], "location", f, (x * S, 0, 0))
    pb["root"].rotation_mode = 'XYZ'
    if "spin" in OPT:  # 360 degrees in 2 frames (spin=N: N frames), around z
        for f, a in ((44, 0), (44 + SPIN, 360)):
            key(pb["root"], "rotation_euler", f, math.radians(a), 2)
    if "teleport" in OPT:
        key(pb["root"], "location", 44, 0.0, 1)
        key(pb["root"], "location", 45, -2.0 * S, 1)
    ends = 40 + (6 + SPIN if "spin" in OPT else 8 if "teleport" in OPT else 0)
    for fc in fcurves(arm.animation_data.action):
        for k in fc.keyframe_points:
            k.interpolation = 'CONSTANT' if ("teleport" in OPT and fc.data_path.endswith('"root"].location')) else 'BEZIER'
    return ends


def fcurves(action):
    if hasattr(action, "fcurves"):
        return list(action.fcurves)
    return [fc for layer in action.layers for strip in layer.strips for cb in strip.channelbags for fc in cb.fcurves]


def maps(obj):
    v = np.array([x.co for x in obj.data.vertices]) / S
    sh = shells(obj)
    follow = np.ones(len(v))
    regions = {}
    wing = np.abs(v[:, 0]) > 0.36
    wing &= np.abs(v[:, 2] - 1.05) < 0.012
    follow[wing] = np.clip(1 - (np.abs(v[wing, 0]) - 0.37) / 0.5 * 0.85, 0.15, 1)
    regions["wings"] = np.where(wing)[0]
    crest = v[:, 2] > 1.72
    crest_sh = np.isin(sh, np.unique(sh[crest & (np.abs(v[:, 1] + 0.25) < 0.2)]))
    crest = crest_sh & (v[:, 2] > 1.6)
    follow[crest] = np.clip(1 - (v[crest, 2] - 1.68) / 0.3 * 0.9, 0.1, 1)
    regions["crest"] = np.where(crest)[0]
    tail = v[:, 1] > 0.42
    follow[tail] = np.clip(1 - (v[tail, 1] - 0.42) / 0.4 * 0.9, 0.1, 1)
    regions["tail"] = np.where(tail)[0]
    belly = (v[:, 1] < -0.3) & (v[:, 2] > 0.6) & (v[:, 2] < 1.15) & (np.abs(v[:, 0]) < 0.3)
    follow[belly] = np.minimum(follow[belly], 0.3)
    regions["belly"] = np.where(belly)[0]
    # hair cards and tail feathers: automatic weights may leave them empty; weigh them to their bones as an artist does
    for idx, bone in ((regions["crest"], "DEF-head"), (regions["tail"], "DEF-tail")):
        g = obj.vertex_groups.get(bone)
        if g is not None:
            g.add([int(i) for i in idx], 1.0, 'REPLACE')
    return follow.round(3), (1 - follow).round(3), regions


def build():
    sc = bpy.context.scene
    sc.render.fps, sc.frame_start, sc.frame_end = FPS, 1, FRAMES
    obj = bird_mesh()
    if "dense" in OPT:
        target = int(OPT["dense"])
        bm = bmesh.new(); bm.from_mesh(obj.data)
        while len(bm.verts) * 4 < target * 1.3:
            bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True)
        bm.to_mesh(obj.data); bm.free()
    arm = armature()
    parent_auto(obj, arm)
    end = animate(arm)
    follow, soft, regions = maps(obj)
    if "shapekey" in OPT:
        obj.shape_key_add(name="Basis")
        k = obj.shape_key_add(name="Breathe")
        v = np.array([x.co for x in obj.data.vertices])
        belly = regions["belly"]
        co = v.copy(); co[belly, 1] -= 0.08 * S
        k.data.foreach_set("co", co.ravel())
        for f, val in ((1, 0), (10, 1), (20, 0), (30, 1), (40, 0)):
            k.value = val; k.keyframe_insert("value", frame=f)
    if "objscale" in OPT:
        arm.scale = (float(OPT["objscale"]),) * 3
    if "nonuniform" in OPT:
        arm.scale = (1.3, 1.0, 0.7)
    if "empty" in OPT:
        e = link(bpy.data.objects.new("Mover", None))
        arm.parent = e
        for f, x, rz in ((1, 0, 0), (20, 1.5 * S, 30), (40, 3 * S, 90)):
            e.location = (x, 0, 0); e.rotation_euler = (0, 0, math.radians(rz))
            e.keyframe_insert("location", frame=f); e.keyframe_insert("rotation_euler", frame=f)
    if "nofloor" not in OPT:
        bpy.ops.mesh.primitive_plane_add(size=100.0 * S)
        fl = bpy.context.active_object
        fl.name = "Floor"
        fl.modifiers.new("Collision", 'COLLISION')
    return obj, arm, end, follow, soft, regions


def main():
    module_name = install(ZIP, KIND)
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    obj, arm, end, follow, soft, regions = build()
    sh = shells(obj)
    print(f"RIG bird scale {S}: {len(obj.data.vertices)} vertices, {len(np.unique(sh))} shells, {len(arm.data.bones)} bones "
          f"({sum(b.use_deform for b in arm.data.bones)} deform), motion ends {end}, regions", {k: len(i) for k, i in regions.items()})
    paint(obj, "follow", follow)
    paint(obj, "softness", soft)
    twin = twin_of(obj)
    others = []
    if "two" in OPT:  # a second character on the same armature: a copy beside it, its own mesh
        o2 = obj.copy(); o2.data = obj.data.copy(); o2.name = "Bird2"; link(o2)
        o2.location.x += (1.6 if OPT["two"] is True else float(OPT["two"])) * S
        for m in list(o2.modifiers):
            if m.type not in ('ARMATURE',):
                o2.modifiers.remove(m)
        if "jacket" in OPT:  # a jacket: the body shell 5 % larger, its own object on the same armature
            bm = bmesh.new(); bm.from_mesh(o2.data)
            keep = set(np.where(sh == np.bincount(sh).argmax())[0].tolist())
            bmesh.ops.delete(bm, geom=[v for v in bm.verts if v.index not in keep], context='VERTS')
            c = Vector((0, 0, 0.95 * S))
            for v in bm.verts:
                v.co = c + (v.co - c) * float(OPT["jacket"])
            bm.to_mesh(o2.data); bm.free()
            o2.location.x -= (1.6 if OPT["two"] is True else float(OPT["two"])) * S
            for g in ("follow", "softness"):
                if o2.vertex_groups.get(g) is None:
                    o2.vertex_groups.new(name=g)
        t2 = twin_of(o2)
        others.append((o2, t2))
    s = obj.opdeform
    before = base(obj)
    targets = [obj] + ([] if "onlyfirst" in OPT else [o for o, _ in others])
    for o in targets:
        if "late" not in OPT:
            o.opdeform.use_goal, o.opdeform.goal_group, o.opdeform.softness_group = True, "follow", "softness"
            if "nosoft" in OPT:
                o.opdeform.softness_group = ""
        if "particles" in OPT:
            o.opdeform.particles = int(OPT["particles"])
        bpy.context.view_layer.objects.active = o
        for x in bpy.context.scene.objects:
            x.select_set(x in targets)
        bpy.ops.opdeform.enable(object=o.name)
        if "late" in OPT:
            o.opdeform.use_goal, o.opdeform.goal_group, o.opdeform.softness_group = True, "follow", "softness"
        if "look" in OPT:
            bpy.ops.opdeform.apply_preset(object=o.name, preset=OPT["look"])
        for k, v in OPT.items():
            if k.startswith("+"):
                setattr(o.opdeform, k[1:], type(getattr(o.opdeform, k[1:]))(v))
    if "subsurf" in OPT:
        for o in (obj, twin):
            m = o.modifiers.new("Subdivision", 'SUBSURF'); m.levels = 1
        scene0 = bpy.context.scene; scene0.frame_set(1)
        dg = bpy.context.evaluated_depsgraph_get(); me = twin.evaluated_get(dg).to_mesh()
        sub_edges = np.array([e.vertices[:] for e in me.edges]); twin.evaluated_get(dg).to_mesh_clear()
    print("STACK", [(m.name, m.type) for m in obj.modifiers], "err", repr(s.error), "built", s.built,
          "particles", s.particles, "goal", s.use_goal, s.goal_group, "look", s.goal_strength)
    sys.path.insert(0, TESTS)
    import helpers as H
    H.ADDON = module_name
    bpy.context.view_layer.objects.active = obj
    log = H.draw_panels()
    print("PANEL", [e[1] for e in log if e[0] == "label"])
    print("CUT", H.cut_texts(log))
    st = sys.modules[module_name + ".blender.state"].get(obj)
    if st is not None and st.engine.goal_strength is not None:
        count, piece, _ = st.engine.pieces()
        gs = st.engine.goal_strength
        c = st.engine.graph.centers / S
        print("PIECES", [(int((piece == k).sum()), round(float(gs[piece == k].min()), 3) if (piece == k).any() else None,
                          c[piece == k].mean(0).round(2).tolist() if (piece == k).any() else None) for k in range(count)])
    core = np.where(follow >= 0.99)[0]
    edges = np.array([e.vertices[:] for e in obj.data.edges])
    rest = base(obj).reshape(-1, 3)
    size = float((rest.max(0) - rest.min(0)).max())
    scene = bpy.context.scene
    rows, shown, twins = [], {}, {}
    import time
    t0 = time.process_time()
    for f in range(1, FRAMES + 1):
        if "fps" in OPT and f == 31:
            scene.render.fps = int(OPT["fps"])
        scene.frame_set(f)
        if s.error:
            print("ERROR at", f, s.error)
            break
        a, b = world(obj), world(twin)
        shown[f] = a
        twins[f] = b
        if f == 1:
            first = b.copy()
        anim = np.linalg.norm(b - first, axis=1)
        d = np.linalg.norm(a - b, axis=1)
        i, j = (sub_edges if "subsurf" in OPT else edges).T
        stt = np.linalg.norm(a[i] - a[j], axis=1) / np.linalg.norm(b[i] - b[j], axis=1)
        row = dict(f=f, anim=anim.max(), anim_wing=anim[regions["wings"]].max() - anim.min(), core=d[core].max(), all=d.max(), stretch=stt.max(), lowest=a[:, 2].min(), lowest_twin=b[:, 2].min(),
                   at=b[i[np.argmax(stt)]] / S)
        row.update({r: d[ix].max() for r, ix in regions.items()})
        row.update({r + "_stretch": stt[np.isin(i, ix)].max(initial=1.0) for r, ix in regions.items()})
        if "contactoff" in OPT and f == 1:
            for o in targets:
                print("CONTACT props", {k: getattr(o.opdeform_contact, k) for k in o.opdeform_contact.bl_rna.properties.keys() if k != "rna_type"})
        if "dbgcache" in OPT and d.max() > 0.1:
            bad = np.where(d > 0.1)[0]
            print("BAD", f, len(bad), "idx", bad[:8].tolist(), "obj", a[bad[:3]].round(3).tolist(), "twin", b[bad[:3]].round(3).tolist(),
                  "other twin", world(others[0][1])[bad[:3]].round(3).tolist(), "other shown", world(others[0][0])[bad[:3]].round(3).tolist())
        if "dbgcache" in OPT:
            rts = [sys.modules[module_name + ".blender.state"].get(o) for o in targets]
            print("CACHE", f, [(len(r.engine.cache), r.engine.sim.counters.get("steps") if isinstance(r.engine.sim.counters, dict) else r.engine.sim.counters, r.engine.behind) for r in rts], round(1e3 * d.max(), 2))
        for k, (o2, t2) in enumerate(others):
            row[f"other{k}_all"] = np.linalg.norm(world(o2) - world(t2), axis=1).max()
            if o2.opdeform.error:
                print("ERROR other", o2.opdeform.error)
        rows.append(row)
    cpu = time.process_time() - t0
    col = {k: np.array([r[k] for r in rows]) for k in rows[0] if k != "at"}
    fr = col["f"]
    after = fr >= end
    big = np.where(after & (col["all"] > 2e-3 * max(S, 1e-9) / 1.0))[0]  # 2 mm at scale 1, scaled
    settle = 0.0 if len(big) == 0 else (fr[big[-1]] + 1 - end) / FPS
    summary = dict(host=bpy.app.version_string, opts=OPT, vertices=len(rest), particles=s.particles, size=size,
                   anim_mm=1e3 * col["anim"].max(), anim_wing_mm=1e3 * col["anim_wing"].max(), core_mm=1e3 * col["core"].max(), core_frame=int(fr[np.argmax(col["core"])]),
                   **{r + "_mm": 1e3 * col[r].max() for r in regions}, stretch=col["stretch"].max(),
                   **{r + "_stretch": col[r + "_stretch"].max() for r in regions},
                   stretch_frame=int(fr[np.argmax(col["stretch"])]), stretch_at=rows[int(np.argmax(col["stretch"]))]["at"].round(2).tolist(),
                   lowest_mm=1e3 * col["lowest"].min(), lowest_twin_mm=1e3 * col["lowest_twin"].min(), settle_s=settle,
                   after_1s_mm=1e3 * col["all"][fr >= end + FPS].max() if (fr >= end + FPS).any() else None,
                   base_kept=bool(np.array_equal(base(obj), before)), cpu_ms_frame=1e3 * cpu / len(rows),
                   **{k: 1e3 * col[k].max() for k in col if k.startswith("other")})
    print("SUMMARY " + json.dumps(summary))
    if "trace" in OPT:
        print("TRACE", json.dumps({**{k: [round(1e3 * x, 1) for x in col[k]] for k in ["all", "core", *regions]},
                                   "stretch": [round(x, 2) for x in col["stretch"]]}))
    if "inval" in OPT:  # what Free Bake does to the engine, without a bake; then a setting changed and back
        rt = sys.modules[module_name + ".blender.state"].get(obj)
        rt.engine.invalidate()
        for f in (1, 2, 3, 12):
            scene.frame_set(f)
            print("INVAL", f, "mm", 1e3 * np.abs(world(obj) - shown[f]).max())
        scene.frame_set(24)
        s.damping_rate += 1.0; s.damping_rate -= 1.0
        for f in (25, 2, 3, 12):
            scene.frame_set(f)
            print("SETTING", f, "mm", 1e3 * np.abs(world(obj) - shown[f]).max())
        bpy.ops.opdeform.reset(object=obj.name)
        for f in (1, 2, 3, 12):
            scene.frame_set(f)
            print("RESET", f, "mm", 1e3 * np.abs(world(obj) - shown[f]).max())
    if "scrub" in OPT:  # back to 12 from the end, a save, then 12 again, 13, 40
        for step in ("back", "save", "after"):
            if step == "save":
                bpy.ops.wm.save_as_mainfile(filepath=os.path.join(OUT, "scrub.blend"))
            for f in (30, 12, 13, 40):
                scene.frame_set(f)
                print("SCRUB", step, f, "mm", 1e3 * np.abs(world(obj) - shown[f]).max(), "twin mm", 1e3 * np.abs(world(twin) - twins[f]).max(), repr(s.error))
    if "render" in OPT:
        render(obj, twin, int(OPT["render"]) if OPT["render"] is not True else 10)
    def eng_state(tag):
        rt = sys.modules[module_name + ".blender.state"].get(obj)
        e = rt.engine
        print("ENG", tag, id(e), "gs", None if e.goal_strength is None else (e.goal_strength.min(), e.goal_strength.mean()),
              "params", e.sim.params if hasattr(e, "sim") and e.sim is not None else None, "carry", getattr(e.sim, "goals_carry_rest", None))
    if "bake" in OPT:
        eng_state("before bake")
        s.cache_directory = os.path.join(OUT, "cache")
        bpy.ops.opdeform.bake(object=obj.name)
        print("BAKED", s.baked, repr(s.error), [(m.name, m.type) for m in obj.modifiers])
        worst = max(np.abs(world(obj) - shown[f]).max() for f in (1, 12, end, FRAMES) if scene.frame_set(f) is None)
        print("BAKE_VS_PLAY", worst)
        if "reopen" in OPT:
            scene.frame_set(30)
            np.save(os.path.join(OUT, "f30.npy"), world(obj)); np.save(os.path.join(OUT, "t30.npy"), world(twin))
            bpy.ops.wm.save_as_mainfile(filepath=os.path.join(OUT, "bird.blend"))
        eng_state("after bake")
        bpy.ops.opdeform.free_bake(object=obj.name)
        scene.frame_set(12)
        eng_state("after free")
        print("FREED", s.baked, repr(s.error), "f12 vs play", np.abs(world(obj) - shown[12]).max(), "twin", np.abs(world(twin) - twins[12]).max())
        M = lambda n: sys.modules[module_name + ".blender." + n]
        for f in (2, 3):
            scene.frame_set(f)
            rt = M("state").get(obj)
            at = obj.data.attributes.get(M("modifier").OFFSET)
            off = np.zeros(1) if at is None else np.array([v.vector[:] for v in at.data])
            print("DBG", f, "live", M("playback").is_live(obj), "attr", at is not None, "attr max", np.abs(off).max(),
                  "engine offset", None if rt is None or rt.engine.offset is None else np.abs(rt.engine.offset).max(),
                  "mods", [(m.name, m.show_viewport) for m in obj.modifiers], "mm", 1e3 * np.abs(world(obj) - shown[f]).max(),
                  "vs twin", 1e3 * np.abs(world(obj) - twins[f]).max())
        for f in (13, 14, 30, 1, 2, 3, 12):
            scene.frame_set(f)
            print("AFTERFREE", f, "mm", 1e3 * np.abs(world(obj) - shown[f]).max())
        for f in range(1, 20):
            scene.frame_set(f)
            print("SEQ", f, "mm", 1e3 * np.abs(world(obj) - shown[f]).max())
    elif "reopen" in OPT:
        scene.frame_set(30)
        np.save(os.path.join(OUT, "f30.npy"), world(obj)); np.save(os.path.join(OUT, "t30.npy"), world(twin))
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(OUT, "bird.blend"))
        print("SAVED")


def render(obj, twin, frame):
    scene = bpy.context.scene
    scene.render.engine = 'CYCLES'
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 480, 480
    for o, c in ((obj, (0.85, 0.45, 0.3, 1)), (twin, (0.3, 0.45, 0.9, 1))):
        mat = bpy.data.materials.new(o.name); mat.diffuse_color = c
        mat.use_nodes = True; mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = c
        o.data.materials.clear(); o.data.materials.append(mat)
    cam = link(bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam")))
    scene.frame_set(frame)
    target = Vector(np.array(world(twin)).mean(0))
    cam.location = target + Vector((2.2, -3.0, 0.8)) * S
    cam.data.clip_start = 0.01 * S
    cam.data.clip_end = 100 * S
    cam.rotation_euler = (target - cam.location).to_track_quat('-Z', 'Y').to_euler()
    scene.camera = cam
    sun = link(bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))); sun.rotation_euler = (0.7, 0.2, 0.5); sun.data.energy = 3
    w = bpy.data.worlds.new("W"); w.color = (0.4, 0.4, 0.45); scene.world = w
    for shown_, hidden, name in ((obj, twin, "opdeform"), (twin, obj, "armature")):
        shown_.hide_render, hidden.hide_render = False, True
        scene.render.filepath = os.path.join(OUT, f"f{frame}_{name}.png")
        bpy.ops.render.render(write_still=True)
        print("RENDER", scene.render.filepath)


if "open" in OPT:
    install(ZIP, KIND)
    bpy.ops.wm.open_mainfile(filepath=os.path.join(OPT["open"], "bird.blend"))
    obj = bpy.data.objects["Bird"]
    a = world(obj)
    ref = np.load(os.path.join(OPT["open"], "f30.npy"))
    print("REOPEN twin mm", 1e3 * np.abs(world(bpy.data.objects["Bird_twin"]) - np.load(os.path.join(OPT["open"], "t30.npy"))).max())
    print("REOPEN frame", bpy.context.scene.frame_current, "max diff mm", 1e3 * np.abs(a - ref).max(), "error", repr(obj.opdeform.error),
          "mods", [(m.name, m.type) for m in obj.modifiers])
else:
    main()
