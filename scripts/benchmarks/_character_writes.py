"""What Blender itself takes when a frame handler changes what the rigged character shows, by the way it is
written (issue 24, aim A): `scripts/bench character --writes` runs this inside Debian's Blender 3.4 and the bpy
module 5.2, one core each as `scripts/bench character` runs them. Every variant is a copy of the armature-only
character (tests/blender/character_scene.py, 5,752 vertices) in a scene of its own; all play interleaved, REPEATS
times over frames 1..96; process time of `scene.frame_set`, median of frames 2..96:

- armature only;
- OPDeform's modifier and its offset attribute, the input read by a frame handler, the offset not written (what
  OPDeform costs Blender in a frame whose offset is the one the mesh holds);
- the offset attribute written and the mesh tagged (what OPDeform does);
- a shape key written instead (before the Armature: not OPDeform's order, for its cost alone);
- the offset read by the modifier from another object's points (Object Info), that object written;
- the offset read by the modifier from a float image of ours (Image Texture, closest texel by index), its pixels
  written (no mesh copied, only the object evaluated again);
- the object tagged, nothing written (its modifiers run again, the mesh not copied);
- without any modifier, untagged and tagged (what any evaluation of this mesh costs: 3.4 computes its normals);
- in frame_change_pre, before Blender's one evaluation of the frame: the offset attribute written; another
  object's points written; and the goal ahead (the rig evaluated alone in a scene of its own at the new frame,
  its deform bones skinned as the Armature does, in numpy: ``GoalAhead``) with the attribute written; its pieces
  are timed in place and its input compared with the one Blender's Armature gives in that evaluation.

Each written variant writes a new offset every frame. Whatever frame_change_post writes, Blender evaluates
the character again after the handler: the Armature and the modifiers, not only what changed.
"""

import os
import statistics
import sys
import time

REPEATS = 4
FRAMES = 96
AHEAD = "in frame_change_pre: goal ahead, attribute written"


def _offset_object(obj, scene, modifier):
    """A point cloud mesh of obj's vertex count in scene, and a modifier on obj that adds its points' positions
    (Sample Index by index) to obj's own."""
    import bpy
    mesh = bpy.data.meshes.new(obj.name + " offsets")
    mesh.vertices.add(len(obj.data.vertices))
    holder = bpy.data.objects.new(mesh.name, mesh)
    scene.collection.objects.link(holder)
    group = bpy.data.node_groups.new("offset from " + obj.name, 'GeometryNodeTree')
    modifier._socket(group, "Geometry", 'INPUT')
    modifier._socket(group, "Geometry", 'OUTPUT')
    nodes, links = group.nodes, group.links
    info, sample, move = (nodes.new(kind) for kind in ('GeometryNodeObjectInfo', 'GeometryNodeSampleIndex',
                                                        'GeometryNodeSetPosition'))
    info.inputs["Object"].default_value = holder
    sample.data_type, sample.domain = 'FLOAT_VECTOR', 'POINT'
    links.new(info.outputs["Geometry"], sample.inputs["Geometry"])
    links.new(nodes.new('GeometryNodeInputPosition').outputs[0], modifier._value(sample.inputs))
    links.new(nodes.new('GeometryNodeInputIndex').outputs[0], sample.inputs["Index"])
    links.new(nodes.new('NodeGroupInput').outputs[0], move.inputs["Geometry"])
    links.new(modifier._value(sample.outputs), move.inputs["Offset"])
    links.new(move.outputs[0], nodes.new('NodeGroupOutput').inputs[0])
    obj.modifiers.new("offset from points", 'NODES').node_group = group
    return holder


