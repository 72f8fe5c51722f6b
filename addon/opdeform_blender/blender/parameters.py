"""What the engine is given, read from an object's settings and its scene: the graph's key, the cache's frame
range, the frame rate, gravity, the solver's parameters (core/settings.py), the floor, contact and goal; and
the folder of a bake. A new setting that reaches the engine is read here."""

from dataclasses import replace

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


def scaling(settings):
    """How the body's size scales its modulus and gravity (opdeform.materials.SCALINGS): "goal" (the same look
    at any size) for an object that follows its animation (a Follow in use) unless it scales physically
    (Physical Scaling, or made before settings version 5: versioning.py), else "froude"."""
    physical = settings.use_physical_scaling or settings.settings_version < core_settings.SIZE_FREE_VERSION
    return "goal" if goal_strength(settings) is not None and not physical else "froude"


def sim_settings(settings, scene, graph):
    """(Simulation parameters, set_solver arguments) of the settings for this graph (core/settings.py)."""
    fps = frame_rate(scene)
    units = replace(presets.units(settings, fps), scaling=scaling(settings))
    return core_settings.solver_settings(module(), graph, units, fps, gravity(settings, scene))


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
    depends on): (follow group, follow range, detached shells' follow minimum, softness group, soft stiffness,
    damping group, its damping per second, the jiggle frequency)."""
    return (settings.goal_group, (settings.goal_min, settings.goal_max), settings.shell_follow_min,
            settings.softness_group, settings.soft_stiffness, settings.damping_group, settings.region_damping,
            settings.jiggle_hz)


def cache_folder(folder):
    """The absolute path of a cache folder setting ('//': next to the .blend, which must be saved then)."""
    if folder.startswith("//") and not bpy.data.filepath:
        raise AddonError("save the .blend file first, or choose an absolute cache folder")
    return bpy.path.abspath(folder)


_HOLDERS = {}  # settings group's name -> its pointer and collection properties (where a stored ID can be)


def _plain(value):
    """A stored value without bpy pointers: an ID as its type and name, groups and lists item by item."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return (type(value).__name__, value.name_full) if isinstance(value, bpy.types.ID) else value


def _holders(obj, name):
    if name not in _HOLDERS:
        _HOLDERS[name] = tuple(p.identifier for p in getattr(obj, name).bl_rna.properties
                               if p.type in ('POINTER', 'COLLECTION') and p.identifier != "rna_type")
    return _HOLDERS[name]


def stored(obj, name):
    """The values of the object's settings group ``name`` as Blender stores them, comparable: its ID property
    group in one call (a property never set is not stored: it is at its default; ``settings_key`` 0.015 -> 0.003
    ms warm, 0.10 -> 0.06 in place after the 1,000-particle character's solve, bpy 5.2: docs/speed.md), the IDs
    it points to as their type and name (no bpy pointer kept across frames). The add-on's properties are apart
    from the custom ones from Blender 5.0."""
    props = obj.bl_system_properties_get() if hasattr(obj, "bl_system_properties_get") else obj
    group = None if props is None else props.get(name)
    if group is None:
        return None
    values = group.to_dict()
    for key in _holders(obj, name):
        if key in values:
            values[key] = _plain(values[key])
    return values


def settings_key(obj, scene):
    """What configuring the engine reads from Blender, as comparable values: the object's OPDeform and contact
    settings (handles included), its mode (where groups are painted) and the scene's rate, gravity and range."""
    render = scene.render
    return (stored(obj, "opdeform"), stored(obj, "opdeform_contact"), obj.mode, render.fps, render.fps_base,
            scene.use_gravity, tuple(scene.gravity), scene.frame_start, scene.frame_end)
