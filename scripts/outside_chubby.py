"""Outside tester 49 (issue 24): a chubby 2 m humanoid ("Chub") the add-on has not seen. One object: a Skin-modifier
body (pelvis, big forward belly, chest, neck, head, two arms, two legs with feet, Subdivision 2 applied), a double
chin pushed down/forward under the jaw, and a cape: its own mesh (a 16x24 grid curved behind the back, separate
shell) joined in. A 12-bone armature (root + 11 deform) with automatic weights (missed vertices weighted to the
spine); a jump (frames 8-32, 0.45 m) then a right-hand punch (32-44) stepping 0.6 m forward at constant speed, a
dead stop at 44, still until 96.
Follow: 1 on the core, 1 -> 0.15 to the belly front, 0.15 at the chin, 1 at the cape's top -> 0.15 at its hem.
Floor with Collision.
    blender -b --factory-startup --python-exit-code 1 -P outside_chubby.py -- - dev OUT [opts]
    bpy-python outside_chubby.py - dev OUT [opts]
opts as scripts/outside_pig.py: particles=N look=NAME +NAME=VALUE looks bake save open=OUT; levels=L (Subdivision,
3); capetop=W (the cape's top row's Follow, 1);
capethick=T (the cape closed by a Solidify of thickness T, applied); bonemove (the root bone carries the jump and
step, not the armature object); lunge=M (the step forward with the
punch, frames 32-44 at constant speed, then a dead stop; 0.6)
"""
import math, os, sys
import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import (armature, collision_floor, gauss, install, link, paint, parent_auto, reshaped, skin_body,
                       twin_of)

ZIP, KIND, OUT, OPT = rig_parts.options()
FPS, FRAMES, STOP = 24, 96, 44

NODES = [((0, 0, 0.95), 0.27), ((0, 0, 1.17), 0.36), ((0, 0, 1.40), 0.31), ((0, 0, 1.60), 0.13),
         ((0, 0, 1.76), 0.17), ((0, 0, 1.92), 0.12)]
EDGES = [(k, k + 1) for k in range(5)]
for sx in (1, -1):
    k = len(NODES)
    NODES += [((sx * 0.30, 0, 1.47), 0.11), ((sx * 0.55, 0, 1.30), 0.08), ((sx * 0.74, 0, 1.12), 0.065)]
    EDGES += [(2, k), (k, k + 1), (k + 1, k + 2)]
    k = len(NODES)
    NODES += [((sx * 0.16, 0, 0.80), 0.15), ((sx * 0.17, 0, 0.45), 0.11), ((sx * 0.18, 0, 0.09), 0.085),
              ((sx * 0.18, -0.16, 0.05), 0.06)]
    EDGES += [(0, k), (k, k + 1), (k + 1, k + 2), (k + 2, k + 3)]

BONES = [("root", (0, 0, 0), (0, -0.3, 0), None, False),
         ("hips", (0, 0, 0.85), (0, 0, 1.15), "root", True),
         ("spine", (0, 0, 1.15), (0, 0, 1.55), "hips", True),
         ("head", (0, 0, 1.55), (0, 0, 1.98), "spine", True)]
for side, sx in (("L", 1), ("R", -1)):
    BONES += [(f"upperarm.{side}", (sx * 0.28, 0, 1.48), (sx * 0.55, 0, 1.30), "spine", True),
              (f"forearm.{side}", (sx * 0.55, 0, 1.30), (sx * 0.76, 0, 1.10), f"upperarm.{side}", True),
              (f"thigh.{side}", (sx * 0.16, 0, 0.85), (sx * 0.17, 0, 0.45), "hips", True),
              (f"shin.{side}", (sx * 0.17, 0, 0.45), (sx * 0.18, 0, 0.06), f"thigh.{side}", True)]


def body_mesh():
    obj = skin_body("Chub", NODES, EDGES, int(OPT.get("levels", 3)))

    def push(v):
        belly = gauss(v, (0, -0.36, 1.12), (0.30, 0.16, 0.26)) * (v[:, 1] < 0) * (np.abs(v[:, 0]) < 0.36)
        chin = gauss(v, (0, -0.12, 1.63), (0.13, 0.10, 0.07))
        v[:, 1] -= 0.14 * belly + 0.05 * chin
        v[:, 2] -= 0.05 * chin
        return belly, chin
    belly, chin = reshaped(obj, push)
    return obj, belly, chin


def cape(obj):
    """A 16x24 grid behind the back, from the shoulders (z 1.50) to the knees (z 0.50), curved around; joined in.
    Its vertex indices and each one's parameter from top (0) to hem (1)."""
    n = len(obj.data.vertices)
    v = np.array([x.co for x in obj.data.vertices])
    back = v[:, 1].max()
    verts, faces, W, H = [], [], 16, 24
    for j in range(H + 1):
        z = 1.50 - 1.0 * j / H
        for i in range(W + 1):
            a = -0.9 + 1.8 * i / W
            r = 0.34 + 0.06 * j / H
            verts.append((r * math.sin(a), r * math.cos(a) + 0.04, z))
    for j in range(H):
        for i in range(W):
            q = j * (W + 1) + i
            faces.append((q, q + 1, q + W + 2, q + W + 1))
    me = bpy.data.meshes.new("Cape")
    me.from_pydata(verts, [], faces)
    c = link(bpy.data.objects.new("Cape", me))
    if "capethick" in OPT:  # a closed cape: Solidify applied
        bpy.context.view_layer.objects.active = c
        c.modifiers.new("Solidify", 'SOLIDIFY').thickness = float(OPT["capethick"])
        bpy.ops.object.modifier_apply(modifier="Solidify")
    bpy.ops.object.select_all(action='DESELECT')
    c.select_set(True)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.join()
    ix = np.arange(n, len(obj.data.vertices))
    zc = np.array([obj.data.vertices[i].co.z for i in ix])
    print("CAPE back y", round(back, 3), "cape y range", round(min(p[1] for p in verts), 3))
    return ix, (zc.max() - zc) / (zc.max() - zc.min())