def _offset_image(obj, modifier):
    """A float image of obj's vertex count (one row, non-colour) and a modifier on obj that adds each vertex's
    texel (Image Texture, closest, by index) to its position; returns the image."""
    import bpy
    n = len(obj.data.vertices)
    image = bpy.data.images.new(obj.name + " offsets", n, 1, alpha=True, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    group = bpy.data.node_groups.new("offset image " + obj.name, 'GeometryNodeTree')
    modifier._socket(group, "Geometry", 'INPUT')
    modifier._socket(group, "Geometry", 'OUTPUT')
    nodes, links = group.nodes, group.links
    texture, move = nodes.new('GeometryNodeImageTexture'), nodes.new('GeometryNodeSetPosition')
    texture.interpolation, texture.extension = 'Closest', 'EXTEND'
    texture.inputs["Image"].default_value = image
    add, scale, combine = nodes.new('ShaderNodeMath'), nodes.new('ShaderNodeMath'), nodes.new('ShaderNodeCombineXYZ')
    add.operation, scale.operation = 'ADD', 'DIVIDE'
    links.new(nodes.new('GeometryNodeInputIndex').outputs[0], add.inputs[0])
    add.inputs[1].default_value = 0.5
    links.new(add.outputs[0], scale.inputs[0])
    scale.inputs[1].default_value = float(n)
    links.new(scale.outputs[0], combine.inputs[0])
    combine.inputs[1].default_value = 0.5
    links.new(combine.outputs[0], texture.inputs["Vector"])
    links.new(nodes.new('NodeGroupInput').outputs[0], move.inputs["Geometry"])
    links.new(texture.outputs[0], move.inputs["Offset"])
    links.new(move.outputs[0], nodes.new('NodeGroupOutput').inputs[0])
    obj.modifiers.new("offset from image", 'NODES').node_group = group
    return image


class GoalAhead:
    """What the Armature will give the modifier at a frame not yet evaluated: the rig alone evaluated in a
    scene of its own at that frame, linear blend skinning of the deform bones (weights normalised per vertex,
    unweighted vertices kept) by blended matrices, float32. For a mesh parented to its rig with one Armature
    before OPDeform: no shape keys, no Preserve Volume, no B-Bones."""

    def __init__(self, obj):
        import bpy
        import numpy as np
        self.obj, self.rig = obj, obj.parent
        self.scene = bpy.data.scenes.new("goal ahead of " + obj.name)
        self.scene.collection.objects.link(self.rig)
        self.bones = [b for b in self.rig.data.bones if b.use_deform]
        weights = np.zeros((len(obj.data.vertices), len(self.bones)), np.float32)
        index = {obj.vertex_groups[b.name].index: j for j, b in enumerate(self.bones) if b.name in obj.vertex_groups}
        for v in obj.data.vertices:
            for g in v.groups:
                if g.group in index:
                    weights[v.index, index[g.group]] = g.weight
        total = weights.sum(1, keepdims=True)
        self.weights = weights / np.maximum(total, 1e-30)
        self.unweighted = np.flatnonzero(total[:, 0] <= 1e-4)
        rest = np.empty(len(obj.data.vertices) * 3, np.float32)
        obj.data.vertices.foreach_get("co", rest)
        self.rest = rest.reshape(-1, 3)
        self.rest_inverse = np.stack([np.array(b.matrix_local.inverted()) for b in self.bones])
        self.timing = {"the rig alone at the frame": [], "skinned": []}

    def at(self, frame):
        """Object-space positions (V, 3) float32 at frame; its pieces' process time in self.timing."""
        import numpy as np
        t0 = time.process_time()
        self.scene.frame_set(frame)
        rig = self.rig.evaluated_get(self.scene.view_layers[0].depsgraph)
        pose = np.stack([np.array(rig.pose.bones[b.name].matrix) for b in self.bones])
        rig_world = np.array(rig.matrix_world)
        t1 = time.process_time()
        out = self._skin(pose, rig_world)
        self.timing["skinned"].append(time.process_time() - t1)
        self.timing["the rig alone at the frame"].append(t1 - t0)
        return out

    def _skin(self, pose, rig_world):
        """The rest mesh deformed by the pose (the deform bones' matrices in the rig's space) as the Armature
        modifier does it, in the rig's space, then back in the object's."""
        import numpy as np
        world = rig_world @ np.array(self.obj.matrix_parent_inverse) @ np.array(self.obj.matrix_basis)
        to_rig = (np.linalg.inv(rig_world) @ world).astype(np.float32)
        at_rig = self.rest @ to_rig[:3, :3].T + to_rig[:3, 3]
        blended = self.weights @ (pose @ self.rest_inverse)[:, :3].reshape(len(self.bones), 12).astype(np.float32)
        out = np.empty_like(at_rig)
        for i in range(3):
            row = blended[:, 4 * i + 3].copy()
            for k in range(3):
                row += blended[:, 4 * i + k] * at_rig[:, k]
            out[:, i] = row
        out[self.unweighted] = at_rig[self.unweighted]
        back = np.linalg.inv(to_rig)
        return out @ back[:3, :3].T + back[:3, 3]


def _variants(C, H):
    """({label: (scene, object, write(obj, depsgraph, offset) or None, "pre" or "post")}, {"goal": the
    GoalAhead of the AHEAD variant; "frame", "predicted": the frame it is asked for and its answer})."""
    import importlib
    import numpy as np
    modifier = importlib.import_module(H.ADDON + ".blender.modifier")
    H.fresh()
    base = C.build()
    out = {}

    def add(label, setup=None, write=None, when="post"):
        scene, obj = C.variant_scene(label, base)
        extra = setup(obj, scene) if setup else None
        out[label] = (scene, obj, None if write is None else (lambda o, dg, off: write(o, dg, off, extra)), when)

    def read(obj, depsgraph):
        modifier.read_input(obj.evaluated_get(depsgraph).data, len(obj.data.vertices))

    def attribute(obj, depsgraph, offset, _):
        read(obj, depsgraph)
        modifier.write_offset(obj.data, offset)

    def shape_key(obj, depsgraph, offset, basis):
        obj.data.shape_keys.key_blocks["offset"].data.foreach_set("co", (basis + offset).ravel())
        obj.data.update()

    def holder(obj, depsgraph, offset, points):
        points.data.vertices.foreach_set("co", offset.ravel())
        points.data.update()

    def with_offset(obj, scene):
        modifier.ensure(obj)
        modifier.write_offset(obj.data, np.zeros((len(obj.data.vertices), 3), np.float32))

    def keyed(obj, scene):
        obj.shape_key_add(name="Basis")
        obj.shape_key_add(name="offset").value = 1.0
        return np.array([v.co for v in obj.data.vertices], np.float32)

    add("armature only")
    add("offset not written, input read", with_offset, lambda o, dg, off, _: read(o, dg))
    add("attribute written (OPDeform)", with_offset, attribute)
    add("shape key written", keyed, shape_key)

    def pixels(obj, depsgraph, offset, image):
        rgba = np.ones((len(offset), 4), np.float32)
        rgba[:, :3] = offset
        image.pixels.foreach_set(rgba.ravel())
        image.update_tag()
    add("the offset in an image sampled by the modifier, written", lambda o, s: _offset_image(o, modifier), pixels)
    add("another object's points written", lambda o, s: _offset_object(o, s, modifier), holder)
    add("object tagged, nothing written", None, lambda o, dg, off, _: o.update_tag())

    def bare(obj, scene):
        obj.modifiers.clear()
    add("no modifier", bare)
    add("no modifier, mesh tagged", bare, lambda o, dg, off, _: o.data.update())
    pre = "in frame_change_pre: "
    add(pre + "attribute written", with_offset, lambda o, dg, off, _: modifier.write_offset(o.data, off), "pre")
    add(pre + "another object's points written", lambda o, s: _offset_object(o, s, modifier), holder, "pre")
    ahead = {}

    def goal_ahead(obj, scene):
        with_offset(obj, scene)
        ahead["goal"] = GoalAhead(obj)

    def predicted(obj, depsgraph, offset, _):
        ahead["predicted"] = ahead["goal"].at(ahead["frame"])
        modifier.write_offset(obj.data, offset)
    add(AHEAD, goal_ahead, predicted, "pre")
    return out, ahead


def inside():
    import bpy
    import numpy as np
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    sys.path.insert(0, os.path.join(root, "tests", "blender"))
    import character_scene as C
    import helpers as H
    import importlib
    modifier = importlib.import_module(H.ADDON + ".blender.modifier")
    variants, ahead = _variants(C, H)
    by_scene = {scene.name: (obj, write, when) for scene, obj, write, when in variants.values()}
    count = len(bpy.data.objects["Character"].data.vertices)
    ahead_scene = variants[AHEAD][0]
    differences = []

    def handler(when, scene, depsgraph=None):
        obj, write, at = by_scene.get(scene.name, (None, None, None))
        if write is not None and at == when:
            ahead["frame"] = scene.frame_current
            write(obj, depsgraph, np.full((count, 3), 1e-6 * scene.frame_current, np.float32))
        if when == "post" and scene == ahead_scene:  # the input Blender's Armature gave, against the goal ahead
            given = modifier.read_input(obj.evaluated_get(depsgraph).data, count)[0]
            differences.append(float(np.abs(given - ahead.pop("predicted")).max()))
    bpy.app.handlers.frame_change_pre.append(lambda scene, depsgraph=None: handler("pre", scene, depsgraph))
    bpy.app.handlers.frame_change_post.append(lambda scene, depsgraph=None: handler("post", scene, depsgraph))
    times = {label: [] for label in variants}
    for _ in range(REPEATS):
        for f in range(1, FRAMES + 1):
            for label, (scene, obj, write, when) in variants.items():
                t = time.process_time()
                scene.frame_set(f)
                if f > 1:
                    times[label].append(time.process_time() - t)
    plain = statistics.median(times["armature only"])
    print(f"{H.host()}: process time of frame_set, median of {REPEATS} x frames 2..{FRAMES}, interleaved")
    for label, t in times.items():
        ms = 1e3 * statistics.median(t)
        print(f"  {label:56s} {ms:6.2f} ms  (+{ms - 1e3 * plain:.2f} over the armature only)")
    for piece, t in ahead["goal"].timing.items():
        print(f"  goal ahead, {piece}: {1e3 * statistics.median(t):.3f} ms")
    print(f"  goal ahead against Blender's Armature: largest difference {max(differences):.2g} m over "
          f"{len(differences)} frames")
    print("WRITES_DONE")


def run(args):
    """The variants in both hosts (or --hosts), one after the other."""
    import subprocess
    from . import character
    hosts = args[args.index("--hosts") + 1].split(",") if "--hosts" in args else ["blender", "bpy-5.2"]
    for name, cmd in character._hosts(hosts):
        if cmd is None:
            print(f"{name}: not installed (scripts/setup-bpy)")
            continue
        cmd = [os.path.abspath(__file__) if c == character.HERE else c for c in cmd]
        proc = subprocess.run(cmd + ["--inside"], capture_output=True, text=True, env=character._env(),
                              timeout=1800, preexec_fn=character._limit)
        lines = proc.stdout.splitlines()
        ok = "WRITES_DONE" in lines
        print("\n".join(line for line in lines if line.startswith(("  ", "blender", "bpy"))) if ok else
              f"{name} failed\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} ({os.cpu_count()} cores)")


if __name__ == "__main__" and "--inside" in sys.argv:
    inside()
