"""opdeform's place in the modifier stack: a Geometry Nodes modifier ("OPDeform", node group "OPDeform Offset")
that the add-on creates and the user may move (after an Armature, before a Subdivision).

Its nodes do two things, read the same way in Blender 3.4 through 5.x:
- Store Named Attribute ``opdeform_input``: the positions that reach the modifier (the rest mesh deformed by
  shape keys, an Armature, a Lattice, ...). The add-on reads them from the evaluated mesh each frame as the
  goal and as the base of the output. Chosen over evaluating the object again with the modifier muted: no
  second evaluation per frame, nothing toggled in the user's stack while playing or rendering.
- Set Position by the offset in the mesh attribute ``opdeform_offset``, which the add-on writes each frame.
  The vertex positions of the mesh are never written. Without the attribute (a saved file: the save handler
  removes it; the add-on disabled or absent) the offset is zero and the modifier passes its input through,
  so the file shows the original mesh and its animation.
"""

import bpy
import numpy as np

MODIFIER = "OPDeform"
GROUP = "OPDeform Offset"
INPUT = "opdeform_input"
OFFSET = "opdeform_offset"


def _socket(group, name, in_out):
    if hasattr(group, "interface"):  # Blender 4.0+
        group.interface.new_socket(name, in_out=in_out, socket_type='NodeSocketGeometry')
    else:
        (group.inputs if in_out == 'INPUT' else group.outputs).new('NodeSocketGeometry', name)


def _vector(sockets):
    return next(s for s in sockets if s.type == 'VECTOR' and s.name in ("Value", "Attribute"))


def _new_group():
    group = bpy.data.node_groups.new(GROUP, 'GeometryNodeTree')
    group["opdeform"] = 1  # ours, whatever its name becomes
    _socket(group, "Geometry", 'INPUT')
    _socket(group, "Geometry", 'OUTPUT')
    nodes, links = group.nodes, group.links
    store = nodes.new('GeometryNodeStoreNamedAttribute')
    store.data_type, store.domain = 'FLOAT_VECTOR', 'POINT'
    store.inputs["Name"].default_value = INPUT
    offset = nodes.new('GeometryNodeInputNamedAttribute')
    offset.data_type = 'FLOAT_VECTOR'
    offset.inputs["Name"].default_value = OFFSET
    move = nodes.new('GeometryNodeSetPosition')
    links.new(nodes.new('NodeGroupInput').outputs[0], store.inputs["Geometry"])
    links.new(nodes.new('GeometryNodeInputPosition').outputs[0], _vector(store.inputs))
    links.new(store.outputs[0], move.inputs["Geometry"])
    links.new(_vector(offset.outputs), move.inputs["Offset"])
    links.new(move.outputs[0], nodes.new('NodeGroupOutput').inputs[0])
    return group


def node_group():
    return next((g for g in bpy.data.node_groups if g.get("opdeform") == 1), None) or _new_group()


def get(obj):
    mod = obj.modifiers.get(MODIFIER)
    return mod if mod is not None and mod.type == 'NODES' and mod.node_group is not None and \
        mod.node_group.get("opdeform") == 1 else None


def ensure(obj):
    """The object's OPDeform modifier, added last in the stack when missing (existing modifiers stay)."""
    mod = get(obj)
    if mod is None:
        mod = obj.modifiers.new(MODIFIER, 'NODES')
        mod.node_group = node_group()
        mod.show_in_editmode = False  # Edit Mode shows and edits the rest mesh
    return mod


def remove(obj):
    mod = get(obj)
    if mod is not None:
        obj.modifiers.remove(mod)
    clear_offset(obj.data)


def index(obj):
    return list(obj.modifiers).index(get(obj))


def write_offset(mesh, offset):
    attr = mesh.attributes.get(OFFSET)
    if attr is None:
        attr = mesh.attributes.new(OFFSET, 'FLOAT_VECTOR', 'POINT')
    attr.data.foreach_set("vector", offset.reshape(-1))
    mesh.update()


def clear_offset(mesh):
    attr = mesh.attributes.get(OFFSET)
    if attr is not None:
        mesh.attributes.remove(attr)
        mesh.update()


def read_input(evaluated_mesh):
    """The positions captured at the modifier (float32 (V, 3)) from the evaluated mesh, None without them."""
    attr = evaluated_mesh.attributes.get(INPUT)
    if attr is None:
        return None
    out = np.empty(len(attr.data) * 3, dtype=np.float32)
    attr.data.foreach_get("vector", out)
    return out.reshape(-1, 3)
