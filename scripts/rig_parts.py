"""Pieces shared by the outside-view rig scripts (scripts/outside_rigs.py, scripts/outside_bird.py): objects linked
into the scene, parented to an armature with automatic weights, painted groups, mesh shells, world positions, the
base mesh and the armature-only twin; the add-on installed from a zip."""
import os
import sys

import bpy
import numpy as np

TESTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "blender")


def install(zip_path, kind):
    """The add-on as a new user has it: the zip installed into the (empty) user folders, kind "legacy" or
    "extension"; kind "dev" (zip "-"): the repository's add-on with $OPDEFORM_PYTHONPATH. Its module name."""
    sys.path.insert(0, TESTS)
    import helpers
    if kind == "dev":
        helpers.enable_addon()
        return helpers.ADDON
    sys.path[:] = [p for p in sys.path if os.path.abspath(p) != os.path.abspath(helpers.ADDON_DIR)]
    return helpers.install_package(zip_path, kind)


def link(obj):
    bpy.context.scene.collection.objects.link(obj)
    return obj


def parent_auto(obj, arm):
    bpy.ops.object.select_all(action='DESELECT')
    obj.select_set(True)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.parent_set(type='ARMATURE_AUTO')


def paint(obj, name, w):
    g = obj.vertex_groups.new(name=name)
    for value in np.unique(w):
        g.add([int(i) for i in np.where(w == value)[0]], float(value), 'REPLACE')


def shells(obj):
    """Per vertex, its connected piece's index (ordered by first vertex)."""
    n = len(obj.data.vertices)
    parent = np.arange(n)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for e in obj.data.edges:
        a, b = find(e.vertices[0]), find(e.vertices[1])
        if a != b:
            parent[max(a, b)] = min(a, b)
    return np.array([find(i) for i in range(n)])


def world(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    me = ev.to_mesh()
    out = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", out)
    ev.to_mesh_clear()
    m = np.array(ev.matrix_world)
    return out.reshape(-1, 3).astype(float) @ m[:3, :3].T + m[:3, 3]


def base(obj):
    out = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", out)
    return out


def twin_of(obj):
    t = obj.copy()
    t.data = obj.data.copy()
    t.name = obj.name + "_twin"
    for m in [m for m in t.modifiers if m.type != 'ARMATURE']:
        t.modifiers.remove(m)
    bpy.context.scene.collection.objects.link(t)
    return t
