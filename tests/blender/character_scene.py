"""The rigged, hopping character of issue 24, built in code the same way in Debian's Blender 3.4 and in the bpy
module (5.2): the scene that the character suite (suite_character.py), its measurement
(character_measure.py), `scripts/bench character` and the frame strip (render_character.py) share.

- Mesh: opdeform.meshes.character(), one closed shell 2.43 m tall, 5,752 vertices (body, forward belly, head,
  two 0.5 m ears, a 0.75 m tail, two feet), standing on z = 0 and facing -y, with smooth shading.
- Rig "Rig": six bones, root (legs and feet) > body (belly included) > head > ear.L, ear.R, and body > tail;
  the mesh is parented to it with Blender's automatic weights (bone heat). Bone heat runs headless in both
  hosts and gave bit-identical weights in 3.4.1 and 5.2.3 and from run to run (measured: md5 of the 5,752 x 6
  weights equal), and it is what an artist does (Ctrl+P > With Automatic Weights), so no weights of our own.
- Animation: two hops of 24 frames (the root rises 0.6 m and moves 0.5 m forward each time; the contact
  keys have vector handles, so the landings are sharp), the body leaning forward and the head back in the
  air, then everything stands still from frame MOTION_END to the end (frame 96, 24 fps). The ears and the
  tail have no keys of their own: whatever they do beyond their parents' motion is secondary motion.
- Vertex groups: "follow" 1 on the core, falling to 0.15 at the belly front, 0.1 at the ear tips and 0.15
  at the tail tip; "softness" 1 where follow is lowest, 0 on the core; "region_ear_tips",
  "region_belly_front", "region_tail_tip" (weight 1) name the vertices that the measurement reports.
- Floor "Floor": an 8 m grid at z = 0 with a Collision modifier (Blender's default settings).
- OPDeform (``enable``) goes after the Armature, with Goal on, the "follow" group and the "softness" group
  picked.

For comparisons, each in a scene of its own sharing the rig and the floor (``variant_scene``): Blender's Soft
Body after the Armature with its goal from "follow" (``soft_body``), and in Blender 5.x the bundled Cloth
Dynamics node group (``cloth_dynamics``, from the essentials' geometry_nodes_dynamics_assets.blend; absent in
3.4) pinned by "follow". Blender simulates Soft Body and simulation zones only in the window's scene.
"""

import math
import os

import bpy
import numpy as np

import helpers as H

FPS = 24
HOP = 24  # frames per hop
MOTION_END = 1 + 2 * HOP  # the first frame of standing still
FRAMES = 96
HOP_HEIGHT, HOP_FORWARD = 0.6, 0.5
FOLLOW_FLOOR = {"ear": 0.1, "belly": 0.15, "tail": 0.15}  # follow at the tips of the loose parts
REGIONS = ("ear_tips", "belly_front", "tail_tip")
CLOTH_DYNAMICS = "Cloth Dynamics (Experimental)"


def _bones(parts):
    """name -> (head, tail, parent) of the rig in rest pose (metres)."""
    return {
        "root": ((0.0, 0.05, 0.0), (0.0, 0.05, 0.4), None),
        "body": ((0.0, 0.05, 0.4), (0.0, 0.03, 1.45), "root"),
        "head": ((0.0, 0.03, 1.45), (0.0, -0.02, 1.9), "body"),
        "ear.L": (parts["ear.L"][0], parts["ear.L"][1], "head"),
        "ear.R": (parts["ear.R"][0], parts["ear.R"][1], "head"),
        "tail": (parts["tail"][0], parts["tail"][1], "body"),
    }


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _along(points, head, tail):
    """Where each point projects on the segment head..tail: 0 at the head, 1 at the tail (clipped)."""
    head, tail = np.asarray(head, float), np.asarray(tail, float)
    axis = tail - head
    return np.clip((points - head) @ axis / (axis @ axis), 0.0, 1.0)


