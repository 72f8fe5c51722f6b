"""Issue 24's checks as an outside tester runs them (stop 37): two rigs the add-on was not tuned on, built by
script, the add-on installed from a zip of scripts/package into empty user folders as a new user does.

- gob: a 1.74 m humanoid from the Skin modifier (subdivided twice) on 15 bones (hips, spine, chest, neck, head,
  arms, legs, feet), belly and cheeks as large skin nodes, two eyes and three buttons as loose shells, parented
  with automatic weights; walks four steps, crouches, jumps 0.45 m, lands, stands from frame 60 to 96. Follow
  1 but for the belly front (to 0.2), the cheeks (0.3), the eyes (0.6) and the buttons (0.25); softness on
  the same regions.
- ellie: a kitbashed elephant, ten intersecting shells in one mesh (body, head, a 0.9 m trunk, two flat ear
  plates 0.45 x 0.5 x 0.025 m, a tail, four legs) on 13 bones; trots 1 m, shakes its head three times, stands
  from frame 51. Follow 1 but along the trunk (to 0.05 at its tip), the ears (0.1 at the outer edge), the tail.
- dog: the stop-38 audit's quadruped of joined primitives (1.6 m, 2,752 vertices, 11 shells: body, head, neck,
  muzzle, four legs, and a 0.45 m tail and two hanging ears as loose shells) on 10 bones; automatic weights, then
  the ears given to the head bone as an artist does (automatic weights leave them unweighted: the panel names
  them); trots in four hops (1..49), stands to 96. Follow 1 but along the tail (to 0.1 at its tip), the ears (0.1
  at their tips) and the belly's underside (0.3); softness 1 - Follow.
- mole (stop 41): metaballs converted to one mesh (a body with a belly, a head, two tall ears and a long tail
  melted into it, four feet; 1.5 m, 5,110 vertices) on 6 bones with automatic weights; hops twice forward with the head nodding,
  turns its head sharply, stands from frame 41. Follow 1 but the ears (to 0.1), the tail (to 0.15) and the belly's
  front (to 0.2); softness 1 - Follow.
- kid (stop 42): primitives voxel-remeshed into one body (1.26 m, A-posed arms with three fingers and a thumb)
  with a skirt (an open sheet), a ponytail and a backpack as loose shells (14,852 vertices) on 18 bones with
  automatic weights (the backpack, left unweighted, given to the chest); swings its arms at 4 Hz, jumps 0.3 m,
  spins 180 degrees in 8 frames, stands from frame 38. Follow 1 on the body, to 0.1 at the skirt's hem and the
  ponytail's tip, 0.5 on the backpack; softness 1 - Follow.

VARIANT: painted (Follow and Softness groups picked before Enable), late (Enable first, then Goal and the
groups), none (Enable with nothing painted), goal (the Follow group only), Subtle / Floppy (a look applied after
Enable), reopen (saved at frame 30) then open (the file opened in a new process). Prints SUMMARY: the follow-1
region's largest distance from the armature-only pose (core), each loose region's, the secondary motion as a
share of the body's size, the longest edge over its animated length, the lowest vertex (and the armature-only
one's), the settle time, the largest offset 1 s after the motion, whether the base mesh was kept; for
painted also the bake against playback and a Cycles frame (OPDeform and the armature-only pose) in OUT.

    blender -b --factory-startup --python-exit-code 1 -P scripts/outside_rigs.py -- ZIP legacy RIG VARIANT OUT
    <python with bpy 5.2> scripts/outside_rigs.py ZIP extension RIG VARIANT OUT
    (ZIP "-" and kind dev: the repository's add-on with $OPDEFORM_PYTHONPATH, in Blender)
    [NAME=VALUE ...: obj.opdeform settings set before Enable; +NAME=VALUE: after Enable and the look; norender]
with BLENDER_USER_CONFIG / BLENDER_USER_SCRIPTS / BLENDER_USER_RESOURCES at empty folders. Also prints HASHES:
short hashes of the graph's inputs (rest positions, triangles, vertex weights) and the graph (particle centres,
Follow), to tell run-to-run differences apart; OUTSIDE_RIGS_DUMP=FILE.npz keeps those arrays;
OUTSIDE_RIGS_TRACE=1 prints TRACE: each frame's largest offset (mm), of all vertices and of each loose region.
OUTSIDE_RIGS_STRETCH=FILE.npz keeps each frame's shown and armature-only vertices, particles and goal frames with the
graph and the skin, for scripts/stretch_cause.py (why an edge stretches).
"""
import json
import math
import os
import sys

import bpy
import bmesh
import numpy as np
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rig_parts import base, install, link, paint, parent_auto, shells, twin_of, world  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
ZIP, KIND, RIG, VARIANT, OUT = args[:5]
EXTRA = args[5:]
FPS = 24
TESTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "blender")
os.makedirs(OUT, exist_ok=True)


# ---------------------------------------------------------------- rig 1: "gob", a Skin-modifier humanoid
GOB_NODES = {  # name: (position, radius, parent)
    "pelvis": ((0, 0, 0.95), 0.17, None), "waist": ((0, 0, 1.13), 0.17, "pelvis"),
    "belly": ((0, -0.13, 1.08), 0.2, "waist"), "chest": ((0, 0, 1.35), 0.19, "waist"),
    "neck": ((0, 0, 1.5), 0.07, "chest"), "head": ((0, 0, 1.63), 0.14, "neck"),
    "top": ((0, 0, 1.8), 0.1, "head"),
    "cheek.L": ((0.08, -0.08, 1.6), 0.08, "head"), "cheek.R": ((-0.08, -0.08, 1.6), 0.08, "head"),
    "shoulder.L": ((0.2, 0, 1.42), 0.07, "chest"), "elbow.L": ((0.44, 0, 1.28), 0.055, "shoulder.L"),
    "hand.L": ((0.62, 0, 1.12), 0.05, "elbow.L"),
    "shoulder.R": ((-0.2, 0, 1.42), 0.07, "chest"), "elbow.R": ((-0.44, 0, 1.28), 0.055, "shoulder.R"),
    "hand.R": ((-0.62, 0, 1.12), 0.05, "elbow.R"),
    "hip.L": ((0.1, 0, 0.9), 0.09, "pelvis"), "knee.L": ((0.11, 0, 0.5), 0.07, "hip.L"),
    "ankle.L": ((0.11, 0, 0.12), 0.06, "knee.L"), "toe.L": ((0.11, -0.14, 0.08), 0.05, "ankle.L"),
    "hip.R": ((-0.1, 0, 0.9), 0.09, "pelvis"), "knee.R": ((-0.11, 0, 0.5), 0.07, "hip.R"),
    "ankle.R": ((-0.11, 0, 0.12), 0.06, "knee.R"), "toe.R": ((-0.11, -0.14, 0.08), 0.05, "ankle.R"),
}
GOB_BONES = {  # name: (head node, tail node, parent)
    "hips": ("pelvis", "waist", None), "spine": ("waist", "chest", "hips"), "chest": ("chest", "neck", "spine"),
    "neck": ("neck", "head", "chest"), "head": ("head", "top", "neck"),
    "upper_arm.L": ("shoulder.L", "elbow.L", "chest"), "forearm.L": ("elbow.L", "hand.L", "upper_arm.L"),
    "upper_arm.R": ("shoulder.R", "elbow.R", "chest"), "forearm.R": ("elbow.R", "hand.R", "upper_arm.R"),
    "thigh.L": ("hip.L", "knee.L", "hips"), "shin.L": ("knee.L", "ankle.L", "thigh.L"),
    "thigh.R": ("hip.R", "knee.R", "hips"), "shin.R": ("knee.R", "ankle.R", "thigh.R"),
    "foot.L": ("ankle.L", "toe.L", "shin.L"), "foot.R": ("ankle.R", "toe.R", "shin.R"),
}
EYES = [(0.055, -0.125, 1.67), (-0.055, -0.125, 1.67)]
BUTTONS = [(0.0, -0.325, z) for z in (0.98, 1.08, 1.18)]


