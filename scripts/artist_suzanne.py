"""New-user check (issue 24): Blender's Suzanne subdivided twice on a two-bone armature with automatic weights, a
Follow group painted 1 at the chin and on a core column falling to 0.1 at the top, swayed 0.6 m and 0.4 rad over
frames 1-24; a second object of three loose cubes; a Collision floor. Installed from a zip (or `-` dev with
OPDEFORM_PYTHONPATH), Enable both, tick Goal, pick the group (the artist's order), play 72 frames, render frame 12
with Cycles and its armature-only twin.

    blender -b --factory-startup --python-exit-code 1 -P scripts/artist_suzanne.py -- ZIP|- legacy|extension|dev OUT

Prints FRAME lines (the soft part's largest distance from the armature-only pose, the mesh edges' largest stretch
and squash against their animated length) and one CHECK line (core and loose mm over the clip and at frame 12, at
frame 72, the cubes' lowest point, base meshes kept, errors).
"""
import os
import sys
import bpy, numpy as np
from mathutils import Vector
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rig_parts import install, parent_auto, paint, world, base, link  # noqa: E402
args = sys.argv[sys.argv.index("--") + 1:]
ZIP, KIND, OUT = args[:3]
os.makedirs(OUT, exist_ok=True)
bpy.ops.wm.read_factory_settings(use_empty=True)
mod = install(ZIP, KIND)
sc = bpy.context.scene
sc.frame_start, sc.frame_end = 1, 72
bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(0, 0, 1.3))
monkey = bpy.context.active_object
sub = monkey.modifiers.new("Sub", 'SUBSURF'); sub.levels = 2
bpy.ops.object.modifier_apply(modifier="Sub")
bpy.ops.object.armature_add(location=(0, 0, 0.2))
arm = bpy.context.active_object
bpy.ops.object.mode_set(mode='EDIT')
b = arm.data.edit_bones[0]; b.head, b.tail = Vector((0, 0, 0)), Vector((0, 0, 1.2))
h = arm.data.edit_bones.new("Head"); h.head, h.tail, h.parent = Vector((0, 0, 1.2)), Vector((0, 0, 2.4)), b
bpy.ops.object.mode_set(mode='OBJECT')
parent_auto(monkey, arm)
v0 = base(monkey).reshape(-1, 3).copy()
z = v0[:, 2]
follow = np.clip(1.0 - (z - z.min()) / (z.max() - z.min()) * 1.4, 0.1, 1.0)  # 1 at the chin, 0.1 at the top
dist = np.linalg.norm(v0[:, :2], axis=1)
follow = np.where(dist < 0.35, 1.0, follow)  # the core
paint(monkey, "Follow", np.round(follow, 2))
pb = arm.pose.bones["Bone"]
for f, (x, rz) in {1: (0, 0), 8: (0.6, 0.4), 16: (-0.4, -0.4), 24: (0, 0)}.items():
    pb.location = (x, 0, 0); pb.rotation_mode = 'XYZ'; pb.rotation_euler = (0, 0, rz)
    pb.keyframe_insert("location", frame=f); pb.keyframe_insert("rotation_euler", frame=f)
# the second object: three loose cubes
bm_objs = []
for i in range(3):
    bpy.ops.mesh.primitive_cube_add(size=0.3, location=(2.0 + 0.5 * i, 0, 1.0 + 0.4 * i))
    bm_objs.append(bpy.context.active_object)
bpy.ops.object.select_all(action='DESELECT')
for o in bm_objs: o.select_set(True)
bpy.context.view_layer.objects.active = bm_objs[0]
bpy.ops.object.join()
cubes = bpy.context.active_object; cubes.name = "Cubes"
bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, 0))
floor = bpy.context.active_object
floor.modifiers.new("Collision", 'COLLISION')
cube_base = base(cubes).copy(); monkey_base = base(monkey).copy()
for o in (monkey, cubes):
    bpy.ops.object.select_all(action='DESELECT'); o.select_set(True); bpy.context.view_layer.objects.active = o
    bpy.ops.opdeform.enable(object=o.name)
monkey.opdeform.use_goal = True
monkey.opdeform.goal_group = "Follow"
# the armature-only twin for the core
twin = monkey.copy(); twin.data = monkey.data.copy(); link(twin)
for m in list(twin.modifiers):
    if m.type != 'ARMATURE': twin.modifiers.remove(m)
twin.hide_render = True
core = follow >= 0.999
worst_core = worst_top = 0.0
ei = np.array([e.vertices[:] for e in monkey.data.edges]).T
for f in range(1, 73):
    sc.frame_set(f)
    d = np.linalg.norm(world(monkey) - world(twin), axis=1)
    worst_core = max(worst_core, d[core].max()); worst_top = max(worst_top, d[~core].max())
    a, b = world(monkey), world(twin)
    st = np.linalg.norm(a[ei[0]] - a[ei[1]], axis=1) / np.linalg.norm(b[ei[0]] - b[ei[1]], axis=1)
    print("FRAME", f, "top mm", round(1e3 * d[~core].max(), 1), "stretch", round(st.max(), 3),
          "squash", round(st.min(), 3))
    if f == 12:
        core12, top12 = d[core].max(), d[~core].max()
at72 = 1e3 * np.linalg.norm(world(monkey) - world(twin), axis=1).max()  # the last frame played
cubes_lowest = 1e3 * world(cubes)[:, 2].min()
print("CHECK", KIND, dict(core_mm=1e3 * worst_core, loose_mm=1e3 * worst_top, core12=1e3 * core12, top12=1e3 * top12,
      at72=at72, cubes_lowest_mm=cubes_lowest,
      monkey_base_kept=bool(np.array_equal(base(monkey), monkey_base)),
      cubes_base_kept=bool(np.array_equal(base(cubes), cube_base)), errors=[o.opdeform.error for o in (monkey, cubes)]))
sc.frame_set(12)
bpy.ops.object.camera_add(location=(0.8, -7.5, 2.0), rotation=(1.45, 0, 0.1)); sc.camera = bpy.context.active_object
bpy.ops.object.light_add(type='SUN', location=(0, 0, 5)); bpy.context.active_object.data.energy = 4
sc.render.engine = 'CYCLES'; sc.cycles.samples = 8; sc.cycles.use_denoising = False
sc.render.resolution_x, sc.render.resolution_y = 480, 320
sc.render.filepath = os.path.join(OUT, "frame12.png"); bpy.ops.render.render(write_still=True)
monkey.hide_render = True; twin.hide_render = False
sc.render.filepath = os.path.join(OUT, "frame12_armature.png"); bpy.ops.render.render(write_still=True)
