"""Issue 24's jiggle on a rig the add-on was not tuned on: a 1.6 m worm (a tapered tube, 24 sides, 33 rings)
with two loose eyeballs (separate shells of the same object), parented to a 4-bone chain with automatic weights,
keyed to sway side to side (its upper three bones, 15 degrees each, 2 Hz) for 2 s and then stand still to frame 96; a floor with a Collision modifier.
An artist's set-up: Follow Group "follow" painted 1 on the lower half, falling smoothly to 0.1 at the top (the
eyes take the weights of the tube at their height), Goal ticked (the Fleshy look), the panel's other defaults.

Measured against an armature-only twin, as character_measure.py does: the locked part (follow >= 0.99), the top
(the highest fifth of the tube), the eyes, the longest edge over its animated length, the lowest vertex above the
floor, the settle time after the sway, the top's secondary motion during it as a share of the worm's height.
Asserted by suite_character.py's checks (its test_every_check_on_another_rig plays it in both hosts): the locked
part within 1 mm, the loose parts' secondary motion at least 2 % of the height and every vertex within 2 mm one
second after the motion stops, no edge over 1.5x, nothing under the floor, the base mesh kept.
With a directory (and $OPDEFORM_PYTHONPATH, for opdeform.blender_render): the frame where the top lags most in
Cycles, OPDeform with the armature-only pose as a ghost over it, DIR/other_rig_worm.png.

    blender -b --factory-startup --python-exit-code 1 -P tests/blender/other_rig.py -- [--set NAME=VALUE] [--units U] [--y-up] [DIR]
"""

import math
import os
import sys

import bmesh
import bpy
import numpy as np
from mathutils import Matrix

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import character_measure as M  # noqa: E402
import character_scene as C  # noqa: E402
import helpers as H  # noqa: E402

HEIGHT, BONES = 1.6, 4
EYE_VERTICES = 162  # an icosphere of 2 subdivisions


def worm(units, y_up):
    """The tube (radius 0.2 at the foot to 0.1 at the top, capped) and two eyeballs, one mesh object, its
    coordinates in 1/units of a metre (100: centimetres, as an FBX from Maya or Mixamo), standing along +y
    with ``y_up`` (as such an FBX's mesh, its rig turned 90 degrees about x)."""
    bm = bmesh.new()
    bmesh.ops.create_cone(bm, cap_ends=True, segments=24, radius1=0.2, radius2=0.1, depth=HEIGHT)
    bmesh.ops.translate(bm, verts=bm.verts, vec=(0.0, 0.0, HEIGHT / 2))
    sides = [e for e in bm.edges if abs(e.verts[0].co.z - e.verts[1].co.z) > HEIGHT / 2]
    bmesh.ops.subdivide_edges(bm, edges=sides, cuts=31, use_grid_fill=True)
    bmesh.ops.triangulate(bm, faces=bm.faces)
    for side in (-1.0, 1.0):
        eye = bmesh.ops.create_icosphere(bm, subdivisions=2, radius=0.05)
        bmesh.ops.translate(bm, verts=eye["verts"], vec=(0.06 * side, -0.12, HEIGHT - 0.12))
    bmesh.ops.scale(bm, verts=bm.verts, vec=(units, units, units))
    if y_up:
        bmesh.ops.rotate(bm, verts=bm.verts, matrix=Matrix.Rotation(-math.pi / 2, 3, 'X'))
    mesh = bpy.data.meshes.new("Worm")
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new("Worm", mesh)
    bpy.context.scene.collection.objects.link(obj)
    for p in mesh.polygons:
        p.use_smooth = True
    return obj