def smooth_object(name, bm):
    """A mesh object of the bmesh (freed), smooth shaded, in the scene."""
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    for p in mesh.polygons:
        p.use_smooth = True
    return link(bpy.data.objects.new(name, mesh))


def gob_mesh():
    names = list(GOB_NODES)
    me = bpy.data.meshes.new("GobSkel")
    me.from_pydata([GOB_NODES[n][0] for n in names],
                   [(names.index(p), i) for i, n in enumerate(names) for p in [GOB_NODES[n][2]] if p], [])
    skel = link(bpy.data.objects.new("GobSkel", me))
    skel.modifiers.new("Skin", 'SKIN')
    for i, n in enumerate(names):
        r = GOB_NODES[n][1]
        me.skin_vertices[0].data[i].radius = (r, r)
    me.skin_vertices[0].data[0].use_root = True
    sub = skel.modifiers.new("Subsurf", 'SUBSURF')
    sub.levels = 2
    dg = bpy.context.evaluated_depsgraph_get()
    body = bpy.data.meshes.new_from_object(skel.evaluated_get(dg))
    bpy.data.objects.remove(skel)
    bm = bmesh.new()
    bm.from_mesh(body)
    for c in EYES:
        r = bmesh.ops.create_uvsphere(bm, u_segments=12, v_segments=8, radius=0.035)
        bmesh.ops.translate(bm, verts=r["verts"], vec=c)
    for c in BUTTONS:
        r = bmesh.ops.create_uvsphere(bm, u_segments=8, v_segments=6, radius=0.022)
        bmesh.ops.translate(bm, verts=r["verts"], vec=c)
    return smooth_object("Gob", bm)


def gob_bones():
    return {b: (GOB_NODES[h][0], GOB_NODES[t][0], p) for b, (h, t, p) in GOB_BONES.items()}


# ---------------------------------------------------------------- rig 2: "ellie", trunk and flat ears
def piece(bm, make, scale=(1, 1, 1), rotate=None, move=(0, 0, 0)):
    """Adds a part built in its own bmesh (make(tmp) -> None), scaled, turned (a 3x3 Matrix) and moved."""
    tmp = bmesh.new()
    make(tmp)
    bmesh.ops.scale(tmp, verts=tmp.verts, vec=scale)
    if rotate is not None:
        bmesh.ops.rotate(tmp, verts=tmp.verts, cent=(0, 0, 0), matrix=rotate)
    bmesh.ops.translate(tmp, verts=tmp.verts, vec=move)
    me = bpy.data.meshes.new("tmp")
    tmp.to_mesh(me)
    tmp.free()
    bm.from_mesh(me)
    bpy.data.meshes.remove(me)


def tube(r1, r2, depth, segments, cuts, up=False, caps=True):
    """A tapered tube from z = 0 (radius r1) down to z = -depth (r2), or up to z = depth, ``cuts`` rings
    between; capped, or an open sheet (caps False)."""
    def make(tmp):
        low, high = (r1, r2) if up else (r2, r1)
        bmesh.ops.create_cone(tmp, cap_ends=caps, segments=segments, radius1=low, radius2=high, depth=depth)
        bmesh.ops.translate(tmp, verts=tmp.verts, vec=(0, 0, depth / 2 if up else -depth / 2))
        sides = [e for e in tmp.edges if abs(e.verts[0].co.z - e.verts[1].co.z) > depth / 2]
        bmesh.ops.subdivide_edges(tmp, edges=sides, cuts=cuts, use_grid_fill=True)
    return make


def plate(tmp):
    bmesh.ops.create_grid(tmp, x_segments=10, y_segments=10, size=0.5)  # 1 x 1 in the xy plane
    bmesh.ops.solidify(tmp, geom=tmp.faces[:], thickness=0.025)  # a thin solid plate


def ellie_mesh():
    from mathutils import Matrix
    bm = bmesh.new()
    piece(bm, lambda t: bmesh.ops.create_uvsphere(t, u_segments=24, v_segments=16, radius=1.0),
          scale=(0.45, 0.7, 0.42), move=(0, 0, 1.05))  # body
    piece(bm, lambda t: bmesh.ops.create_uvsphere(t, u_segments=20, v_segments=14, radius=0.3),
          move=(0, -0.8, 1.3))  # head
    piece(bm, tube(0.09, 0.035, 0.9, 12, 17), move=(0, -1.02, 1.28))  # trunk, 0.9 m hanging
    for s in (1, -1):  # ears: flat plates 0.45 wide, 0.5 tall, 0.025 thick, beside the head
        piece(bm, plate, scale=(0.45, 0.5, 1.0), rotate=Matrix.Rotation(math.pi / 2, 3, 'X'),
              move=(s * 0.45, -0.72, 1.3))
    piece(bm, tube(0.04, 0.015, 0.5, 8, 9), rotate=Matrix.Rotation(math.radians(35), 3, 'X'),
          move=(0, 0.7, 1.1))  # tail, back and down
    for x in (0.25, -0.25):
        for y in (0.4, -0.4):
            piece(bm, tube(0.11, 0.11, 0.8, 12, 3), move=(x, y, 0.8))  # legs
    return smooth_object("Ellie", bm)


