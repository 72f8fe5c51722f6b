"""Outside tester 50 (issue 24): a long-legged pony ("Pony", body 1.2 m rump to chest, 1.5 m high at the ears) the
add-on has not seen, galloping and stopping dead. ONE object of several LOOSE PARTS: a Skin-modifier body
(spine, neck, head, four legs; Subdivision 2 applied) with its belly pushed down and jowls pushed out under the
jaw, then joined in as separate shells: two ears (Skin tubes whose roots sink into the head), a tail (a Skin tube
whose root sinks into the rump) and two UV-sphere eyeballs half inside the head. A 10-bone armature (root + 9
deform) with automatic weights; any vertex they miss weighted 1 to the head (ears, eyes) or the tail, as an
artist would. A gallop of 2.4 m/s reached over 8 frames (12-frame strides: bob, pitch, nod, legs in pairs, tail
swinging) over frames 1-40, linear keys, a dead stop at 40, still until 96. Follow: 1 on the core and the eyes,
1 -> 0.15 over the belly, 1 -> 0.2 over the jowls, 1 -> 0.15 out to the ear tips, 1 -> 0.1 out to the tail's tip.
Floor with Collision.
    blender -b --factory-startup --python-exit-code 1 -P scripts/outside_pony.py -- - dev OUT [opts]
    bpy-python scripts/outside_pony.py - dev OUT [opts]    (or ZIP legacy / ZIP extension as scripts/outside_pig.py)
opts: particles=N look=NAME +NAME=VALUE looks bake save scrub open=OUT (as scripts/outside_blob.py); ease=E (frames
to reach the gallop's speed, 8; 0: a standing start at full speed); levels=L (Subdivision, 2); render=F
(Workbench stills of frame F after the first play: OUT/pony_F.png and the armature-only OUT/pony_F_armature.png)
"""
import math, os, sys
import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rig_parts  # noqa: E402
from rig_parts import (armature, collision_floor, gauss, joined, paint, parent_auto, reshaped,  # noqa: E402
                       skin_body, still, taper, twin_of)

OUT, OPT = rig_parts.options()[2:]
FPS, FRAMES, STOP, STRIDE, SPEED = 24, 96, 40, 12, 2.4

NODES = [((0, 0.45, 0.80), 0.17), ((0, 0.15, 0.82), 0.20), ((0, -0.15, 0.82), 0.20), ((0, -0.40, 0.85), 0.19),
         ((0, -0.52, 1.00), 0.13), ((0, -0.60, 1.15), 0.10), ((0, -0.66, 1.28), 0.11), ((0, -0.80, 1.24), 0.09),
         ((0, -0.93, 1.16), 0.065)]
EDGES = [(k, k + 1) for k in range(8)]
LEGS = {"leg.FL": (0.11, -0.36), "leg.FR": (-0.11, -0.36), "leg.HL": (0.11, 0.36), "leg.HR": (-0.11, 0.36)}
for x, y in LEGS.values():
    k = len(NODES)
    NODES += [((x, y, 0.62), 0.08), ((x, y, 0.32), 0.05), ((x, y, 0.04), 0.045)]
    EDGES += [(1 if y > 0 else 3, k), (k, k + 1), (k + 1, k + 2)]
EAR_ROOT, EYE = (0.05, -0.68, 1.27), (0.08, -0.80, 1.22)  # 3 cm into the head's top; half out of its side
TAIL = [((0, 0.50, 0.88), 0.05), ((0, 0.72, 0.76), 0.045), ((0, 0.84, 0.58), 0.035), ((0, 0.88, 0.38), 0.02)]

BONES = [("root", (0, 0, 0), (0, -0.3, 0), None, False),
         ("hips", (0, 0.45, 0.80), (0, 0.0, 0.82), "root", True),
         ("spine", (0, 0.0, 0.82), (0, -0.45, 0.86), "hips", True),
         ("neck", (0, -0.45, 0.86), (0, -0.64, 1.25), "spine", True),
         ("head", (0, -0.64, 1.25), (0, -0.97, 1.15), "neck", True),
         ("tail", (0, 0.55, 0.86), (0, 0.88, 0.38), "hips", True)]
BONES += [(name, (x, y, 0.70), (x, y, 0.03), "spine" if y < 0 else "hips", True) for name, (x, y) in LEGS.items()]


def body_mesh():
    obj = skin_body("Pony", NODES, EDGES, int(OPT.get("levels", 2)))

    def push(v):
        belly = gauss(v, (0, 0, 0.62), (0.16, 0.26, 0.10)) * (np.abs(v[:, 1]) < 0.3) * (v[:, 2] < 0.78)
        jowl = sum(gauss(v, (sx * 0.06, -0.77, 1.14), (0.06, 0.08, 0.06)) for sx in (1, -1))
        v[:, 2] -= 0.08 * belly + 0.03 * jowl
        v[:, 0] += 0.025 * jowl * np.sign(v[:, 0])
        return belly, jowl
    belly, jowl = reshaped(obj, push)
    return obj, belly, jowl