def rig(obj, scene, units, y_up):
    """The 4-bone chain in the worm's units and axes, the worm parented to it with automatic weights, the
    armature object scaled by 1/units (the world size in metres) and turned upright, the sway keyed."""
    step = units * HEIGHT / BONES
    up = np.array((0.0, 1.0, 0.0) if y_up else (0.0, 0.0, 1.0))
    bones = {f"b{i}": (tuple(i * step * up), tuple((i + 1) * step * up), f"b{i - 1}" if i else None)
             for i in range(BONES)}
    arm = C.armature(scene, bones)
    bpy.ops.object.select_all(action='DESELECT')
    obj.select_set(True)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.parent_set(type='ARMATURE_AUTO')
    arm.scale = (1.0 / units,) * 3
    arm.rotation_euler.x = math.pi / 2 if y_up else 0.0
    for b in arm.pose.bones:
        b.rotation_mode = 'XYZ'
    for frame in range(1, C.MOTION_END + 1, 6):  # four sways a second, 15 degrees a bone, the foot's bone still
        angle = (0.0, 15.0, 0.0, -15.0)[(frame - 1) // 6 % 4]
        for b in arm.pose.bones[1:]:  # about the forward axis: the worm sways side to side
            C.key(b, "rotation_euler", 2, frame, math.radians(angle))
    return arm


def heights(obj):
    """Each vertex's height on the worm at rest, in metres."""
    z = np.array([v.co for v in obj.data.vertices])
    z = z[:, 1] if abs(z[:, 1]).max() > abs(z[:, 2]).max() else z[:, 2]  # the worm stands along y or z
    return z * HEIGHT / z.max()


def follow_weights(obj):
    """1 up to half the height, a smoothstep down to 0.1 at the top."""
    u = np.clip((heights(obj) - HEIGHT / 2) / (HEIGHT / 2), 0.0, 1.0)
    return 1.0 - 0.9 * u * u * (3.0 - 2.0 * u)


class Measure(M.Measure):
    """character_measure's figures with the worm's regions: the top fifth of the tube and the eyes."""

    def parts(self):
        z = heights(self.obj)
        eyes = np.arange(len(z)) >= len(z) - 2 * EYE_VERTICES  # the two icospheres, added last
        regions = {"top": np.where((z > 0.8 * HEIGHT) & ~eyes)[0], "eyes": np.where(eyes)[0]}
        return np.where(follow_weights(self.obj) >= M.CORE_FOLLOW)[0], regions

    def summary(self):
        col, common = self.common()
        return dict(common, top=col["top"].max(), eyes=col["eyes"].max())


def shot(units=1.0, y_up=False, **settings):
    H.fresh()
    scene = bpy.context.scene
    scene.render.fps, scene.frame_start, scene.frame_end = C.FPS, 1, C.FRAMES
    obj = worm(units, y_up)
    rig(obj, scene, units, y_up)
    C.paint(obj, "follow", follow_weights(obj))
    C.floor(scene)
    twin = C.armature_only(obj)
    s = obj.opdeform
    s.use_goal, s.goal_group = True, "follow"
    for name, value in settings.items():
        setattr(s, name, value)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.opdeform.enable(object=obj.name)
    assert s.built and not s.error, s.error
    return Measure(obj, twin)


def render(measure, out):
    """The frame where the top lags most, in Cycles: OPDeform, and the armature-only pose as a ghost over it."""
    sys.path.insert(0, os.environ["OPDEFORM_PYTHONPATH"])
    from opdeform.blender_render import camera, material, setup_render
    scene = measure.obj.users_scene[0]
    frame = measure.frames[int(np.argmax([r["top"] for r in measure.rows]))]
    measure.twin.hide_render = False
    for obj, colour, alpha in ((measure.obj, (0.85, 0.45, 0.3), 1.0), (measure.twin, (0.3, 0.45, 0.9), 0.35)):
        obj.data.materials.clear()
        obj.data.materials.append(material(obj.name, colour, alpha))
    setup_render(scene, resolution=(360, 400), samples=32)
    camera(scene, (0.0, 0.0, 1.05), (0.0, -1.0, 0.15), 2.6)
    scene.frame_set(frame)
    scene.render.filepath = os.path.join(out, "other_rig_worm.png")
    bpy.ops.render.render(write_still=True)
    print(f"render: {scene.render.filepath} (frame {frame})")


def main(argv):
    import argparse
    p = argparse.ArgumentParser()
    p.add_argument("--set", action="append", default=[])
    p.add_argument("--units", type=float, default=1.0, help="the mesh and bones in 1/UNITS m, the rig scaled back")
    p.add_argument("--y-up", action="store_true", help="the mesh and bones along +y, the rig turned upright")
    p.add_argument("out", nargs="?")
    args = p.parse_args(argv)
    settings = {k: M._value(v) for k, v in (s.split("=", 1) for s in args.set)}
    out = args.out
    import suite_character as S
    measure = shot(args.units, args.y_up, **settings)
    s = S.summary(measure)
    print({k: (round(v, 5) if isinstance(v, float) else v) for k, v in s.items()})
    for check in S.CHECKS:
        check(s)
    if out:
        render(measure, out)
    H.cleanup()


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
