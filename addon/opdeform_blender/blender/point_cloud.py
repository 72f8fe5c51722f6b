"""The point cloud that shows baked tumbling frames: a mesh object "<domain> Particles" of vertices only, whose
"orientation" attribute (a quaternion from Blender 4.1, XYZ Euler angles before) turns a snowflake, or any
object, instanced on every point by Geometry Nodes."""

import importlib

import bpy
import numpy as np

from ..core import tumbling as core
from .compiled import module

ATTRIBUTE = "orientation"
MODIFIER_NAME = "Tumbling Instances"


def _quaternion_attributes():
    return bpy.app.version >= core.QUATERNION_ATTRIBUTES


def points_object(domain, scene):
    """The domain's point cloud, made and linked to the scene when missing."""
    s = domain.opdeform_tumbling
    name = s.points_name or f"{domain.name} Particles"
    obj = bpy.data.objects.get(name)
    if obj is None or obj.type != 'MESH':
        obj = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        scene.collection.objects.link(obj)
    s.points_name = obj.name
    return obj


def show_frame(points, mpm, folder, frame):
    """Loads a baked frame into the point cloud; False when its file is missing."""
    data = core.read_frame(mpm, folder, frame)
    if data is None:
        return False
    show_particles(points, mpm, *data)
    return True


def write_positions(mesh, verts):
    """The fast path: one foreach_set of a float32 buffer ("position" attribute on 3.5+, vertex co before)."""
    flat = verts.reshape(-1)
    attr = mesh.attributes.get("position")
    if attr is not None and attr.data_type == 'FLOAT_VECTOR' and attr.domain == 'POINT':
        attr.data.foreach_set("vector", flat)
    else:
        mesh.vertices.foreach_set("co", flat)
    mesh.update()


def show_particles(points, mpm, positions, quaternions):
    """Sets the point cloud's vertices and orientation attribute (quaternions w x y z)."""
    mesh = points.data
    if len(mesh.vertices) != len(positions):
        mesh.clear_geometry()
        mesh.vertices.add(len(positions))
    write_positions(mesh, np.ascontiguousarray(positions, dtype=np.float32))
    attr = mesh.attributes.get(ATTRIBUTE)
    if attr is None:
        attr = mesh.attributes.new(ATTRIBUTE, 'QUATERNION' if _quaternion_attributes() else 'FLOAT_VECTOR', 'POINT')
    if attr.data_type == 'QUATERNION':
        attr.data.foreach_set("value", np.ascontiguousarray(quaternions, dtype=np.float32).ravel())
    else:
        euler = mpm.quaternions_to_euler(quaternions)
        attr.data.foreach_set("vector", np.ascontiguousarray(euler, dtype=np.float32).ravel())
    mesh.update()


def snowflake_object():
    """The add-on's snowflake: a six-armed star of radius 1 in the xy plane (not linked to any scene)."""
    scenes = importlib.import_module(module().__name__ + ".mpm_scenes")
    name = "OPDeform Snowflake"
    obj = bpy.data.objects.get(name)
    if obj is None:
        verts, tris = scenes.snowflake_mesh(radius=1.0)
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata([tuple(v) for v in verts], [], [tuple(int(i) for i in t) for t in tris])
        mesh.update()
        obj = bpy.data.objects.new(name, mesh)
    return obj


def _geometry_sockets(group):
    if hasattr(group, "interface"):  # Blender 4.0+
        group.interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
        group.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    else:
        group.inputs.new('NodeSocketGeometry', "Geometry")
        group.outputs.new('NodeSocketGeometry', "Geometry")


def instance_nodes(points, instance, scale=1.0):
    """Geometry Nodes on the point cloud: Instance on Points of `instance` (its own geometry, without its
    transform) scaled by `scale` and turned by the orientation attribute."""
    name = f"{points.name} Instances"
    old = bpy.data.node_groups.get(name)
    if old is not None:
        bpy.data.node_groups.remove(old)
    group = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    _geometry_sockets(group)
    nodes, links = group.nodes, group.links
    gin, gout = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    info = nodes.new('GeometryNodeObjectInfo')
    info.inputs["Object"].default_value = instance
    info.transform_space = 'ORIGINAL'
    attr = nodes.new('GeometryNodeInputNamedAttribute')
    attr.data_type = 'QUATERNION' if _quaternion_attributes() else 'FLOAT_VECTOR'
    attr.inputs["Name"].default_value = ATTRIBUTE
    place = nodes.new('GeometryNodeInstanceOnPoints')
    place.inputs["Scale"].default_value = (scale, scale, scale)
    links.new(gin.outputs[0], place.inputs["Points"])
    links.new(info.outputs["Geometry"], place.inputs["Instance"])
    links.new(next(o for o in attr.outputs if o.name == "Attribute" and o.enabled), place.inputs["Rotation"])
    links.new(place.outputs["Instances"], gout.inputs[0])
    mod = points.modifiers.get(MODIFIER_NAME) or points.modifiers.new(MODIFIER_NAME, 'NODES')
    mod.node_group = group
    return mod