def ellie_bones():
    tb, tt = Vector((0, -1.02, 1.28)), Vector((0, -1.02, 0.38))
    t = [tuple(tb + (tt - tb) * i / 4) for i in range(5)]
    return {
        "root": ((0, 0.5, 1.05), (0, -0.3, 1.05), None),
        "head": ((0, -0.55, 1.2), (0, -0.95, 1.35), "root"),
        "trunk.1": (t[0], t[1], "head"), "trunk.2": (t[1], t[2], "trunk.1"),
        "trunk.3": (t[2], t[3], "trunk.2"), "trunk.4": (t[3], t[4], "trunk.3"),
        "ear.L": ((0.25, -0.72, 1.3), (0.68, -0.72, 1.3), "head"),
        "ear.R": ((-0.25, -0.72, 1.3), (-0.68, -0.72, 1.3), "head"),
        "tail": ((0, 0.7, 1.1), (0, 0.99, 0.69), "root"),
        "leg.FL": ((0.25, -0.4, 0.8), (0.25, -0.4, 0.0), "root"), "leg.FR": ((-0.25, -0.4, 0.8), (-0.25, -0.4, 0.0), "root"),
        "leg.BL": ((0.25, 0.4, 0.8), (0.25, 0.4, 0.0), "root"), "leg.BR": ((-0.25, 0.4, 0.8), (-0.25, 0.4, 0.0), "root"),
    }


# ---------------------------------------------------------------- rig 3: "dog", loose tail and hanging ears
def sphere(u, v):
    return lambda t: bmesh.ops.create_uvsphere(t, u_segments=u, v_segments=v, radius=1.0)


def dog_mesh():
    from mathutils import Matrix
    bm = bmesh.new()
    piece(bm, sphere(48, 24), scale=(0.45, 0.2, 0.2), move=(0, 0, 0.6))  # body
    piece(bm, sphere(32, 16), scale=(0.14, 0.14, 0.14), move=(0.58, 0, 0.88))  # head
    piece(bm, tube(0.09, 0.07, 0.35, 16, 6, up=True), rotate=Matrix.Rotation(math.radians(50), 3, 'Y'),
          move=(0.32, 0, 0.62))  # neck
    piece(bm, tube(0.06, 0.04, 0.14, 12, 3, up=True), rotate=Matrix.Rotation(math.radians(90), 3, 'Y'),
          move=(0.66, 0, 0.84))  # muzzle
    for x in (0.3, -0.3):
        for y in (0.12, -0.12):
            piece(bm, tube(0.05, 0.05, 0.55, 16, 8, up=True), move=(x, y, 0.0))  # legs
    piece(bm, tube(0.035, 0.012, 0.45, 12, 10, up=True), rotate=Matrix.Rotation(math.radians(-60), 3, 'Y'),
          move=(-0.4, 0, 0.66))  # tail, a loose shell
    for y in (0.1, -0.1):  # hanging ears, loose shells
        piece(bm, tube(0.05, 0.015, 0.18, 12, 6, up=True), scale=(1, 0.35, 1),
              rotate=Matrix.Rotation(math.radians(-150 if y > 0 else 150), 3, "X"), move=(0.55, y, 0.98))
    return smooth_object("Dog", bm)


def dog_bones():
    bones = {"root": ((0, 0, 0.2), (0, 0, 0.45), None), "spine": ((-0.4, 0, 0.6), (0.3, 0, 0.62), "root"),
             "neck": ((0.3, 0, 0.62), (0.55, 0, 0.85), "spine"), "head": ((0.55, 0, 0.85), (0.8, 0, 0.85), "neck"),
             "tail": ((-0.4, 0, 0.66), (-0.62, 0, 1.05), "spine")}
    for i, (x, y) in enumerate([(0.3, 0.12), (0.3, -0.12), (-0.3, 0.12), (-0.3, -0.12)]):
        bones[f"leg{i}"] = ((x, y, 0.55), (x, y, 0.03), "spine")
    return bones


def dog_animate(arm):
    """Trots forward in four hops (frames 1..49), then stands still to 96. The root bone points up: its local y
    is world z."""
    end = 49
    for f in range(1, end + 1, 2):
        t = (f - 1) / FPS
        r = arm.pose.bones["root"]
        r.location = (0.0, 0.1 * abs(math.sin(2 * math.pi * t)), 0.0)
        r.keyframe_insert("location", frame=f)
        for name, amp, axis in (("neck", 0.25, 0), ("tail", 0.5, 2), ("leg0", 0.3, 0), ("leg1", -0.3, 0),
                                ("leg2", -0.3, 0), ("leg3", 0.3, 0)):
            pb = arm.pose.bones[name]
            pb.rotation_mode = 'XYZ'
            e = [0.0, 0.0, 0.0]
            e[axis] = amp * math.sin(4 * math.pi * t) if f < end else 0.0
            pb.rotation_euler = e
            pb.keyframe_insert("rotation_euler", frame=f)
    for pb in arm.pose.bones:
        for path in ("location", "rotation_euler"):
            pb.keyframe_insert(path, frame=96)
    return end


def dog_ears(sh, v):
    """The shells of the ears (the two above the head), whose vertices automatic weights leave in no group."""
    return [r for r in np.unique(sh) if abs(v[sh == r, 1].mean()) > 0.05 and v[sh == r, 2].mean() > 0.7]


def weigh_to(obj, bone, vertices):
    """What an artist does when automatic weights leave a part behind (the panel names it): weight its vertices 1
    to the bone it hangs from."""
    idx = [int(i) for i in vertices]
    for g in obj.vertex_groups:
        g.remove(idx)
    obj.vertex_groups[bone].add(idx, 1.0, 'REPLACE')


def dog_weigh_ears(obj):
    v = np.array([x.co for x in obj.data.vertices])
    sh = shells(obj)
    weigh_to(obj, "head", np.where(np.isin(sh, dog_ears(sh, v)))[0])


def dog_maps(obj):
    """Follow 1 but the tail (to 0.1 at its tip), the ears (0.1 at their tips), the belly's underside (to 0.3);
    softness 1 - Follow."""
    dog_weigh_ears(obj)
    v = np.array([x.co for x in obj.data.vertices])
    sh = shells(obj)
    roots = np.unique(sh)
    follow = np.ones(len(v))
    tail = [r for r in roots if v[sh == r, 0].mean() < -0.45][0]
    d = np.linalg.norm(v[sh == tail] - (-0.4, 0, 0.66), axis=1) / 0.45
    follow[sh == tail] = 1 - 0.9 * smooth(d / 0.8)
    regions = {"tail_tip": np.where(sh == tail)[0][d > 0.8]}
    tips = []
    for r in dog_ears(sh, v):
        e = v[sh == r]
        d = np.linalg.norm(e - (0.55, np.sign(e[:, 1].mean()) * 0.1, 0.98), axis=1) / 0.18
        follow[sh == r] = 1 - 0.9 * smooth(d / 0.7)
        tips.append(np.where(sh == r)[0][d > 0.7])
    regions["ear_tips"] = np.concatenate(tips)
    body = np.where(sh == roots[0])[0]
    belly = body[(v[body, 2] < 0.48) & (np.abs(v[body, 0]) < 0.25)]
    follow[belly] = 1 - 0.7 * smooth((0.48 - v[belly, 2]) / 0.06)
    regions["belly"] = belly[v[belly, 2] < 0.43]
    return follow, 1 - follow, regions