def loose_parts(obj):
    """Ears, tail and eyeballs as separate shells joined into obj (the body's lift to the floor, a few mm, left
    out). Per part its indices, and per vertex of the ears and tail the parameter from root (0) to tip (1)."""
    def tube(name, nodes):
        return skin_body(name, nodes, [(k, k + 1) for k in range(len(nodes) - 1)], 1)
    parts, param = {}, {}
    for side, sx in (("L", 1), ("R", -1)):
        root = (sx * EAR_ROOT[0], EAR_ROOT[1], EAR_ROOT[2])
        tip = (sx * 0.09, -0.66, 1.45)
        parts[f"ear.{side}"] = joined(obj, tube(f"Ear.{side}", [(root, 0.035), (tip, 0.01)]))
    parts["tail"] = joined(obj, tube("Tail", TAIL))
    for side, sx in (("L", 1), ("R", -1)):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=0.03,
                                             location=(sx * EYE[0], EYE[1], EYE[2]))
        bpy.ops.object.transform_apply(location=True)
        parts[f"eye.{side}"] = joined(obj, bpy.context.active_object)
    v = np.array([x.co for x in obj.data.vertices])
    for name in ("ear.L", "ear.R", "tail"):
        ix = parts[name]
        root = np.array(TAIL[0][0] if name == "tail" else (np.sign(v[ix, 0].mean()) * EAR_ROOT[0], *EAR_ROOT[1:]))
        d = np.linalg.norm(v[ix] - root, axis=1)
        param[name] = (d - d.min()) / np.ptp(d)
    return parts, param


def gallop(f):
    """(forward metres, bob metres, stride phase radians) at frame f, still from STOP on."""
    g, e = min(f, STOP) - 1, max(float(OPT.get("ease", 8)), 1e-9)
    moving = f < STOP
    run = g - e / 2 if g >= e else g * g / (2 * e)  # the speed reached over the first e frames
    return SPEED * run / FPS, 0.05 * abs(math.sin(math.pi * g / STRIDE)) * moving, 2 * math.pi * g / STRIDE * moving


def animate(arm):
    pb = rig_parts.linear_pose(arm)
    for f in range(1, STOP + 1):
        forward, bob, ph = gallop(f)
        arm.location = (0, -forward, bob)
        arm.keyframe_insert("location", frame=f)
        pb["spine"].rotation_euler = (0.08 * math.sin(ph), 0, 0)
        pb["neck"].rotation_euler = (0.15 * math.sin(ph + 1.0), 0, 0)
        pb["tail"].rotation_euler = (0.3 * math.sin(ph), 0, 0.25 * math.sin(0.5 * ph))
        for name in LEGS:
            lag = 0.0 if name.startswith("leg.F") else math.pi * 0.8
            pb[name].rotation_euler = (0.6 * math.sin(ph + lag + 0.3 * name.endswith("R")), 0, 0)
        for b in pb:
            b.keyframe_insert("rotation_euler", frame=f)


def weight_leftovers(obj, parts):
    """Vertices automatic weights missed, weighted 1 to the tail (the tail) or the head (the rest), as an artist
    does; how many per part."""
    missed = {}
    for name, ix in parts.items():
        left = [int(i) for i in ix if not any(g.weight > 0 for g in obj.data.vertices[i].groups)]
        if left:
            obj.vertex_groups["tail" if name == "tail" else "head"].add(left, 1.0, 'REPLACE')
        missed[name] = len(left)
    return missed


def build_scene():
    rig_parts.empty_scene(FPS, FRAMES)
    obj, belly, jowl = body_mesh()
    loose, param = loose_parts(obj)
    arm = armature("PonyRig", BONES, lambda b, p: b in ("spine", "neck", "head"))
    parent_auto(obj, arm)
    nb = len(belly)
    body_missed = [x.index for x in obj.data.vertices[:nb] if not any(g.weight > 0 for g in x.groups)]
    if body_missed:
        obj.vertex_groups["spine"].add(body_missed, 1.0, 'REPLACE')
    missed = weight_leftovers(obj, loose)
    animate(arm)
    w = np.ones(len(obj.data.vertices))
    w[:nb] = 1 - np.maximum(0.85 * np.clip(belly, 0, 1), 0.8 * jowl / jowl.max())
    p = np.zeros(len(w))
    for name, t in param.items():
        p[loose[name]] = t
    follow = taper(w, loose, p, (("ear.L", 0.15), ("ear.R", 0.15), ("tail", 0.1)))
    paint(obj, "Follow", follow)
    collision_floor()
    twin = twin_of(obj)
    body = np.arange(nb)
    parts = dict(belly=body[belly >= 0.3], jowls=body[jowl >= 0.3],
                 ears=np.concatenate([loose[k][p[loose[k]] >= 0.5] for k in ("ear.L", "ear.R")]),
                 tail=loose["tail"][p[loose["tail"]] >= 0.5], eyes=np.concatenate([loose["eye.L"], loose["eye.R"]]))
    v = np.array([x.co for x in obj.data.vertices])
    print(f"PONY {len(v)} vertices, {len(obj.data.polygons)} faces, shells "
          f"{np.unique(rig_parts.shells(obj), return_counts=True)[1].tolist()}, box {v.min(0).round(3).tolist()} "
          f"{v.max(0).round(3).tolist()}, missed weights body {len(body_missed)} parts {missed}",
          {k: len(i) for k, i in parts.items()}, "core", int((follow >= 0.999).sum()),
          "follow min", {k: float(follow[i].min()) for k, i in parts.items()})
    return obj, twin, parts, follow


def stills(shot):
    f = int(OPT["render"])
    y = -gallop(f)[0]
    view = dict(frame=f, eye=(2.4, y - 1.6, 1.3), target=(0, y - 0.2, 0.8))
    still(os.path.join(OUT, f"pony_{f}.png"), hidden=(shot.twin,), **view)
    still(os.path.join(OUT, f"pony_{f}_armature.png"), hidden=(shot.obj,), **view)


def shot_of(H):
    return rig_parts.PartsShot(*build_scene(), H, FRAMES, STOP, FPS)


rig_parts.run_shot("Pony", shot_of, (1, 12, 24, 36, 44, 60, 72, FRAMES), stills if "render" in OPT else None)
