"""Settings versions of ``Object.opdeform`` (core/settings.py). Version 2: the modulus calibrated in bending
(a version-1 modulus is tripled on load, keeping the look). Version 3: the goal's follow values (a version-2
goal keeps its mapping and gravity, ``keep_goal``). Version 4: Shell Min (an older object keeps its shells'
painted Follow, ``keep_shells``). Version 5: with a goal the same look at any size (an older object keeps the
physical scaling of free bodies: Physical Scaling on). Version 6: Jiggle (Hz) (an older object whose Jiggle was
never set gets its look's, ``keep_look``). Version 0 (files saved before material units)
keeps its meaning: such an object runs in solver units (its raw k, damping per step and iteration count,
stored or default). On a file load (handlers.on_load_post) every such object is marked so
(``use_solver_units``), which the Advanced sub-panel shows; an object read without a load (appended, linked)
is treated the same way (``uses_solver_units``). Enabling oriented particles on an object stamps the current
version and gives the settings the user has not set the default preset (Rubber) and Match Frame Rate
(``presets.stamp``, above this module: it needs the presets)."""

from ..core import settings as core_settings

OLD_GOAL_STRENGTH = 0.5  # the goal strength's default before version 3


def uses_solver_units(s):
    return s.use_solver_units or s.settings_version < core_settings.MATERIAL_UNITS_VERSION


def modulus(s):
    """The modulus (MPa) in use: an object read from a version-1 file without a load (appended, linked) means
    V1_MODULUS_FACTOR times its stored value, as ``upgrade`` makes it on a load."""
    return core_settings.modulus_now(s.modulus, s.settings_version)


def upgrade(objects):
    """Objects of a file from before material units run in solver units from now on, visibly; version-1
    objects (k from a uniform strain) get the modulus that keeps their look (V1_MODULUS_FACTOR times, so a
    version-1 Rubber is Rubber). Returns what it changed that the user sees, a line per object (printed)."""
    changes = []
    for obj in objects:
        s = getattr(obj, "opdeform", None)
        if s is not None and obj.library is None and s.enabled and \
                s.settings_version < core_settings.SETTINGS_VERSION:
            if s.settings_version < core_settings.MATERIAL_UNITS_VERSION:
                s.use_solver_units = True
            else:
                s.modulus = modulus(s)
            change = keep_meaning(s)
            if change:
                changes.append(f"opdeform: {obj.name}: {change}")
                print(changes[-1])
    return changes


def keep_meaning(s):
    """What an older object's goal (below version 3), detached shells (below version 4) and size (below version
    5) meant stays so, and its look its jiggle (below version 6); the object is stamped with today's version.
    Returns ``keep_look``'s line (None when nothing it tells changed)."""
    if s.settings_version < core_settings.FOLLOW_VERSION:
        keep_goal(s)
    if s.settings_version < core_settings.SHELL_MIN_VERSION:
        keep_shells(s)
    if s.settings_version < core_settings.SIZE_FREE_VERSION:
        s.use_physical_scaling = True  # its modulus acted as modulus x size with a goal too (the "froude" rule)
    change = keep_look(s) if s.settings_version < core_settings.JIGGLE_VERSION else None
    s.settings_version = core_settings.SETTINGS_VERSION
    return change


def keep_goal(s):
    """An object from before version 3 keeps what its goal meant: its strength times the group's weight (Min 0,
    Max the strength) and the scene's full gravity (Sag 1); its strength is stored, whatever the default is
    now."""
    s.goal_strength = s.goal_strength if s.is_property_set("goal_strength") else OLD_GOAL_STRENGTH
    s.goal_min, s.goal_max, s.sag = 0.0, s.goal_strength, 1.0


def keep_shells(s):
    """An object from before version 4 keeps its detached shells' painted Follow (Shell Min 0) unless Shell Min
    was set."""
    if not s.is_property_set("shell_follow_min"):
        s.shell_follow_min = 0.0


def keep_look(s):
    """An object from before version 6 whose Jiggle (Hz) was never set, and whose other values are a look's, gets
    that look's jiggle (saved before the looks set it, it opened with Jiggle 0 and its look read Custom); a Jiggle
    the user set stays, and so does a baked object's (what it simulates past its bake goes on from what it
    baked). Returns a line saying what it set, or None."""
    if s.is_property_set("jiggle_hz") or uses_solver_units(s) or s.baked:
        return None
    name = core_settings.look_but_jiggle({k: getattr(s, k) for k in core_settings.LOOKS[core_settings.DEFAULT_LOOK]})
    if name == core_settings.CUSTOM:
        return None
    s.jiggle_hz = core_settings.LOOKS[name]["jiggle_hz"]
    return f"Jiggle (Hz) {s.jiggle_hz:g}, the {name} look's (the file was saved before the looks set it)"