# ---------------------------------------------------------------- rig 4: "mole", a metaball body in one shell
def mole_mesh():
    """Metaballs converted to one mesh: a pear-shaped body with a belly, a head, two tall ears and a long tail
    melted into it, four stubby feet (about 1.5 m tall), standing on the floor."""
    from mathutils import Matrix
    mb = bpy.data.metaballs.new("MoleBalls")
    mb.resolution = 0.03
    balls = link(bpy.data.objects.new("MoleBalls", mb))
    for co, size, radius in (((0, 0, 0.45), (1.0, 0.9, 1.1), 0.6), ((0, -0.15, 0.4), (0.8, 0.8, 0.8), 0.45),
                             ((0, -0.05, 0.95), (1, 1, 1), 0.42)):  # body, belly, head
        e = mb.elements.new(type='ELLIPSOID')
        e.co, e.radius, (e.size_x, e.size_y, e.size_z) = co, radius, size
    for x in (0.1, -0.1):  # ears: a chain of balls up from the head
        for k in range(7):
            e = mb.elements.new(type='BALL')
            e.co, e.radius = (x * (1 + 0.2 * k), 0.0, 1.1 + 0.06 * k), 0.15 - 0.008 * k
    for k in range(12):  # tail: a chain out of the back, rising
        e = mb.elements.new(type='BALL')
        e.co, e.radius = (0.0, 0.3 + 0.05 * k, 0.3 + 0.004 * k * k), 0.16 - 0.006 * k
    for x in (0.18, -0.18):
        for y in (0.15, -0.15):
            e = mb.elements.new(type='BALL')
            e.co, e.radius = (x, y, 0.1), 0.2
    dg = bpy.context.evaluated_depsgraph_get()
    mesh = bpy.data.meshes.new_from_object(balls.evaluated_get(dg))
    bpy.data.objects.remove(balls)
    mesh.name = "Mole"
    lowest = min(v.co.z for v in mesh.vertices)
    mesh.transform(Matrix.Translation((0.0, 0.0, 0.005 - lowest)))  # standing on the floor
    return link(bpy.data.objects.new("Mole", mesh))


def mole_bones():
    return {"root": ((0, 0, 0.1), (0, 0, 0.3), None), "spine": ((0, 0, 0.3), (0, 0, 0.8), "root"),
            "head": ((0, 0, 0.8), (0, 0, 1.1), "spine"), "ear.L": ((0.13, 0, 1.1), (0.25, 0, 1.5), "head"),
            "ear.R": ((-0.13, 0, 1.1), (-0.25, 0, 1.5), "head"), "tail": ((0, 0.35, 0.3), (0, 0.95, 1.1), "root")}


def mole_animate(arm):
    """Two hops forward (1..33) with the head nodding, a sharp head turn (33..41), stands to 96. The root bone
    points up: its local y is world z, local z world -y."""
    p = arm.pose.bones
    for b in p:
        b.rotation_mode = 'XYZ'
    for f, fwd, up, nod in ((1, 0, 0, 0), (5, 0.05, -0.06, 10), (11, 0.3, 0.35, -10), (17, 0.55, 0, 15),
                            (21, 0.6, -0.06, 10), (27, 0.85, 0.35, -10), (33, 1.1, 0, 0)):
        key(p["root"], "location", 2, f, fwd)
        key(p["root"], "location", 1, f, up)
        key(p["head"], "rotation_euler", 0, f, math.radians(nod))
    for f, a in ((33, 0), (37, 40), (41, 0)):
        key(p["head"], "rotation_euler", 2, f, math.radians(a))
    return 41


def mole_maps(obj):
    """Follow 1 but the ears (to 0.1 at their tips), the tail (to 0.15 at its tip) and the belly's front (to
    0.2); softness 1 - Follow."""
    v = np.array([x.co for x in obj.data.vertices])
    ear = smooth((v[:, 2] - 1.15) / 0.35) * (np.abs(v[:, 0]) > 0.08)
    tail = smooth((v[:, 1] - 0.45) / (v[:, 1].max() - 0.5)) * (v[:, 2] < 0.9)
    front = -v[np.abs(v[:, 2] - 0.4) < 0.1, 1].max()  # the belly's frontmost point
    belly = smooth((-v[:, 1] - front + 0.08) / 0.06) * smooth((0.2 - np.abs(v[:, 2] - 0.4)) / 0.1)
    follow = 1 - np.max([0.9 * ear, 0.85 * tail, 0.8 * belly], axis=0)
    regions = {"ear_tips": np.where(ear > 0.95)[0], "tail_tip": np.where(tail > 0.95)[0],
               "belly": np.where(belly > 0.9 * belly.max())[0]}
    assert all(len(r) for r in regions.values()), {k: len(r) for k, r in regions.items()}
    return follow, 1 - follow, regions


# ---------------------------------------------------------------- rig 5: "kid", a remeshed child in clothes
KID_JOINTS = {  # name: position (the child faces -y, feet on the floor)
    "ground": (0, 0, 0), "pelvis": (0, 0, 0.6), "waist": (0, 0, 0.72), "chest": (0, 0, 0.9),
    "neck": (0, 0, 1.0), "head": (0, 0, 1.05), "crown": (0, 0, 1.25),
    **{k + s: (x * (1 if s == ".L" else -1), y, z) for s in (".L", ".R") for k, (x, y, z) in {
        "shoulder": (0.13, 0, 0.92), "elbow": (0.27, 0, 0.79), "wrist": (0.38, 0, 0.66), "fingertip": (0.45, 0, 0.57),
        "hip": (0.075, 0, 0.6), "knee": (0.08, 0, 0.33), "ankle": (0.08, 0, 0.07), "toe": (0.08, -0.1, 0.03)}.items()},
}
KID_BONES = {  # name: (head joint, tail joint, parent)
    "root": ("ground", "pelvis", None), "hips": ("pelvis", "waist", "root"), "spine": ("waist", "chest", "hips"),
    "chest": ("chest", "neck", "spine"), "neck": ("neck", "head", "chest"), "head": ("head", "crown", "neck"),
    **{k + s: (a + s, b + s, p if p in ("hips", "chest") else p + s) for s in (".L", ".R")
       for k, (a, b, p) in {"upper_arm": ("shoulder", "elbow", "chest"), "forearm": ("elbow", "wrist", "upper_arm"),
                            "hand": ("wrist", "fingertip", "forearm"), "thigh": ("hip", "knee", "hips"),
                            "shin": ("knee", "ankle", "thigh"), "foot": ("ankle", "toe", "shin")}.items()},
}
KID_SKIRT = (0.74, 0.45)  # the skirt's waistband and hem heights
KID_PONYTAIL = (0, 0.1, 1.17)  # where the ponytail leaves the head


