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
- the offset read by the modifier from another object's points (Object Info), that object written.

Each written variant writes a new offset every frame. Whatever is written, Blender evaluates the character
again after the handler: the Armature and the modifiers, not only what changed.
"""

import os
import statistics
import sys
import time

REPEATS = 4
FRAMES = 96


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


def _variants(C, H):
    """{label: (scene, object, write(obj, depsgraph, offset) or None)}."""
    import importlib
    import numpy as np
    modifier = importlib.import_module(H.ADDON + ".blender.modifier")
    H.fresh()
    base = C.build()
    out = {}

    def add(label, setup=None, write=None):
        scene, obj = C.variant_scene(label, base)
        extra = setup(obj, scene) if setup else None
        out[label] = (scene, obj, None if write is None else (lambda o, dg, off: write(o, dg, off, extra)))

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
    add("another object's points written", lambda o, s: _offset_object(o, s, modifier), holder)
    return out


def inside():
    import bpy
    import numpy as np
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    sys.path.insert(0, os.path.join(root, "tests", "blender"))
    import character_scene as C
    import helpers as H
    variants = _variants(C, H)
    by_scene = {scene.name: (obj, write) for scene, obj, write in variants.values()}
    count = len(bpy.data.objects["Character"].data.vertices)

    def handler(scene, depsgraph=None):
        obj, write = by_scene.get(scene.name, (None, None))
        if write is not None:
            write(obj, depsgraph, np.full((count, 3), 1e-6 * scene.frame_current, np.float32))
    bpy.app.handlers.frame_change_post.append(handler)
    times = {label: [] for label in variants}
    for _ in range(REPEATS):
        for f in range(1, FRAMES + 1):
            for label, (scene, obj, write) in variants.items():
                t = time.process_time()
                scene.frame_set(f)
                if f > 1:
                    times[label].append(time.process_time() - t)
    plain = statistics.median(times["armature only"])
    print(f"{H.host()}: process time of frame_set, median of {REPEATS} x frames 2..{FRAMES}, interleaved")
    for label, t in times.items():
        ms = 1e3 * statistics.median(t)
        print(f"  {label:36s} {ms:6.2f} ms  (+{ms - 1e3 * plain:.2f} over the armature only)")
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
