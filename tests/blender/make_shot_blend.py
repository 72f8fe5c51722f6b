"""Saves the .blend of the Blender-path shot tests (tests/test_blender_shot.py):

    blender -b --factory-startup -P make_shot_blend.py -- OUT.blend

(the add-on installed in $BLENDER_USER_SCRIPTS, opdeform through $OPDEFORM_PYTHONPATH). Object "Bar":
opdeform.meshes.bar(), pinned at one end face by the vertex group "Pin", oriented particles enabled (20
particles, a chain) sagging under gravity over frames 1-24; a camera and a sun, so that the file renders.
Object "Lamp" is no mesh.
"""

import importlib
import math
import sys

import addon_utils
import bpy
import numpy as np


def main(out):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert addon_utils.enable("opdeform_blender", default_set=True) is not None
    od = importlib.import_module("opdeform_blender.blender.runtime").module()
    v, t = od.meshes.bar()
    mesh = bpy.data.meshes.new("Bar")
    mesh.from_pydata([tuple(map(float, p)) for p in v], [], [tuple(map(int, f)) for f in t])
    obj = bpy.data.objects.new("Bar", mesh)
    scene = bpy.context.scene
    scene.collection.objects.link(obj)
    group = obj.vertex_groups.new(name="Pin")
    group.add([int(i) for i in np.where(v[:, 0] < v[:, 0].min() + 1e-6)[0]], 1.0, 'REPLACE')
    bpy.ops.opdeform.enable(object=obj.name)
    s = obj.opdeform
    s.pin_group, s.particles, s.graph_mode = "Pin", 20, "chain"
    s.stiffness, s.damping, s.frame_start, s.frame_end = 1e6, 0.02, 1, 24
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (1.0, -5.0, 1.0)
    camera.rotation_euler = (math.radians(85), 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'SUN'))
    scene.collection.objects.link(lamp)
    bpy.ops.wm.save_as_mainfile(filepath=out)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1])