def animate(arm):
    pb = arm.pose.bones
    for b in pb:
        b.rotation_mode = 'XYZ'
    for f in range(1, STOP + 1):
        t = (f - 8) / 24
        z = 0.45 * math.sin(math.pi * t) if 0 <= t <= 1 else 0.0
        lift = 0.5 * math.sin(math.pi * t) if 0 <= t <= 1 else 0.0
        for s in ("L", "R"):
            pb[f"upperarm.{s}"].rotation_euler = (0, 0, 0)
        pb["upperarm.L"].rotation_euler = (0, 0, lift)
        pb["upperarm.R"].rotation_euler = (0, 0, -lift)
        p = (f - 32) / 12
        punch = math.sin(math.pi * min(p, 1.0)) if p > 0 else 0.0
        if p > 0:
            pb["upperarm.R"].rotation_euler = (1.3 * punch, 0, 0)
            pb["forearm.R"].rotation_euler = (0.8 * punch, 0, 0)
            pb["spine"].rotation_euler = (0, 0.25 * punch, 0)
        lunge = float(OPT.get("lunge", 0.6)) * min(max(p, 0.0), 1.0)  # a step forward at 1.2 m/s with the punch
        if "bonemove" in OPT:  # the root bone carries the jump and the step (its local y is world -y, z up)
            pb["root"].location = (0, lunge, z)
            pb["root"].keyframe_insert("location", frame=f)
        else:
            arm.location = (0, -lunge, z)
            arm.keyframe_insert("location", frame=f)
        for b in pb:
            b.keyframe_insert("rotation_euler", frame=f)
    # dead stop: frame 44 pose held (punch mid-swing reaches 0 at p=1 -> body already back; make it abrupt)
    

def follow_map(n, belly, chin, cape_ix, param):
    w = np.ones(n)
    nb = len(belly)
    w[:nb] = 1 - 0.85 * np.clip(np.maximum(belly, chin * 1.2), 0, 1)
    top = float(OPT.get("capetop", 1.0))  # capetop=0.9: the cape's top row painted under 1
    w[cape_ix] = top - (top - 0.15) * param
    return w.round(3)


def build_scene():
    rig_parts.empty_scene(FPS, FRAMES)
    obj, belly, chin = body_mesh()
    cape_ix, param = cape(obj)
    v = np.array([x.co for x in obj.data.vertices])
    arm = armature("ChubRig", BONES, lambda b, p: not b.startswith(("upperarm", "thigh")))
    parent_auto(obj, arm)
    missed = [x.index for x in obj.data.vertices if not any(g.weight > 0 for g in x.groups)]
    if missed:
        obj.vertex_groups["spine"].add(missed, 1.0, 'REPLACE')
    animate(arm)
    follow = follow_map(len(v), belly, chin, cape_ix, param)
    paint(obj, "Follow", follow)
    collision_floor()
    twin = twin_of(obj)
    body = np.arange(len(belly))
    parts = dict(belly=body[belly >= 0.3], chin=body[chin >= 0.3], cape=cape_ix[param >= 0.5])
    print(f"CHUB {len(v)} vertices, {len(obj.data.polygons)} faces, shells {np.unique(rig_parts.shells(obj), return_counts=True)[1].tolist()}, "
          f"box {v.min(0).round(3).tolist()} {v.max(0).round(3).tolist()}, missed weights {len(missed)}",
          {k: len(i) for k, i in parts.items()}, "core", int((follow >= 0.999).sum()),
          "follow min", {k: float(follow[i].min()) for k, i in parts.items()})
    return obj, twin, parts, follow


class Shot(rig_parts.PartsShot):
    """The shot's parts named as the blob's; a vertex of the cape's top, outside the named parts, "cape-top/body"."""

    def __init__(self, obj, twin, parts, follow, H):
        super().__init__(obj, twin, parts, follow, H, FRAMES, STOP, FPS)
        self.nbody = len(follow) - (850 if "capethick" in OPT else 425)

    def part_of(self, i):
        part = super().part_of(i)
        return "cape-top/body" if part == "body" and i >= self.nbody else part


def main():
    name = install(ZIP, KIND)
    import helpers as H
    H.ADDON = name
    obj, twin, parts, follow = build_scene()
    rig_parts.artist_session(Shot(obj, twin, parts, follow, H), H, OPT, OUT, (1, 12, 24, 36, 44, 60, 72, FRAMES))


rig_parts.reopen(OPT["open"], ZIP, KIND, "Chub") if "open" in OPT else main()
