"""Outside tester 50 (issue 24): a 2 m dancer ("Dancer") with thin flat appendages the add-on has not seen. ONE
object: a slim Skin-modifier body (pelvis, waist, chest, neck, head, arms, legs with feet; Subdivision 2 applied),
then joined in as separate OPEN single-sided shells: a skirt of 12 planar cards (each 3 x 10 quads, 0.16 m wide,
0.6 m long) hanging from the waist and flaring out, and 10 flat hair ribbons (each 2 x 12 quads, 4 cm wide, 0.6 m
long) from the back of the head down the back. A 12-bone armature (root + 11 deform) with automatic weights; the
cards and ribbons, which they weight badly (a card swung up with an arm, the ribbons missed), repainted 1 to the
hips (skirt) or the head (hair). A jump (frames 4-24, 0.4 m), then a full turn
on the spot at constant speed (frames 24-36, 720 deg/s) with the arms out, linear keys, a dead stop at 36, still
until 96. Follow: 1 on the body, each card 1 at its top row -> 0.15 at its hem, each ribbon 1 at the head -> 0.1
at its tip. Floor with Collision.
    blender -b --factory-startup --python-exit-code 1 -P scripts/outside_dancer.py -- - dev OUT [opts]
    bpy-python scripts/outside_dancer.py - dev OUT [opts]    (or ZIP legacy / ZIP extension)
opts: particles=N look=NAME +NAME=VALUE looks bake save scrub open=OUT (as scripts/outside_blob.py); levels=L
(Subdivision, 2); thick=T (cards and ribbons closed by a Solidify of thickness T, applied); render=F (Workbench
stills of frame F after the first play: OUT/dancer_F.png and the armature-only OUT/dancer_F_armature.png)
"""
import math, os, sys
import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import (armature, collision_floor, joined, link, paint, parent_auto, reshaped,  # noqa: E402
                       skin_body, still, taper, twin_of)

OUT, OPT = rig_parts.options()[2:]
FPS, FRAMES, JUMP, STOP = 24, 96, (4, 24), 36

# the trunk (pelvis 0, waist, chest 2, neck, head) and per side, mirrored in x, the limbs: (the trunk node they
# start from, [(position, radius)]) and their bones (name, head, tail, parent: a trunk bone or the limb's own)
NODES = [((0, 0, 0.98), 0.15), ((0, 0, 1.12), 0.12), ((0, 0, 1.35), 0.16), ((0, 0, 1.55), 0.06),
         ((0, 0, 1.70), 0.10), ((0, 0, 1.86), 0.09)]
EDGES = [(k, k + 1) for k in range(5)]
LIMBS = [(2, [((0.22, 0, 1.45), 0.06), ((0.48, 0, 1.30), 0.045), ((0.70, 0, 1.15), 0.04)]),
         (0, [((0.10, 0, 0.85), 0.08), ((0.11, 0, 0.47), 0.06), ((0.11, 0, 0.08), 0.05), ((0.11, -0.14, 0.04), 0.04)])]
LIMB_BONES = [("upperarm", (0.20, 0, 1.46), (0.48, 0, 1.30), "spine"), ("forearm", (0.48, 0, 1.30), (0.72, 0, 1.13),
              "upperarm"), ("thigh", (0.10, 0, 0.85), (0.11, 0, 0.47), "hips"), ("shin", (0.11, 0, 0.47),
              (0.11, 0, 0.06), "thigh")]
BONES = [("root", (0, 0, 0), (0, -0.3, 0), None, False), ("hips", (0, 0, 0.85), (0, 0, 1.15), "root", True),
         ("spine", (0, 0, 1.15), (0, 0, 1.55), "hips", True), ("head", (0, 0, 1.55), (0, 0, 1.98), "spine", True)]


def mirrored(p, sx):
    return (sx * p[0], p[1], p[2])


for side, sx in (("L", 1), ("R", -1)):
    for start, chain in LIMBS:
        EDGES += [(start, len(NODES))] + [(len(NODES) + i, len(NODES) + i + 1) for i in range(len(chain) - 1)]
        NODES += [(mirrored(p, sx), r) for p, r in chain]
    BONES += [(f"{b}.{side}", mirrored(h, sx), mirrored(t, sx), p if p in ("spine", "hips") else f"{p}.{side}", True)
              for b, h, t, p in LIMB_BONES]

def card(name, columns, rows, point):
    """A single-sided grid of columns x rows quads at point(u, v) (u across 0..1, v down 0..1), linked; with
    thick=T closed by an applied Solidify."""
    verts = [point(i / columns, j / rows) for j in range(rows + 1) for i in range(columns + 1)]
    faces = [(j * (columns + 1) + i, j * (columns + 1) + i + 1, (j + 1) * (columns + 1) + i + 1,
              (j + 1) * (columns + 1) + i) for j in range(rows) for i in range(columns)]
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    obj = link(bpy.data.objects.new(name, me))
    if "thick" in OPT:
        bpy.context.view_layer.objects.active = obj
        obj.modifiers.new("Solidify", 'SOLIDIFY').thickness = float(OPT["thick"])
        bpy.ops.object.modifier_apply(modifier="Solidify")
    return obj


