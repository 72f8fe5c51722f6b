"""Tumbling particles in the add-on (run by tests/blender/runner.py inside Blender; see test_addon_tumbling.py).

A cube domain with a flake layer, wind, a floor and an animated box collider is baked; the frames play on
the point cloud with the orientation attribute (quaternion from 4.1, Euler before) and Instance on Points."""

import os

import bpy
import numpy as np

import helpers


def tumbling():
    import importlib
    return importlib.import_module(helpers.ADDON + ".blender.tumbling_runtime")


def domain(name="Domain", lo=(0.0, 0.0, -0.1), hi=(1.0, 1.0, 1.0)):
    v, t = helpers.box_mesh(lo, hi, (2, 2, 2))
    obj = helpers.mesh_object(name, v, t)
    bpy.ops.opdeform.tumbling_enable(object=obj.name)
    s = obj.opdeform_tumbling
    s.dx, s.count, s.frame_start, s.frame_end = 0.05, 300, 1, 8
    s.layer_height, s.layer_thickness = 0.5, 0.2
    s.cache_directory = os.path.join(helpers.tmpdir(), name)
    return obj


def animated_box(name="Car", half=0.12):
    v, t = helpers.box_mesh((-half, -0.3, 0.0), (half, 0.3, 0.3), (2, 2, 2))
    obj = helpers.mesh_object(name, v, t, location=(0.0, 0.5, 0.0))
    obj.keyframe_insert("location", frame=1)
    obj.location = (0.6, 0.5, 0.0)  # stops short of the domain's wall: material squeezed against a wall
    obj.keyframe_insert("location", frame=8)  # would be held there by the wall, inside the collider
    collection = bpy.data.collections.new("Colliders")
    bpy.context.scene.collection.children.link(collection)
    collection.objects.link(obj)
    return obj, collection


def points_state(points):
    mesh = points.data
    pos = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", pos)
    attr = mesh.attributes["orientation"]
    width = 4 if attr.data_type == 'QUATERNION' else 3
    rot = np.empty(len(mesh.vertices) * width, np.float32)
    attr.data.foreach_get("value" if width == 4 else "vector", rot)
    return pos.reshape(-1, 3), rot.reshape(-1, width), attr.data_type


def test_bake_plays_frames_with_orientation_and_instances():
    obj = domain()
    bpy.ops.opdeform.tumbling_bake(object=obj.name)
    s = obj.opdeform_tumbling
    assert s.baked
    core = tumbling().core
    assert core.baked_frames(s.baked_folder) == list(range(1, 9))
    points = bpy.data.objects[s.points_name]
    assert len(points.data.vertices) == 300
    mpm = tumbling().mpm()
    scene = bpy.context.scene
    turned = []
    for frame in (1, 5, 8):
        scene.frame_set(frame)
        pos, rot, kind = points_state(points)
        ref_pos, ref_q = core.read_frame(mpm, s.baked_folder, frame)
        np.testing.assert_allclose(pos, ref_pos, atol=1e-6)
        if bpy.app.version >= (4, 1):
            assert kind == 'QUATERNION'
            np.testing.assert_allclose(rot, ref_q, atol=1e-6)
        else:
            assert kind == 'FLOAT_VECTOR'
            np.testing.assert_allclose(rot, mpm.quaternions_to_euler(ref_q), atol=1e-5)
        turned.append(ref_q)
    dots = np.abs((turned[0] * turned[-1]).sum(axis=1))
    assert np.median(2 * np.degrees(np.arccos(np.clip(dots, 0, 1)))) > 0.5  # the noise wind turned them
    mod = points.modifiers["Tumbling Instances"]
    kinds = {n.bl_idname for n in mod.node_group.nodes}
    assert 'GeometryNodeInstanceOnPoints' in kinds and 'GeometryNodeInputNamedAttribute' in kinds
    # the evaluated point cloud holds one snowflake per particle
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = points.evaluated_get(depsgraph)
    instances = [i for i in depsgraph.object_instances if i.is_instance and i.parent
                 and i.parent.original == points]
    assert len(instances) == 300 or len(evaluated.data.vertices) == 0


def test_animated_collider_pushes_and_nothing_enters_it():
    obj = domain("Street", lo=(0.0, 0.0, -0.1), hi=(1.0, 1.0, 0.6))
    s = obj.opdeform_tumbling
    s.material, s.wind, s.count = "snow", "off", 400
    s.layer_height, s.layer_thickness = 0.25, 0.2
    car, collection = animated_box()
    s.colliders = collection
    bpy.ops.opdeform.tumbling_bake(object=obj.name)
    mpm = tumbling().mpm()
    core = tumbling().core
    first, _ = core.read_frame(mpm, s.baked_folder, 1)
    for frame in range(2, 9):
        pos, _ = core.read_frame(mpm, s.baked_folder, frame)
        bpy.context.scene.frame_set(frame)
        x = car.matrix_world.translation.x
        inside = (np.abs(pos[:, 0] - x) < 0.12 - 0.01) & (np.abs(pos[:, 1] - 0.5) < 0.3 - 0.01) & \
                 (pos[:, 2] < 0.3 - 0.01)
        assert not inside.any(), (frame, int(inside.sum()))
    last, _ = core.read_frame(mpm, s.baked_folder, 8)
    assert (last[:, 0] - first[:, 0]).max() > 0.1  # pushed ahead of the box


def test_errors_are_reports():
    obj = domain("Bad")
    s = obj.opdeform_tumbling
    s.emitter = 'VOLUME'
    helpers.expect_error(lambda: bpy.ops.opdeform.tumbling_bake(object=obj.name), "emitter")
    s.emitter = 'LAYER'
    flat = helpers.mesh_object("Flat", [(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    collection = bpy.data.collections.new("Flat Colliders")
    bpy.context.scene.collection.children.link(collection)
    collection.objects.link(flat)
    s.colliders = collection
    helpers.expect_error(lambda: bpy.ops.opdeform.tumbling_bake(object=obj.name), "faces")
    s.colliders = None
    s.dx = 0.5  # a domain of 2 cells
    helpers.expect_error(lambda: bpy.ops.opdeform.tumbling_bake(object=obj.name), "grid spacing")
    assert not s.baked


def test_free_bake_removes_frames_and_points():
    obj = domain("Freed")
    s = obj.opdeform_tumbling
    s.frame_end = 3
    bpy.ops.opdeform.tumbling_bake(object=obj.name)
    folder, name = s.baked_folder, s.points_name
    assert tumbling().core.baked_frames(folder) == [1, 2, 3]
    bpy.ops.opdeform.tumbling_free_bake(object=obj.name)
    assert tumbling().core.baked_frames(folder) == [] and bpy.data.objects.get(name) is None and not s.baked


def test_panel_draws():
    obj = domain("Drawn")
    log = helpers.draw_panels()
    assert ("operator", "opdeform.tumbling_bake", None) in log
    obj.opdeform_tumbling.enabled = False
    assert ("operator", "opdeform.tumbling_enable", None) in helpers.draw_panels()