def limb(bm, a, b, r1, r2, segments=12, cuts=4):
    """A capped tube from point a (radius r1) to point b (r2)."""
    a, b = Vector(a), Vector(b)
    turn = Vector((0, 0, 1)).rotation_difference(b - a).to_matrix()
    piece(bm, tube(r1, r2, (b - a).length, segments, cuts, up=True), rotate=turn, move=a)


def kid_body():
    """The body as an artist blocks it out: overlapping primitives (torso, head, A-posed arms, three fingers and
    a thumb on each hand, legs, feet), then a voxel Remesh into one shell."""
    j = {k: Vector(v) for k, v in KID_JOINTS.items()}
    bm = bmesh.new()
    piece(bm, sphere(24, 12), scale=(0.14, 0.1, 0.11), move=(0, 0, 0.63))  # pelvis
    piece(bm, sphere(24, 12), scale=(0.13, 0.09, 0.2), move=(0, 0, 0.82))  # torso
    limb(bm, j["chest"], j["head"], 0.045, 0.04)  # neck
    piece(bm, sphere(24, 16), scale=(0.12, 0.12, 0.13), move=(0, 0, 1.14))  # head
    for s in (".L", ".R"):
        piece(bm, sphere(12, 8), scale=(0.05, 0.05, 0.05), move=j["shoulder" + s])
        limb(bm, j["shoulder" + s], j["elbow" + s], 0.04, 0.033)
        limb(bm, j["elbow" + s], j["wrist" + s], 0.033, 0.027)
        limb(bm, j["hip" + s], j["knee" + s], 0.06, 0.045)
        limb(bm, j["knee" + s], j["ankle" + s], 0.045, 0.035)
        piece(bm, sphere(16, 8), scale=(0.04, 0.085, 0.035), move=j["ankle" + s] + Vector((0, -0.04, -0.025)))
        palm = j["wrist" + s] + (j["fingertip" + s] - j["wrist" + s]) * 0.35
        piece(bm, sphere(12, 8), scale=(0.03, 0.015, 0.03), move=palm)  # a flat palm, fingers along the arm
        down = (j["fingertip" + s] - j["wrist" + s]).normalized()
        for dy in (-0.016, 0.0, 0.016):
            limb(bm, palm, palm + down * 0.07 + Vector((0, dy, 0)), 0.011, 0.009, 8, 3)  # fingers
        limb(bm, palm, palm + Vector((0, -0.045, 0.005)), 0.011, 0.01, 8, 2)  # thumb, to the front
    blocks = smooth_object("KidBlocks", bm)
    remesh = blocks.modifiers.new("Remesh", 'REMESH')
    remesh.mode, remesh.voxel_size = 'VOXEL', 0.01
    dg = bpy.context.evaluated_depsgraph_get()
    body = bpy.data.meshes.new_from_object(blocks.evaluated_get(dg))
    bpy.data.objects.remove(blocks)
    return body


def kid_mesh():
    """The remeshed body, then the clothes and hair as loose shells: a skirt (an open sheet, no thickness) from
    the waist, a 0.3 m ponytail, a backpack."""
    from mathutils import Matrix
    bm = bmesh.new()
    body = kid_body()
    bm.from_mesh(body)
    bpy.data.meshes.remove(body)
    top, hem = KID_SKIRT
    piece(bm, tube(0.155, 0.24, top - hem, 32, 6, caps=False), move=(0, 0, top))  # skirt, flaring out
    piece(bm, tube(0.03, 0.012, 0.3, 10, 10), rotate=Matrix.Rotation(math.radians(35), 3, 'X'),
          move=KID_PONYTAIL)  # ponytail, hanging down the back
    piece(bm, lambda t: bmesh.ops.create_cube(t, size=1.0), scale=(0.2, 0.09, 0.24), move=(0, 0.16, 0.84))
    return smooth_object("Kid", bm)


def kid_bones():
    return {b: (KID_JOINTS[h], KID_JOINTS[t], p) for b, (h, t, p) in KID_BONES.items()}


def kid_animate(arm):
    """Swings the arms fast (1..13, 60 degrees each way at 4 Hz), crouches, jumps 0.3 m and lands (13..30),
    spins about the root 180 degrees in 8 frames (30..38), stands still to 96. The root bone points up: its
    local y is world z."""
    p = arm.pose.bones
    for b in p:
        b.rotation_mode = 'XYZ'
    for f in range(1, 14):
        swing = math.sin(2 * math.pi * 4 * (f - 1) / FPS) if f < 13 else 0.0
        for side, sign in (("L", 1), ("R", -1)):
            key(p["upper_arm." + side], "rotation_euler", 0, f, math.radians(60 * swing * sign))
            key(p["forearm." + side], "rotation_euler", 0, f, math.radians(30 * max(swing * sign, 0)))
    for f, up, dip, crouch in ((13, 0, 0, 0), (17, 0, -0.04, 1), (20, 0.3, 0, 0), (23, 0.3, 0, 0), (26, 0, 0, 0),
                               (28, 0, -0.03, 0.8), (30, 0, 0, 0)):
        key(p["root"], "location", 1, f, up)
        key(p["hips"], "location", 1, f, dip)
        key(p["spine"], "rotation_euler", 0, f, math.radians(20 * crouch))
        for side in ("L", "R"):
            key(p["thigh." + side], "rotation_euler", 0, f, math.radians(-30 * crouch))
            key(p["shin." + side], "rotation_euler", 0, f, math.radians(60 * crouch))
            key(p["foot." + side], "rotation_euler", 0, f, math.radians(-30 * crouch))
    for f, turn in ((30, 0), (38, 180)):
        key(p["root"], "rotation_euler", 1, f, math.radians(turn))
    return 38


def kid_maps(obj):
    """Shells in build order: body, skirt, ponytail, backpack. Follow 1 on the body (fingers too), the skirt
    from 1 at its waistband to 0.1 at its hem, the ponytail to 0.1 at its tip, the backpack 0.5; softness 1 -
    Follow."""
    v = np.array([x.co for x in obj.data.vertices])
    sh = shells(obj)
    order = {r: i for i, r in enumerate(np.unique(sh))}
    part = np.array([order[r] for r in sh])
    assert part.max() == 3, f"the remeshed body is {len(order) - 3} shells, not one"
    weigh_to(obj, "chest", np.where(part == 3)[0])  # the backpack, which automatic weights leave unweighted
    top, hem = KID_SKIRT
    skirt = (part == 1) * smooth((top - v[:, 2]) / (top - hem))
    tail = (part == 2) * smooth(np.linalg.norm(v - np.array(KID_PONYTAIL), axis=1) / 0.3)
    follow = 1 - 0.9 * np.maximum(skirt, tail) - 0.5 * (part == 3)
    regions = {"skirt_hem": np.where(skirt > 0.95)[0], "ponytail_tip": np.where(tail > 0.9)[0],
               "backpack": np.where(part == 3)[0]}
    assert all(len(r) for r in regions.values()), {k: len(r) for k, r in regions.items()}
    return follow, 1 - follow, regions