def skirt_card(k):
    a = 2 * math.pi * k / 12

    def point(u, v):
        r, t = 0.165 + 0.16 * v, a + (u - 0.5) * 0.16 / 0.2
        return (r * math.cos(t), r * math.sin(t), 1.06 - 0.6 * v)
    return card(f"Card{k}", 3, 10, point)


def ribbon(k):
    a = math.pi / 2 + (k - 4.5) * 0.22  # around the back of the head (+y)

    def point(u, v):
        t = a + (u - 0.5) * 0.04 / 0.1
        r = 0.1 + 0.06 * min(v * 4, 1.0)
        return (r * math.cos(t), r * math.sin(t) + 0.02 * v, 1.84 - 0.6 * v)
    return card(f"Hair{k}", 2, 12, point)


def animate(arm):
    pb = rig_parts.linear_pose(arm)
    for f in range(1, STOP + 1):
        t = (f - JUMP[0]) / (JUMP[1] - JUMP[0])
        arm.location = (0, 0, 0.4 * math.sin(math.pi * t) if 0 <= t <= 1 else 0.0)
        arm.rotation_euler = (0, 0, 2 * math.pi * min(max((f - JUMP[1]) / (STOP - JUMP[1]), 0.0), 1.0))
        out = 0.9 * min(max((f - 14) / 10, 0.0), 1.0)  # the arms rise from the top of the jump
        pb["upperarm.L"].rotation_euler = (0, 0, out)
        pb["upperarm.R"].rotation_euler = (0, 0, -out)
        arm.keyframe_insert("location", frame=f)
        arm.keyframe_insert("rotation_euler", frame=f)
        for b in pb:
            b.keyframe_insert("rotation_euler", frame=f)


def build_scene():
    rig_parts.empty_scene(FPS, FRAMES)
    obj = skin_body("Dancer", NODES, EDGES, int(OPT.get("levels", 2)))
    reshaped(obj, lambda v: None)
    nb = len(obj.data.vertices)
    cards = {f"card{k}": joined(obj, skirt_card(k)) for k in range(12)}
    hair = {f"hair{k}": joined(obj, ribbon(k)) for k in range(10)}
    v = np.array([x.co for x in obj.data.vertices])
    arm = armature("DancerRig", BONES, lambda b, p: not b.startswith(("upperarm", "thigh")))
    parent_auto(obj, arm)
    missed = {}
    for group, pieces in (("hips", cards), ("head", hair)):  # the cards and ribbons repainted 1 to one bone
        ix = [int(i) for i in np.concatenate(list(pieces.values()))]
        missed[group] = sum(not any(g.weight > 0 for g in obj.data.vertices[i].groups) for i in ix)
        for g in obj.vertex_groups:
            g.remove(ix)
        obj.vertex_groups[group].add(ix, 1.0, 'REPLACE')
    body_missed = [x.index for x in obj.data.vertices[:nb] if not any(g.weight > 0 for g in x.groups)]
    obj.vertex_groups["spine"].add(body_missed, 1.0, 'REPLACE')
    animate(arm)
    param = np.zeros(len(v))  # down each card and ribbon, 0 at its top, 1 at its lower end
    for ix in (*cards.values(), *hair.values()):
        param[ix] = (v[ix, 2].max() - v[ix, 2]) / np.ptp(v[ix, 2])
    follow = taper(np.ones(len(v)), {**cards, **hair}, param,
                   [(k, 0.15) for k in cards] + [(k, 0.1) for k in hair])
    paint(obj, "Follow", follow)
    collision_floor()
    twin = twin_of(obj)
    skirt, locks = np.concatenate(list(cards.values())), np.concatenate(list(hair.values()))
    parts = dict(skirt=skirt[param[skirt] >= 0.5], hair=locks[param[locks] >= 0.5])
    print(f"DANCER {len(v)} vertices, {len(obj.data.polygons)} faces, {len(np.unique(rig_parts.shells(obj)))} "
          f"shells, box {v.min(0).round(3).tolist()} {v.max(0).round(3).tolist()}, automatic weights missed "
          f"{missed} body {len(body_missed)}", {k: len(i) for k, i in parts.items()},
          "core", int((follow >= 0.999).sum()), "follow min", {k: float(follow[i].min()) for k, i in parts.items()})
    return obj, twin, parts, follow


def stills(shot):
    f = int(OPT["render"])
    view = dict(frame=f, eye=(2.8, -3.8, 1.5), target=(0, 0, 1.0))
    still(os.path.join(OUT, f"dancer_{f}.png"), hidden=(shot.twin,), **view)
    still(os.path.join(OUT, f"dancer_{f}_armature.png"), hidden=(shot.obj,), **view)


def shot_of(H):
    return rig_parts.PartsShot(*build_scene(), H, FRAMES, STOP, FPS)


rig_parts.run_shot("Dancer", shot_of, (1, 12, 24, 30, 36, 48, 60, FRAMES), stills if "render" in OPT else None)