def looseness(points, bones, skin):
    """Per loose part (ear, belly, tail) how loose each point is, 0 on the core to 1 at the part's tip:
    along the ear and tail bones (from a tenth and a quarter of their length on, times the bone's skin
    weight), and for the belly its reach forward (-y) in a band about the belly's height."""
    ears = np.maximum(*(_smoothstep((_along(points, *bones[e][:2]) - 0.1) / 0.9) * skin[e]
                        for e in ("ear.L", "ear.R")))
    tail = _smoothstep((_along(points, *bones["tail"][:2]) - 0.25) / 0.75) * skin["tail"]
    band = _smoothstep((0.45 - np.abs(points[:, 2] - 0.79)) / 0.25)
    front = -points[:, 1].min()
    belly = _smoothstep((-points[:, 1] - 0.3) / (front - 0.3)) * band
    return {"ear": ears, "belly": belly, "tail": tail}


def maps(points, bones, skin):
    """(follow, softness, regions): the painted maps and the measured regions' vertex indices."""
    loose = looseness(points, bones, skin)
    follow = 1.0 - np.max([(1.0 - FOLLOW_FLOOR[k]) * r for k, r in loose.items()], axis=0)
    softness = np.max(list(loose.values()), axis=0)
    regions = {"ear_tips": np.where(loose["ear"] > 0.95)[0], "belly_front": np.where(loose["belly"] > 0.95)[0],
               "tail_tip": np.where(loose["tail"] > 0.95)[0]}
    return follow, softness, regions


def armature(scene, bones):
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode='EDIT')
    for name, (head, tail, parent) in bones.items():
        bone = rig.data.edit_bones.new(name)
        bone.head, bone.tail = head, tail
        if parent is not None:
            bone.parent = rig.data.edit_bones[parent]
    bpy.ops.object.mode_set(mode='OBJECT')
    return rig


def key(bone, path, index, frame, value):
    getattr(bone, path)[index] = value
    bone.keyframe_insert(path, index=index, frame=frame)