# ---------------------------------------------------------------- rig, animation, maps
def armature(bones):
    arm = link(bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig")))
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    for name, (head, tail, parent) in bones.items():
        b = arm.data.edit_bones.new(name)
        b.head, b.tail = head, tail
        if parent:
            b.parent = arm.data.edit_bones[parent]
            b.use_connect = False
    bpy.ops.object.mode_set(mode='OBJECT')
    return arm


def key(pb, path, index, frame, value):
    getattr(pb, path)[index] = value
    pb.keyframe_insert(path, index=index, frame=frame)


def gob_animate(arm):
    """Walks four steps (1..37, 1 m forward), crouches and jumps 0.45 m (37..55, 0.3 m forward), lands with a
    small dip, stands from frame 60 to 96. The hips bone points up: its local y is world z, local z world -y."""
    p = arm.pose.bones
    for b in p:
        b.rotation_mode = 'XYZ'
    table = [  # frame, forward, up, stride (-1..1), crouch (0..1), arms up (0..1)
        (1, 0.0, 0.0, 0, 0, 0), (10, 0.25, 0.0, 1, 0, 0), (19, 0.5, 0.0, -1, 0, 0), (28, 0.75, 0.0, 1, 0, 0),
        (37, 1.0, 0.0, 0, 0, 0), (43, 1.0, -0.14, 0, 1, 0), (47, 1.12, 0.45, 0, 0, 1), (50, 1.2, 0.45, 0, 0, 1),
        (53, 1.3, 0.0, 0, 0, 0), (55, 1.3, -0.08, 0, 0.5, 0), (60, 1.3, 0.0, 0, 0, 0)]
    for f, fwd, up, s, crouch, arms in table:
        key(p["hips"], "location", 2, f, fwd)
        key(p["hips"], "location", 1, f, up)
        key(p["spine"], "rotation_euler", 1, f, math.radians(8 * s))
        for side, sign in (("L", 1), ("R", -1)):
            key(p["thigh." + side], "rotation_euler", 0, f, math.radians(25 * s * sign - 35 * crouch))
            key(p["shin." + side], "rotation_euler", 0, f, math.radians(70 * crouch))
            key(p["foot." + side], "rotation_euler", 0, f, math.radians(-35 * crouch))
            key(p["upper_arm." + side], "rotation_euler", 0, f, math.radians(-20 * s * sign))
            key(p["upper_arm." + side], "rotation_euler", 2, f, math.radians(60 * arms * sign))
    return 60


def ellie_animate(arm):
    """Trots 1 m forward with a bob and swinging legs (1..31), shakes its head three times (31..51), stands to
    96. The root bone points forward (-y): its local y is world -y, local z world z."""
    p = arm.pose.bones
    for b in p:
        b.rotation_mode = 'XYZ'
    for i, f in enumerate(range(1, 32, 5)):
        swing = 0 if f in (1, 31) else (1 if i % 2 else -1)
        key(p["root"], "location", 1, f, (f - 1) / 30)
        key(p["root"], "location", 2, f, 0.05 * abs(swing))
        for leg, ph in (("leg.FL", 1), ("leg.BR", 1), ("leg.FR", -1), ("leg.BL", -1)):
            key(p[leg], "rotation_euler", 0, f, math.radians(18 * ph * swing))
    for f, a in ((31, 0), (35, 25), (39, -25), (43, 25), (47, -25), (51, 0)):
        key(p["head"], "rotation_euler", 2, f, math.radians(a))
        key(p["head"], "rotation_euler", 0, f, math.radians(10 if a else 0))
    return 51


def smooth(x):
    x = np.clip(x, 0, 1)
    return x * x * (3 - 2 * x)


def gob_maps(obj):
    v = np.array([x.co for x in obj.data.vertices])
    sh = shells(obj)
    roots, sizes = np.unique(sh, return_counts=True)
    body = np.isin(sh, roots[sizes > 100])  # the Skin modifier's hulls (one shell in 3.4, several in 5.2)
    band = body & (np.abs(v[:, 2] - 1.08) < 0.22)
    front = -v[band, 1].min()  # Subdivision pulls the belly node's hull in: y -0.18 in 3.4.1, not the node's -0.33
    belly = smooth((-v[:, 1] - front + 0.1) / 0.08) * smooth((0.22 - np.abs(v[:, 2] - 1.08)) / 0.12) * body
    cheek = np.zeros(len(v))
    for c in ((0.08, -0.08, 1.6), (-0.08, -0.08, 1.6)):
        d = np.linalg.norm(v - np.array(c) - np.array((0.03 * np.sign(c[0]), -0.03, 0)), axis=1)
        cheek = np.maximum(cheek, smooth((0.1 - d) / 0.06) * body)
    follow = 1 - np.maximum(0.8 * belly, 0.7 * cheek)
    soft = np.maximum(belly, cheek)
    eyes = ~body & (v[:, 2] > 1.5)
    buttons = ~body & (v[:, 2] < 1.5)
    follow[buttons] = 0.25
    soft[buttons] = 1.0
    follow[eyes] = 0.6
    regions = {"belly": np.where(belly > 0.95 * belly.max())[0], "cheeks": np.where(cheek > 0.9 * cheek.max())[0],
               "eyes": np.where(eyes)[0], "buttons": np.where(buttons)[0]}
    assert follow[regions["belly"]].max() < 0.25, "the belly map misses the mesh's belly"
    return follow, soft, regions


def ellie_maps(obj):
    """Shells in build order: body, head, trunk, ear.L, ear.R, tail, four legs. Follow 1 on all but the trunk
    (to 0.05 at its tip), the ears (to 0.1 at their outer edge) and the tail (to 0.1 at its tip)."""
    v = np.array([x.co for x in obj.data.vertices])
    sh = shells(obj)
    order = {r: i for i, r in enumerate(np.unique(sh))}
    part = np.array([order[r] for r in sh])
    trunk = (part == 2) * np.clip((1.28 - v[:, 2]) / 0.9, 0, 1)
    ear = np.isin(part, (3, 4)) * np.clip((np.abs(v[:, 0]) - 0.225) / 0.45, 0, 1)
    tail = (part == 5) * np.clip(np.linalg.norm(v - np.array((0, 0.7, 1.1)), axis=1) / 0.5, 0, 1)
    loose = np.max([0.95 * smooth((trunk - 0.1) / 0.9), 0.9 * smooth((ear - 0.15) / 0.85),
                    0.9 * smooth((tail - 0.2) / 0.8)], axis=0)
    follow = 1 - loose
    regions = {"trunk_tip": np.where(trunk > 0.9)[0], "ear_edges": np.where(ear > 0.9)[0],
               "tail_tip": np.where(tail > 0.85)[0]}
    return follow, loose / 0.95, regions


def floor():
    bpy.ops.mesh.primitive_plane_add(size=10.0)
    f = bpy.context.active_object
    f.name = "Floor"
    f.modifiers.new("Collision", 'COLLISION')
    return f


RIGS = {"gob": (gob_mesh, gob_bones, gob_animate, gob_maps),
        "ellie": (ellie_mesh, ellie_bones, ellie_animate, ellie_maps),
        "dog": (dog_mesh, dog_bones, dog_animate, dog_maps),
        "mole": (mole_mesh, mole_bones, mole_animate, mole_maps),
        "kid": (kid_mesh, kid_bones, kid_animate, kid_maps)}
VIEWS = {"gob": ((0.0, -1.3, 1.1), (1.2, -1.8, 0.5)), "ellie": ((0.2, -1.0, 1.0), (1.6, -2.2, 0.6)),
         "dog": ((0.15, 0.0, 0.65), (1.3, -2.3, 0.6)), "mole": ((0.0, -1.1, 0.75), (2.6, -3.0, 0.7)),
         "kid": ((0.0, 0.0, 0.75), (1.2, -2.2, 0.4))}  # camera target (where it is mid-motion) and offset
NAMES = {"gob": "Gob", "ellie": "Ellie", "dog": "Dog", "mole": "Mole", "kid": "Kid"}


def build():
    scene = bpy.context.scene
    scene.render.fps, scene.frame_start, scene.frame_end = FPS, 1, 96
    make, bones, animate, maps = RIGS[RIG]
    obj = make()
    arm = armature(bones())
    parent_auto(obj, arm)
    end = animate(arm)
    follow, soft, regions = maps(obj)
    floor()
    return obj, arm, end, follow, soft, regions


# ---------------------------------------------------------------- measure
def digest(a):
    """A short hash of an array's bits (None: None)."""
    import hashlib
    return None if a is None else hashlib.sha1(np.ascontiguousarray(a).tobytes()).hexdigest()[:10]


def main():
    module_name = install(ZIP, KIND)
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    obj, arm, end, follow, soft, regions = build()
    n = len(obj.data.vertices)
    sh = shells(obj)
    v = np.array([x.co for x in obj.data.vertices])
    print("SHELLS", [(int((sh == r).sum()), v[sh == r].mean(0).round(2).tolist()) for r in np.unique(sh)])
    print("REGIONS", {r: len(i) for r, i in regions.items()}, "follow min", follow.min())
    print(f"RIG {RIG}: {n} vertices, {len(np.unique(sh))} shells, {len(arm.data.bones)} bones, motion ends {end}")
    if VARIANT in ("painted", "goal", "Subtle", "Floppy", "Jelly", "reopen", "late"):
        paint(obj, "follow", follow)
        if VARIANT != "goal":
            paint(obj, "softness", soft)
    twin = twin_of(obj)
    s = obj.opdeform
    bpy.context.view_layer.objects.active = obj
    for o in bpy.context.scene.objects:
        o.select_set(o == obj)
    before = base(obj)
    for k in [e for e in EXTRA if "=" in e and not e.startswith("+")]:
        name, value = k.split("=")
        setattr(s, name, type(getattr(s, name))(value))
    if VARIANT == "late":  # Enable first, then tick and pick (the click order)
        bpy.ops.opdeform.enable(object=obj.name)
        s.use_goal, s.goal_group, s.softness_group = True, "follow", "softness"
    else:
        if VARIANT != "none":
            s.use_goal = True
            s.goal_group = "follow"
            if VARIANT != "goal":
                s.softness_group = "softness"
        bpy.ops.opdeform.enable(object=obj.name)
    if VARIANT in ("Subtle", "Floppy", "Jelly"):
        bpy.ops.opdeform.apply_preset(object=obj.name, preset=VARIANT)
    for k in [e[1:] for e in EXTRA if e.startswith("+")]:  # +NAME=VALUE: set after Enable and the look
        name, value = k.split("=")
        setattr(s, name, type(getattr(s, name))(value))
    print("SETTINGS", {k: getattr(s, k) for k in ("use_goal", "goal_group", "softness_group", "goal_strength",
                                                   "particles", "modulus", "damping_rate", "sag", "goal_min",
                                                   "goal_max", "soft_stiffness")}, "built", s.built, "err", s.error)
    st = sys.modules[module_name + ".blender.state"].get(obj)
    if st is not None and st.engine.goal_strength is not None:
        gs = st.engine.goal_strength
        print("PARTICLE_FOLLOW n", len(gs), "min", gs.min(), "sorted low", np.sort(gs)[:12].round(3))
        count, piece, _ = st.engine.pieces()
        print("PIECES", [(int((piece == k).sum()), gs[piece == k].min().round(3) if (piece == k).any() else None)
                         for k in range(count)], "(particles, least Follow; None: attached)")
    if st is not None:  # the graph's inputs and the graph, to tell run-to-run differences apart
        e = st.engine
        weights = np.array([[w.group, w.weight] for x in obj.data.vertices for w in x.groups])
        print("HASHES", {k: digest(a) for k, a in dict(rest=e.rest, triangles=e.triangles, weights=weights,
                                                        centers=e.graph.centers, follow=e.follow,
                                                        particle_follow=e.goal_strength).items()})
        if os.environ.get("OUTSIDE_RIGS_DUMP"):
            np.savez(os.environ["OUTSIDE_RIGS_DUMP"], rest=e.rest, triangles=e.triangles, weights=weights,
                     centers=e.graph.centers, particle_follow=e.goal_strength)
    sys.path.insert(0, TESTS)
    import helpers as H
    H.ADDON = module_name
    log = H.draw_panels()
    print("PANEL_LABELS", [e[1] for e in log if e[0] == "label"])
    print("CUT", H.cut_texts(log))
    core = np.where(follow >= 0.99)[0] if VARIANT not in ("none",) else np.array([], int)
    loose = np.concatenate(list(regions.values()))
    edges = np.array([e.vertices[:] for e in obj.data.edges])
    rest = base(obj).reshape(-1, 3)
    size = float((rest.max(0) - rest.min(0)).max())
    rows, offs, frames, shown_at = [], [], [], {}
    held, kept = sys.modules[module_name + ".blender.state"].get(obj), {}
    scene = bpy.context.scene
    for f in range(1, 97):
        scene.frame_set(f)
        assert not s.error, s.error
        a, b_ = world(obj), world(twin)
        shown_at[f] = a
        d = np.linalg.norm(a - b_, axis=1)
        i, j = edges.T
        st = np.linalg.norm(a[i] - a[j], axis=1) / np.linalg.norm(b_[i] - b_[j], axis=1)
        row = dict(core=d[core].max() if len(core) else 0.0, all=d.max(), stretch=st.max(), stretched=i[np.argmax(st)],
                   lowest=a[:, 2].min(), lowest_twin=b_[:, 2].min())
        row.update({r: d[ix].max() for r, ix in regions.items()})
        rows.append(row)
        offs.append((a - b_)[loose])
        frames.append(f)
        if os.environ.get("OUTSIDE_RIGS_STRETCH"):
            keep_frame(kept, held, a, b_)
    col = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    after = [k for k, f in enumerate(frames) if f >= end]
    unsettled = [k for k in after if col["all"][k] > 2e-3]
    settle = 0.0 if not unsettled else ((frames[unsettled[-1] + 1] - end) / FPS if unsettled[-1] + 1 < len(frames) else None)
    last = offs[-1]
    sec = max(np.linalg.norm(offs[k] - last, axis=1).max() for k, f in enumerate(frames) if f <= end)
    worst = int(np.argmax(col[list(regions)[0]][:end]))
    summary = dict(rig=RIG, variant=VARIANT, host=bpy.app.version_string, vertices=n, particles=s.particles,
                   core_mm=1e3 * col["core"].max(),
                   **{r + "_mm": 1e3 * col[r].max() for r in regions}, secondary_pct=100 * sec / size,
                   stretch=col["stretch"].max(), stretch_frame=frames[int(np.argmax(col["stretch"]))],
                   stretch_at=rest[col["stretched"][np.argmax(col["stretch"])]].round(3).tolist(), lowest_mm=1e3 * col["lowest"].min(),
                   lowest_twin_mm=1e3 * col["lowest_twin"].min(), settle_s=settle,
                   after_1s_mm=1e3 * col["all"][after[FPS:]].max(), base_kept=bool(np.array_equal(base(obj), before)),
                   size=size, worst_frame=frames[worst])
    print("SUMMARY " + json.dumps(summary))
    if os.environ.get("OUTSIDE_RIGS_STRETCH"):
        save_frames(os.environ["OUTSIDE_RIGS_STRETCH"], kept, held.engine, edges)
    if os.environ.get("OUTSIDE_RIGS_TRACE"):  # each frame's largest offsets (mm), to see how a part comes back
        print("TRACE", json.dumps({k: [round(1e3 * x, 2) for x in col[k]] for k in ["all", *regions]}))
    if VARIANT == "painted" and "norender" not in EXTRA:
        render(obj, twin, frames[worst])
    if VARIANT == "painted":  # bake = playback
        s.cache_directory = os.path.join(OUT, f"cache_{RIG}_{KIND}")
        bpy.ops.opdeform.bake(object=obj.name)
        assert s.baked and not s.error, s.error
        worst_b = 0.0
        for f in (1, 20, end, 96):
            scene.frame_set(f)
            worst_b = max(worst_b, np.abs(world(obj) - shown_at[f]).max())
        print("BAKE_VS_PLAY", worst_b)
    if VARIANT == "reopen":
        scene.frame_set(30)
        np.save(os.path.join(OUT, f"{RIG}_{KIND}_f30.npy"), world(obj))
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(OUT, f"{RIG}_{KIND}.blend"))
        print("SAVED")


