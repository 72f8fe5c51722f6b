"""What the engine is given, read from an object's settings and its scene: the graph's key, the cache's frame
range, the frame rate, gravity, the solver's parameters (core/settings.py), the floor, contact and goal; and
the folder of a bake. A new setting that reaches the engine is read here."""

import operator

import bpy

from ..core import settings as core_settings
from . import presets
from .colliders import FRICTION_SCALE
from .compiled import AddonError, module


def graph_key(settings):
    return (settings.particles, settings.graph_mode, settings.neighbors, settings.pin_group)


def frame_range(settings, scene):
    """(start, end) of the cache: the scene's frame range while Scene Range is on, else the object's own."""
    if settings.use_scene_range:
        return scene.frame_start, scene.frame_end
    return settings.frame_start, settings.frame_end


def frame_rate(scene):
    return scene.render.fps / scene.render.fps_base


def gravity(settings, scene):
    """The scene's gravity as the body feels it: with a goal, the Sag share of it (the animation holds its shape
    against the rest)."""
    use = scene.use_gravity and (settings.mode == 'DYNAMIC' or settings.pose_gravity)
    share = settings.sag if goal_strength(settings) is not None else 1.0
    return tuple(share * g for g in scene.gravity) if use else (0.0, 0.0, 0.0)


def sim_settings(settings, scene, graph):
    """(Simulation parameters, set_solver arguments) of the settings for this graph (core/settings.py)."""
    fps = frame_rate(scene)
    return core_settings.solver_settings(module(), graph, presets.units(settings, fps), fps,
                                         gravity(settings, scene))


def floor(settings):
    return (settings.floor_height, settings.floor_friction) if settings.use_floor else None


def self_contact(contact):
    """set_self_contact's arguments from the object's contact settings (None: Self Collision off)."""
    if not contact.use_self_collision:
        return None
    return dict(thickness=contact.self_distance, friction=FRICTION_SCALE * contact.self_friction)


def body_contact(contact):
    """Engine.set_contact's (gap, friction, skin) with the other opdeform objects."""
    return contact.object_distance, FRICTION_SCALE * contact.object_friction, contact.object_shape == 'SKIN'


def goal_strength(settings):
    """The goal's Follow in use: None when off (and in posing mode, which has no animation to follow)."""
    return settings.goal_strength if settings.use_goal and settings.mode == 'DYNAMIC' else None


def maps(settings):
    """The painted maps' settings (what the engine is given besides the groups' weights, and what a bake
    depends on): (follow group, follow range, softness group, soft stiffness, damping group, its damping per
    second)."""
    return (settings.goal_group, (settings.goal_min, settings.goal_max), settings.softness_group,
            settings.soft_stiffness, settings.damping_group, settings.region_damping)


def cache_folder(folder):
    """The absolute path of a cache folder setting ('//': next to the .blend, which must be saved then)."""
    if folder.startswith("//") and not bpy.data.filepath:
        raise AddonError("save the .blend file first, or choose an absolute cache folder")
    return bpy.path.abspath(folder)


_FIELDS = {}  # settings class -> (a reader of its plain properties, names of its array, pointer, collection ones)


def _reader(names):
    """The values of the named properties of a group as a tuple, read in one call (attrgetter: 0.004 ms for the
    47 plain settings of an object, where a getattr each took 0.006)."""
    get = operator.attrgetter(*names) if names else None
    return get if len(names) > 1 else (lambda group: (get(group),)) if names else (lambda group: ())


def _fields(group):
    cls = type(group)
    if cls not in _FIELDS:
        props = [p for p in group.bl_rna.properties if p.identifier != "rna_type"]
        kinds = ["ARRAY" if getattr(p, "is_array", False) else p.type if p.type in ('POINTER', 'COLLECTION')
                 else "PLAIN" for p in props]
        plain, *others = ([p.identifier for p, k in zip(props, kinds) if k == kind]
                          for kind in ("PLAIN", "ARRAY", 'POINTER', 'COLLECTION'))
        _FIELDS[cls] = (_reader(plain), *others)
    return _FIELDS[cls]


def _pointed(value):
    """A pointer property's value without keeping a bpy pointer: an ID's type and name, a group's values."""
    if value is None:
        return None
    return (type(value).__name__, value.name_full) if isinstance(value, bpy.types.ID) else values(value)


def values(group):
    """Every property of a settings group (its collections' items included) as comparable values (0.01 ms for an
    object's settings)."""
    plain, arrays, pointers, collections = _fields(group)
    return (plain(group), tuple(tuple(getattr(group, name)) for name in arrays),
            tuple(_pointed(getattr(group, name)) for name in pointers),
            tuple(tuple(values(item) for item in getattr(group, name)) for name in collections))


def settings_key(obj, scene):
    """What configuring the engine reads from Blender, as comparable values: the object's OPDeform and contact
    settings (handles included), its mode (where groups are painted) and the scene's rate, gravity and range."""
    render = scene.render
    return (values(obj.opdeform), values(obj.opdeform_contact), obj.mode, render.fps, render.fps_base,
            scene.use_gravity, tuple(scene.gravity), scene.frame_start, scene.frame_end)
