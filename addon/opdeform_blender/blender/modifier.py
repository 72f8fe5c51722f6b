"""opdeform's place in the modifier stack: a Geometry Nodes modifier ("OPDeform", node group "OPDeform: see
Physics") that the add-on creates and the user may move (after an Armature, before a Subdivision). The Modifier
tab explains it by the group's name (whole at the factory Properties width, 333 px under a 1920-pixel window),
its description (Blender 4.0+: the group's tooltip) and a frame inside the group.

Its nodes do three things, read the same way in Blender 3.4 through 5.x:
- Store Named Attribute ``opdeform_input``: the positions that reach the modifier (the rest mesh deformed by
  shape keys, an Armature, a Lattice, ...). The add-on reads them from the evaluated mesh each frame as the
  goal and as the base of the output. Chosen over evaluating the object again with the modifier muted: no
  second evaluation per frame, nothing toggled in the user's stack while playing or rendering.
- Store Named Attribute ``opdeform_index``: each vertex's index at the modifier. Modifiers after OPDeform
  carry both attributes along; a Subdivision keeps the original vertices first and copies their attributes
  unchanged, so the index tells the add-on where they are in the evaluated mesh (and that a count differing
  at the modifier itself comes from a modifier before it).
- Store Named Attribute ``opdeform_maps``: per vertex the weights of the vertex groups picked as the painted
  maps (the group inputs Follow, Softness and Damping, each fed by its group on the modifier, ``set_maps``; 0
  where none is picked), one vector. The add-on reads it each frame in one call (``read_maps``; walking the
  groups in Python takes 5-8 ms for 5,000 vertices), so a group changed in any way (a script, Weight Paint, Edit
  Mode) is applied on the next frame.
- Set Position by the offset in the mesh attribute ``opdeform_offset``, which the add-on writes each frame.
  The vertex positions of the mesh are never written. Without the attribute (a saved file: the save handler
  removes it; the add-on disabled or absent) the offset is zero and the modifier passes its input through,
  so the file shows the original mesh and its animation.
"""

import bpy
import numpy as np

MODIFIER = "OPDeform"
GROUP = "OPDeform: see Physics"
ABOUT = ("OPDeform soft body: the OPDeform add-on writes each frame's simulated offset here; its settings are "
         "in the Physics tab (Oriented Particles)")
INPUT = "opdeform_input"
INDEX = "opdeform_index"
OFFSET = "opdeform_offset"
WEIGHTS = "opdeform_maps"
MAPS = ("Follow", "Softness", "Damping")  # the group inputs carrying the painted maps' groups
VERSION = 4  # the node group's layout: 1 had no index, 2 no explanation, 3 no maps; an older group is replaced on Build


def _socket(group, name, in_out, kind='NodeSocketGeometry'):
    if hasattr(group, "interface"):  # Blender 4.0+
        return group.interface.new_socket(name, in_out=in_out, socket_type=kind)
    return (group.inputs if in_out == 'INPUT' else group.outputs).new(kind, name)


def _inputs(group):
    """The group's inputs: name -> identifier (the modifier's keys)."""
    if hasattr(group, "interface"):  # Blender 4.0+
        return {i.name: i.identifier for i in group.interface.items_tree
                if i.item_type == 'SOCKET' and i.in_out == 'INPUT'}
    return {i.name: i.identifier for i in group.inputs}


def _value(sockets, kind='VECTOR'):
    return next(s for s in sockets if s.type == kind and s.name in ("Value", "Attribute"))


def _store(nodes, links, name, data_type, kind, value_socket, geometry_socket):
    """A Store Named Attribute node writing value_socket on the points; returns its geometry output."""
    store = nodes.new('GeometryNodeStoreNamedAttribute')
    store.data_type, store.domain = data_type, 'POINT'
    store.inputs["Name"].default_value = name
    links.new(geometry_socket, store.inputs["Geometry"])
    links.new(value_socket, _value(store.inputs, kind))
    return store.outputs[0]


def _new_group():
    group = bpy.data.node_groups.new(GROUP, 'GeometryNodeTree')
    group["opdeform"] = VERSION  # ours, whatever its name becomes
    if hasattr(group, "description"):  # Blender 4.0+
        group.description = ABOUT
    _socket(group, "Geometry", 'INPUT')
    for name in MAPS:
        socket = _socket(group, name, 'INPUT', 'NodeSocketFloat')
        socket.hide_value = True  # fed a vertex group by the add-on, never a value
        socket.description = f"The {name} group picked in the Physics tab (Oriented Particles), set by the add-on"
    _socket(group, "Geometry", 'OUTPUT')
    nodes, links = group.nodes, group.links
    given = nodes.new('NodeGroupInput').outputs
    geometry = _store(nodes, links, INPUT, 'FLOAT_VECTOR', 'VECTOR',
                      nodes.new('GeometryNodeInputPosition').outputs[0], given[0])
    geometry = _store(nodes, links, INDEX, 'INT', 'INT', nodes.new('GeometryNodeInputIndex').outputs[0], geometry)
    combine = nodes.new('ShaderNodeCombineXYZ')
    for k, name in enumerate(MAPS):
        links.new(given[name], combine.inputs[k])
    geometry = _store(nodes, links, WEIGHTS, 'FLOAT_VECTOR', 'VECTOR', combine.outputs[0], geometry)
    offset = nodes.new('GeometryNodeInputNamedAttribute')
    offset.data_type = 'FLOAT_VECTOR'
    offset.inputs["Name"].default_value = OFFSET
    move = nodes.new('GeometryNodeSetPosition')
    links.new(geometry, move.inputs["Geometry"])
    links.new(_value(offset.outputs), move.inputs["Offset"])
    links.new(move.outputs[0], nodes.new('NodeGroupOutput').inputs[0])
    note = nodes.new('NodeFrame')
    note.label, note.label_size = "Settings: Physics tab > Oriented Particles (OPDeform add-on)", 14
    return group


