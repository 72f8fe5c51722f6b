"""Regenerates tests/reference/suzanne_subdivided.npz: Blender's Suzanne (``primitive_monkey_add``) with a
Subdivision modifier of 2 levels applied, triangulated; a head and two separate eyeballs (the loose-parts
check of tests/test_loose_parts.py, issue 12).

    ~/.cache/opdeform/bpy-venv/bin/python tests/blender/make_suzanne.py   # the bpy module (scripts/setup-bpy), or
    blender -b --factory-startup -P tests/blender/make_suzanne.py

Blender's user folders are pointed at a temporary folder, so no preference or add-on of the machine enters.
Vertices are stored as float32 (Blender's own precision), triangles as int32, compressed (about 130 kB).
"""

import os
import sys
import tempfile

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reference", "suzanne_subdivided.npz")


def main():
    user = tempfile.mkdtemp(prefix="opdeform-suzanne-")
    os.environ.setdefault("BLENDER_USER_CONFIG", user)
    os.environ.setdefault("BLENDER_USER_SCRIPTS", user)
    import bpy
    import numpy as np

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add()
    obj = bpy.context.active_object
    mod = obj.modifiers.new("subdivision", "SUBSURF")
    mod.levels = mod.render_levels = 2
    bpy.ops.object.modifier_apply(modifier=mod.name)
    mesh = obj.data
    mesh.calc_loop_triangles()
    vertices = np.empty(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertices.foreach_get("co", vertices)
    triangles = np.empty(3 * len(mesh.loop_triangles), dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    vertices, triangles = vertices.reshape(-1, 3), triangles.reshape(-1, 3)
    np.savez_compressed(os.path.abspath(OUT), vertices=vertices, triangles=triangles)
    print(f"wrote {os.path.abspath(OUT)}: {len(vertices)} vertices, {len(triangles)} triangles", file=sys.stderr)


if __name__ == "__main__":
    main()
