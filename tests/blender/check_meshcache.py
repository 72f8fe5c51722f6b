"""Opens a .blend baked by the add-on in a Blender where the add-on is NOT enabled (nor on any path) and checks
that the Mesh Cache modifier alone reproduces every baked frame exactly, and holds the last one after the end.

    blender -b --factory-startup --python-exit-code 1 -P check_meshcache.py -- FILE.blend OBJECT
    <python with bpy> check_meshcache.py FILE.blend OBJECT
"""

import struct
import sys

import bpy
import numpy as np

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
blend, name = args[0], args[1]
bpy.ops.wm.open_mainfile(filepath=blend)
assert not any(m.startswith("opdeform") for m in sys.modules), [m for m in sys.modules if "opdeform" in m]
assert not hasattr(bpy.types.Object, "opdeform"), "the add-on is registered"
assert not hasattr(bpy.ops.opdeform, "bake") or "bake" not in dir(bpy.ops.opdeform)

obj = bpy.data.objects[name]
mod = obj.modifiers["OPDeform Cache"]
assert mod.type == 'MESH_CACHE' and mod.cache_format == 'PC2'
path = bpy.path.abspath(mod.filepath)
with open(path, "rb") as f:
    magic, version, n, start, rate, count = struct.unpack("<12siiffi", f.read(32))
    frames = np.frombuffer(f.read(), dtype="<f4").reshape(count, n, 3)
assert magic == b"POINTCACHE2\0" and version == 1 and n == len(obj.data.vertices)


def evaluated():
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", out)
    ev.to_mesh_clear()
    return out.reshape(-1, 3)


scene = bpy.context.scene
first = int(start)
for k in range(count):
    scene.frame_set(first + k)
    got = evaluated()
    assert np.array_equal(got, frames[k]), f"frame {first + k}: max difference {np.abs(got - frames[k]).max()}"
scene.frame_set(first + count + 5)
assert np.array_equal(evaluated(), frames[-1]), "past the end the last baked frame is not held"
moved = float(np.abs(frames[-1] - frames[0]).max())
assert moved > 1e-3, "the baked frames do not move"
print(f"MESHCACHE_OK frames={count} vertices={n} moved={moved:.4f} blender={bpy.app.version_string}")