def _animate(rig):
    """Two hops, then still: root height and forward travel, body lean forward, head back."""
    pose = rig.pose.bones
    for b in pose:
        b.rotation_mode = 'XYZ'
    for hop in range(2):
        start = 1 + hop * HOP
        for frame, height, lean in ((start, 0.0, 0.0), (start + HOP // 2, HOP_HEIGHT, 12.0), (start + HOP, 0.0, 0.0)):
            # the bones point up: a bone's y is world z, its z is world -y (forward), its x is world x
            key(pose["root"], "location", 1, frame, height)
            key(pose["root"], "location", 2, frame, HOP_FORWARD * (frame - 1) / HOP)
            key(pose["body"], "rotation_euler", 0, frame, math.radians(lean))
            key(pose["head"], "rotation_euler", 0, frame, math.radians(-lean))
    for fc in H.action_fcurves(rig.animation_data.action):
        for k in fc.keyframe_points:
            if fc.data_path.endswith("location") and fc.array_index == 2:
                k.interpolation = 'LINEAR'  # forward travel stops dead at the landing
            elif fc.data_path.endswith("location") and k.co[1] == 0.0:
                k.handle_left_type = k.handle_right_type = 'VECTOR'  # ground contact: a hop's sharp turn
        fc.update()


def paint(obj, name, weights):
    group = obj.vertex_groups.new(name=name)
    for value in np.unique(weights):
        group.add([int(i) for i in np.where(weights == value)[0]], float(value), 'REPLACE')


def skin_weights(obj, names):
    """name -> weight per vertex of the vertex groups named (0 outside a group)."""
    out = {name: np.zeros(len(obj.data.vertices)) for name in names}
    index = {obj.vertex_groups[n].index: n for n in names}
    for v in obj.data.vertices:
        for g in v.groups:
            if g.group in index:
                out[index[g.group]][v.index] = g.weight
    return out


def floor(scene):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=8, y_subdivisions=8, size=8.0)
    obj = bpy.context.active_object
    obj.name = "Floor"
    obj.modifiers.new("Collision", 'COLLISION')
    return H.move_to(obj, scene)


def build(scene=None):
    """The character, its rig (keyed) and the floor in ``scene`` (the context's by default), frames 1..96 at
    24 fps, OPDeform not yet enabled. Returns the character object."""
    from opdeform import meshes
    scene = scene or bpy.context.scene
    scene.render.fps, scene.frame_start, scene.frame_end = FPS, 1, FRAMES
    vertices, triangles = meshes.character()
    obj = H.mesh_object("Character", vertices, triangles)
    H.move_to(obj, scene)
    for p in obj.data.polygons:
        p.use_smooth = True
    bones = _bones(meshes.CHARACTER_PARTS)
    rig = armature(scene, bones)
    bpy.ops.object.select_all(action='DESELECT')
    obj.select_set(True)
    rig.select_set(True)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.parent_set(type='ARMATURE_AUTO')
    follow, softness, regions = maps(vertices, bones, skin_weights(obj, bones))
    paint(obj, "follow", follow)
    paint(obj, "softness", softness)
    for name, index in regions.items():
        assert len(index), f"the character has no {name} vertices"
        obj.vertex_groups.new(name="region_" + name).add([int(i) for i in index], 1.0, 'REPLACE')
    _animate(rig)
    floor(scene)
    bpy.context.view_layer.objects.active = obj
    scene.frame_set(1)
    return obj


def armature_only(obj, scene=None):
    """A copy of the character (its own mesh, the same rig and groups) without OPDeform: the armature-only pose
    that the measurement compares with. Hidden in renders; in ``scene`` (the character's by default)."""
    twin = obj.copy()
    twin.data = obj.data.copy()
    twin.name = obj.name + " (armature only)"
    for m in [m for m in twin.modifiers if m.type != 'ARMATURE']:
        twin.modifiers.remove(m)
    twin.hide_render = True
    (scene or obj.users_scene[0]).collection.objects.link(twin)
    return twin


def enable(obj, **settings):
    """OPDeform after the Armature, as an artist sets it up: Goal on (which picks the Fleshy look), the "follow"
    group picked and the "softness" group picked for the painted regions, the settings given (property names of
    obj.opdeform), then Enable (which builds)."""
    s = obj.opdeform
    s.use_goal, s.goal_group, s.softness_group = True, "follow", "softness"
    for name, value in settings.items():
        setattr(s, name, value)
    scene = obj.users_scene[0]
    with bpy.context.temp_override(scene=scene):
        bpy.ops.opdeform.enable(object=obj.name)
    assert s.built and not s.error, s.error
    assert [m.type for m in obj.modifiers][:1] == ['ARMATURE'], [m.type for m in obj.modifiers]
    return obj


def variant_scene(name, obj):
    """A new scene (the same frames and rate) with the character's rig and floor and a copy of the character
    (its own mesh, no modifier but the Armature); (scene, copy)."""
    scene = bpy.data.scenes.new(name)
    source = obj.users_scene[0]
    scene.render.fps, scene.frame_start, scene.frame_end = source.render.fps, source.frame_start, source.frame_end
    for other in (obj.parent, bpy.data.objects["Floor"]):
        scene.collection.objects.link(other)
    copy = armature_only(obj, scene)
    copy.name, copy.hide_render = name, False
    return scene, copy


def soft_body(obj):
    """Blender's Soft Body after the Armature as an artist adds it: its defaults, Goal from "follow"."""
    obj.modifiers.new("Softbody", 'SOFT_BODY')
    obj.soft_body.use_goal, obj.soft_body.vertex_group_goal = True, "follow"
    return obj


def cloth_dynamics_group():
    """Blender 5.x's bundled Cloth Dynamics node group, appended once; None where the host has none (3.4)."""
    if CLOTH_DYNAMICS in bpy.data.node_groups:
        return bpy.data.node_groups[CLOTH_DYNAMICS]
    path = os.path.join(bpy.utils.system_resource('DATAFILES'), "assets", "nodes",
                        "geometry_nodes_dynamics_assets.blend")
    if not os.path.exists(path):
        return None
    with bpy.data.libraries.load(path) as (src, dst):
        if CLOTH_DYNAMICS not in src.node_groups:
            return None
        dst.node_groups = [CLOTH_DYNAMICS]
    return bpy.data.node_groups[CLOTH_DYNAMICS]


def cloth_dynamics(obj):
    """The Cloth Dynamics node group after the Armature, its defaults, "Pin Group" read from "follow"."""
    group = cloth_dynamics_group()
    mod = obj.modifiers.new("Cloth Dynamics", 'NODES')
    mod.node_group = group
    pin = next(i.identifier for i in group.interface.items_tree
               if i.item_type == 'SOCKET' and i.in_out == 'INPUT' and i.name == "Pin Group")
    field = getattr(mod.properties.inputs, pin)  # Blender 5's modifier interface (4.x: ID properties)
    field.type, field.attribute_name = 'ATTRIBUTE', "follow"
    return obj
