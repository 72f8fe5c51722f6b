"""Reading a mesh object for the engine: its checks, vertex positions, triangles and vertex groups (pins, the
painted maps). Bad input raises AddonError naming the object or group."""

import numpy as np

from .compiled import AddonError


CONVERTIBLE = ('META', 'CURVE', 'SURFACE', 'FONT')  # objects Blender converts to a mesh
SURFACE_MAKERS = ('SKIN', 'SCREW')  # modifiers that make faces of a mesh of edges


def check_object(obj):
    if obj is None:
        raise AddonError("no object: select a mesh object or pass object=NAME")
    if obj.type != 'MESH':
        kind = obj.type.lower()
        article = "an" if kind[0] in "aeiou" else "a"
        convert = " (Object > Convert > Mesh first)" if obj.type in CONVERTIBLE else ""
        raise AddonError(f"{obj.name!r} is {article} {kind} object, not a mesh: oriented particles simulate "
                         f"meshes{convert}")
    mesh = obj.data
    if len(mesh.vertices) == 0:
        raise AddonError(f"mesh {mesh.name!r} has no vertices")
    if len(mesh.polygons) == 0:
        makers = [m.name for m in obj.modifiers if m.type in SURFACE_MAKERS]
        made = f" (its surface is the {makers[0]!r} modifier's: apply it first)" if makers else ""
        raise AddonError(f"mesh {mesh.name!r} has no faces: oriented particles need a surface or a volume{made}")
    if obj.mode == 'EDIT':
        raise AddonError(f"{obj.name!r} is in Edit Mode: leave it first")


def vertex_positions(mesh):
    buf = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    attr = mesh.attributes.get("position")
    if attr is not None and attr.data_type == 'FLOAT_VECTOR' and attr.domain == 'POINT':
        attr.data.foreach_get("vector", buf)
    else:
        mesh.vertices.foreach_get("co", buf)
    return buf.reshape(-1, 3)


def edges(mesh):
    e = np.empty(len(mesh.edges) * 2, dtype=np.int32)
    mesh.edges.foreach_get("vertices", e)
    return e.reshape(-1, 2)


def triangles(mesh):
    mesh.calc_loop_triangles()
    tri = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", tri)
    return tri.reshape(-1, 3)


def group_index(obj, name, what):
    """The index of the object's vertex group ``name``; AddonError naming it when there is none (removed or
    renamed since it was picked)."""
    group = obj.vertex_groups.get(name)
    if group is None:
        raise AddonError(f"{what} group {name!r} is not a vertex group of {obj.name!r} (removed or renamed? "
                         "pick it again in the Physics tab)")
    return group.index


def read_vertex_group(obj, name, what):
    """(indices, weights) of the group's vertices with a weight above zero; None without a group name."""
    if not name:
        return None
    gi = group_index(obj, name, what)
    idx, w = [], []
    for v in obj.data.vertices:
        for g in v.groups:
            if g.group == gi and g.weight > 0.0:
                idx.append(v.index)
                w.append(g.weight)
    if not idx:
        raise AddonError(f"{what} group {name!r} of {obj.name!r} has no vertices (or only zero weights)")
    return np.array(idx, dtype=np.int64), np.array(w, dtype=np.float64)


def bone_moved(obj):
    """Per vertex, whether a deforming bone of the object's Armature modifiers moves it (a weight above zero in
    the vertex group of that bone's name); None where the groups do not say (no such modifier, one without an
    armature or with bone envelopes, which move vertices outside any group)."""
    rigs = [m for m in obj.modifiers if m.type == 'ARMATURE' and m.show_viewport]
    if not rigs or any(m.object is None or m.object.type != 'ARMATURE' or m.use_bone_envelopes
                       or not m.use_vertex_groups for m in rigs):
        return None
    bones = {b.name for m in rigs for b in m.object.data.bones if b.use_deform}
    groups = {g.index for g in obj.vertex_groups if g.name in bones}
    return np.array([any(g.group in groups and g.weight > 0.0 for g in v.groups) for v in obj.data.vertices],
                    dtype=bool)


def read_weights(obj, name, what):
    """A vertex group as one weight per vertex (0 outside the group); None without a group name."""
    group = read_vertex_group(obj, name, what)
    if group is None:
        return None
    weights = np.zeros(len(obj.data.vertices))
    weights[group[0]] = group[1]
    return weights
