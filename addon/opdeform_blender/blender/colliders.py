"""The scene's colliders and force fields as core/colliders.py and core/fields.py records, read from the evaluated
depsgraph of the frame: every object with a Collision modifier (its Friction and Outer Thickness; animated by
its transform, deforming by its evaluated mesh) and every Wind, Force, Vortex and Turbulence field, filtered by
the simulated object's contact settings (``Object.opdeform_contact``: Scene Colliders on or off, the Collision
Collection, the effector weights with their collection, as Cloth and Soft Body have them).

A collider that is switched off (Collision > Field Absorption's panel header, ``collision.use``) is skipped;
so is the simulated object itself. Bad input raises core's ColliderError naming the object; the caller
reports it and changes nothing.
"""

import bpy
import numpy as np

from ..core import colliders as core
from ..core import fields as field_logic
from . import mesh_data

FRICTION_SCALE = 0.1  # Coulomb mu = Collision's Friction (0..80, Blender's default 5) / 10
# The skin rests a quarter into the Collision's Thickness Outer zone: 0.5 cm at Blender's default 2 cm, where
# Soft Body's vertices rest 0.4-0.6 cm off on the same shot (docs/contact.md, "Contact on the skin").
OUTER_ZONE_REST = 0.25
_FIELD_WEIGHTS = {"WIND": "wind", "FORCE": "force", "VORTEX": "vortex", "TURBULENCE": "turbulence"}
_reader = core.ColliderReader()  # an unchanged collider is read without its checks, as the same record
# collider name -> ((its mesh's name and vertex, corner and face counts), its triangles): kept for a collider whose
# mesh does not deform until an edit updates its geometry (forget_triangles): Blender triangulates anew on every
# read: 0.06 ms a frame for a 512-triangle ramp, 6.7 ms for 51,200 triangles (measured in Blender 3.4)
_triangles = {}


def _in(collection, obj):
    return collection is None or obj.name in collection.all_objects


def collision_modifier(obj):
    return next((m for m in obj.modifiers if m.type == 'COLLISION' and m.show_viewport), None) \
        if obj.type == 'MESH' else None


def collider_objects(scene, obj, settings):
    """The objects whose Collision modifier acts on obj (none while its Scene Colliders is off), by name."""
    if not settings.use_colliders:
        return []
    return sorted((o for o in scene.objects if o != obj and collision_modifier(o) is not None and o.collision.use
                   and _in(settings.collision_collection, o)), key=lambda o: o.name)


def may_deform(obj):
    """Whether the evaluated mesh may change from frame to frame (modifiers other than Collision, shape keys):
    such colliders are sampled coarser, as they re-sample each frame they change."""
    keys = obj.data.shape_keys
    return keys is not None or any(m.type != 'COLLISION' for m in obj.modifiers)


def forget_triangles(names=None):
    """Drops the kept triangles of the colliders or meshes named (all when None): their geometry was edited."""
    if names is None:
        _triangles.clear()
        return
    names = set(names)
    for collider in [c for c, (key, _) in _triangles.items() if c in names or key[0] in names]:
        del _triangles[collider]


def _triangles_of(obj, mesh, deforms):
    if deforms:
        return mesh_data.triangles(mesh)
    key = (obj.data.name, len(mesh.vertices), len(mesh.loops), len(mesh.polygons))
    kept = _triangles.get(obj.name)
    if kept is None or kept[0] != key:
        kept = _triangles[obj.name] = (key, mesh_data.triangles(mesh))
    return kept[1]


def read_collider(obj, depsgraph):
    evaluated = obj.evaluated_get(depsgraph)
    deforms = may_deform(obj)
    vertices = mesh_data.vertex_positions(evaluated.data).astype(np.float64)
    triangles = _triangles_of(obj, evaluated.data, deforms)
    c = obj.collision
    resolution = core.DEFORMING_RESOLUTION if deforms else core.STATIC_RESOLUTION
    return _reader.frame(obj.name, vertices, triangles, np.array(evaluated.matrix_world),
                         FRICTION_SCALE * c.cloth_friction, OUTER_ZONE_REST * c.thickness_outer, resolution)


def _field_weight(weights, kind):
    return weights.all * getattr(weights, _FIELD_WEIGHTS[kind])


def field_objects(scene, weights):
    return sorted((o for o in scene.objects if o.field is not None and o.field.type in _FIELD_WEIGHTS
                   and _in(weights.collection, o)), key=lambda o: o.name)


def read_field(obj, weights, depsgraph):
    f = obj.field
    if not np.isfinite(f.strength):
        raise core.ColliderError(f"force field {obj.name!r}: its strength is not finite (NaN)")
    return field_logic.field(obj.name, f.type, f.strength * _field_weight(weights, f.type),
                             np.array(obj.evaluated_get(depsgraph).matrix_world), f.falloff_power,
                             f.distance_min if f.use_min_distance else 0.0,
                             f.distance_max if f.use_max_distance else 0.0, f.noise, f.flow, f.size, f.seed)


def fields(scene, settings, depsgraph):
    weights = settings.effector_weights
    return tuple(read_field(o, weights, depsgraph) for o in field_objects(scene, weights)
                 if _field_weight(weights, o.field.type) != 0.0)


def surroundings(obj, scene, depsgraph=None):
    """obj's colliders and force fields at the scene's frame; ColliderError on bad input."""
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    settings = obj.opdeform_contact
    colliders = tuple(read_collider(o, depsgraph) for o in collider_objects(scene, obj, settings))
    return core.Surroundings(colliders, fields(scene, settings, depsgraph))