def keep_frame(kept, st, shown, armature_only):
    """OUTSIDE_RIGS_STRETCH: one frame's shown and armature-only vertices, particles and goal frames."""
    e = st.engine
    n = e.graph.n_particles
    goals = e._fitted[1] if e._fitted is not None else (e.graph.centers, np.tile(np.eye(3), (n, 1, 1)))
    for k, v in dict(shown=shown, armature_only=armature_only, positions=e.shown_state[0],
                     rotations=e.shown_state[1], goal_positions=goals[0], goal_rotations=goals[1]).items():
        kept.setdefault(k, []).append(np.array(v, dtype=np.float64))


def save_frames(path, kept, e, edges):
    """The frames keep_frame kept, with the graph, the skin and the per-particle maps, in one npz."""
    np.savez(path, **{k: np.array(v) for k, v in kept.items()}, edges=edges, centers=e.graph.centers,
             graph_edges=e.graph.edges, volumes=e.graph.volumes, stiffness=np.ravel(e._params["stiffness"]),
             skin_indices=e.skin.indices, skin_weights=e.skin.weights, rest=e.rest, follow=e.goal_strength,
             softness=e._softness if e._softness is not None else np.ones(e.graph.n_particles))


def render(obj, twin, frame):
    scene = bpy.context.scene
    scene.render.engine = 'CYCLES'
    scene.cycles.samples = 16
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 480, 480
    for o, col, alpha in ((obj, (0.85, 0.45, 0.3, 1), 1.0), (twin, (0.3, 0.45, 0.9, 1), 1.0)):
        mat = bpy.data.materials.new(o.name)
        mat.use_nodes = True
        bsdf = mat.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = col
        bsdf.inputs["Alpha"].default_value = alpha
        o.data.materials.clear()
        o.data.materials.append(mat)
    cam = link(bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam")))
    target, offset = (Vector(x) for x in VIEWS[RIG])
    cam.location = target + offset
    d = target - cam.location
    cam.rotation_euler = d.to_track_quat('-Z', 'Y').to_euler()
    scene.camera = cam
    sun = link(bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN')))
    sun.rotation_euler = (0.7, 0.2, 0.5)
    sun.data.energy = 3.0
    world = bpy.data.worlds.new("W")
    world.color = (0.4, 0.4, 0.45)
    scene.world = world
    scene.frame_set(frame)
    for shown, hidden, name in ((obj, twin, "opdeform"), (twin, obj, "armature")):
        shown.hide_render, hidden.hide_render = False, True
        scene.render.filepath = os.path.join(OUT, f"{RIG}_{KIND}_f{frame}_{name}.png")
        bpy.ops.render.render(write_still=True)
        print("RENDER", scene.render.filepath)


if VARIANT == "open":
    install(ZIP, KIND)
    bpy.ops.wm.open_mainfile(filepath=os.path.join(OUT, f"{RIG}_{KIND}.blend"))
    obj = bpy.data.objects[NAMES[RIG]]
    a = world(obj)
    ref = np.load(os.path.join(OUT, f"{RIG}_{KIND}_f30.npy"))
    print("REOPEN frame", bpy.context.scene.frame_current, "max diff mm", 1e3 * np.abs(a - ref).max(),
          "error", obj.opdeform.error)
else:
    main()