def node_group():
    return next((g for g in bpy.data.node_groups if g.get("opdeform") == VERSION), None) or _new_group()


def get(obj):
    mod = obj.modifiers.get(MODIFIER)
    return mod if mod is not None and mod.type == 'NODES' and mod.node_group is not None and \
        mod.node_group.get("opdeform") else None


def ensure(obj):
    """The object's OPDeform modifier, added last in the stack when missing (existing modifiers stay); an
    older node group is replaced by the current one."""
    mod = get(obj)
    if mod is None:
        mod = obj.modifiers.new(MODIFIER, 'NODES')
        mod.show_in_editmode = False  # Edit Mode shows and edits the rest mesh
    if mod.node_group is None or mod.node_group.get("opdeform") != VERSION:
        mod.node_group = node_group()
    return mod


def _fed(mod, key):
    """The vertex group feeding the modifier's input ``key`` ("" for none)."""
    if hasattr(mod, "properties"):  # Blender 5.0+
        socket = getattr(mod.properties.inputs, key)
        return socket.attribute_name if socket.type == 'ATTRIBUTE' else ""
    return mod.get(f"{key}_attribute_name", "") if mod.get(f"{key}_use_attribute") else ""


def _feed(mod, key, group):
    """Feeds the modifier's input ``key`` with the vertex group ``group`` (its value, 0, for "")."""
    if hasattr(mod, "properties"):  # Blender 5.0+
        socket = getattr(mod.properties.inputs, key)
        socket.type, socket.attribute_name = 'ATTRIBUTE' if group else 'VALUE', group
    else:
        use = f"{key}_use_attribute"  # an int ID property up to 4.x, a Boolean one in 5.0 (which takes no int)
        mod[use], mod[f"{key}_attribute_name"] = type(mod.get(use, 0))(bool(group)), group


def set_maps(obj, names):
    """Feeds the modifier's Follow, Softness and Damping inputs with the vertex groups ``names`` (MAPS order; ""
    for none); the object is evaluated again. A node group older than VERSION has no such inputs (replaced on
    Build)."""
    mod = get(obj)
    if mod.node_group.get("opdeform") != VERSION:
        return
    ids = _inputs(mod.node_group)
    for name, group in zip(MAPS, names):
        if _fed(mod, ids[name]) != group:
            _feed(mod, ids[name], group)
    obj.update_tag()


def read_maps(evaluated_mesh, n):
    """The weights the modifier stored for its map inputs, float32 (n, 3) in MAPS order, None where missing (an
    older node group; Edit Mode, where the modifier does not run). A later modifier that grew the mesh keeps the
    original vertices first (``read_input`` checks it)."""
    weights = _read(evaluated_mesh, WEIGHTS, "vector", np.float32, 3)
    return None if weights is None or len(weights) < n else weights[:n]


def remove(obj):
    mod = get(obj)
    if mod is not None:
        obj.modifiers.remove(mod)
    clear_offset(obj.data)


def index(obj):
    return list(obj.modifiers).index(get(obj))


def above(obj):
    """The names of the modifiers above OPDeform's that are on in the viewport, but Armatures."""
    return [m.name for m in list(obj.modifiers)[:index(obj)] if m.show_viewport and m.type != 'ARMATURE']


def offset_attribute(mesh):
    return mesh.attributes.get(OFFSET)


def write_offset(mesh, offset, attr=None):
    """Writes the offset into the mesh's attribute (``attr`` when the caller has it, else looked up), created
    when missing."""
    attr = mesh.attributes.get(OFFSET) if attr is None else attr
    if attr is None:
        attr = mesh.attributes.new(OFFSET, 'FLOAT_VECTOR', 'POINT')
    attr.data.foreach_set("vector", offset.reshape(-1))
    mesh.update()


def clear_offset(mesh):
    attr = mesh.attributes.get(OFFSET)
    if attr is not None:
        mesh.attributes.remove(attr)
        mesh.update()


def _read(evaluated_mesh, name, field, dtype, width):
    attr = evaluated_mesh.attributes.get(name)
    if attr is None:
        return None
    out = np.empty(len(attr.data) * width, dtype=dtype)
    attr.data.foreach_get(field, out)
    return out.reshape(-1, width) if width > 1 else out


def read_input(evaluated_mesh, n):
    """(the positions captured at the modifier, float32 (L, 3); each one's vertex index there, int32 (L,)) from
    the evaluated mesh, which later modifiers may have grown to L vertices; None where missing. The index is
    read only where L differs from the mesh's n vertices (0.3 ms a frame at 100k vertices)."""
    positions = _read(evaluated_mesh, INPUT, "vector", np.float32, 3)
    needs_index = positions is not None and len(positions) != n
    return positions, _read(evaluated_mesh, INDEX, "value", np.int32, 1) if needs_index else None
