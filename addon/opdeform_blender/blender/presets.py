"""Material presets (Jelly, Flesh, Rubber, Stiff from ``opdeform.materials.PRESETS``) and jiggle looks (Subtle,
Fleshy, Floppy from ``core.settings.LOOKS``): applying one, and which one the settings hold ("Custom" when none: no preset is stored). Their menu and operator are in
settings_panels.py and operators.py. Also what the engine reads from the settings: the Units
(core/settings.py) and the substeps in use; and the stamp that Enable gives an object (versioning.py)."""

from ..core import settings as core_settings
from . import versioning
from .compiled import AddonError, module

DEFAULT_PRESET = "Rubber"


def materials():
    return module().materials


def default_name():
    return materials().DEFAULT_MATERIAL


def apply(s, name, only_unset=False):
    """Sets the preset's stiffness, density, damping and tolerance (material units; only_unset: only the
    settings never set)."""
    for key, value in core_settings.preset_values(materials(), name).items():
        if not (only_unset and s.is_property_set(key)):
            setattr(s, key, value)
    if not only_unset:
        s.use_solver_units = False
        if s.settings_version == core_settings.MATERIAL_UNITS_VERSION:  # today's values: no version-1 factor
            s.settings_version = core_settings.SETTINGS_VERSION


def apply_named(s, name):
    """Applies a material preset or a look by its name; AddonError naming the choices for another name."""
    if name in core_settings.LOOKS:
        apply_look(s, name)
    elif name in materials().PRESETS:
        apply(s, name)
    else:
        raise AddonError(f"no preset {name!r}: one of {', '.join((*materials().PRESETS, *core_settings.LOOKS))}")


def goal_ticked(s):
    """Goal turned on: an object whose material is still the default preset takes the default look (a jiggle
    out of the box); a material chosen by the user stays."""
    try:
        if s.use_goal and s.enabled and current_name(s) == DEFAULT_PRESET:
            apply_look(s, core_settings.DEFAULT_LOOK)
    except AddonError:  # opdeform did not load (the panel says so): the material stays
        pass


def apply_look(s, name):
    """Sets a look of ``core.settings.LOOKS`` (material units)."""
    for key, value in core_settings.LOOKS[name].items():
        setattr(s, key, value)
    s.use_solver_units = False
    if s.settings_version == core_settings.MATERIAL_UNITS_VERSION:
        s.settings_version = core_settings.SETTINGS_VERSION


def current_look(s):
    """The name of the look the settings hold, else "Custom"."""
    for name, values in core_settings.LOOKS.items():
        if not versioning.uses_solver_units(s) and all(
                abs(getattr(s, k) - v) <= 1e-4 * abs(v) for k, v in values.items()):
            return name
    return core_settings.CUSTOM


def current_name(s):
    if versioning.uses_solver_units(s):
        return "Solver Units"
    values = {k: getattr(s, k) for k in ("density", "damping_rate", "tolerance")}
    values["modulus"] = versioning.modulus(s)
    return core_settings.matching_preset(materials(), values)


def substeps(s, fps):
    """The substeps in use: substeps_for(fps) (steps of at most 1/240 s) with Match Frame Rate, else the
    setting."""
    return materials().substeps_for(fps) if s.use_frame_rate_substeps else s.substeps


def units(s, fps):
    return core_settings.Units(versioning.uses_solver_units(s), versioning.modulus(s), s.stiffness, s.density,
                               s.damping_rate, s.damping, s.tolerance, s.max_iterations, s.iterations,
                               substeps(s, fps))


def stamp(s):
    """Enabled now: a new object gets the current version and, unless in solver units, the default preset for
    the settings not set by hand or script (the default look with its Goal on)."""
    if not s.enabled or s.settings_version >= core_settings.SETTINGS_VERSION:
        return
    if s.settings_version >= core_settings.MATERIAL_UNITS_VERSION:  # set up before: only the modulus moves
        s.modulus = versioning.modulus(s)
        versioning.keep_meaning(s)
        return
    if not s.use_solver_units:
        try:
            apply(s, default_name(), only_unset=True)
        except AddonError:  # opdeform did not load (the panel says so): the defaults stay
            pass
        if not s.is_property_set("use_frame_rate_substeps") and not s.is_property_set("substeps"):
            s.use_frame_rate_substeps = True
    if not s.is_property_set("use_goal") and rigged(s.id_data):
        s.use_goal = True  # it rides its animation, as Soft Body's Goal (on by default) would have it
    s.settings_version = core_settings.SETTINGS_VERSION
    goal_ticked(s)


def rigged(obj):
    """Whether an Armature modifier (shown in viewports) deforms the object's mesh."""
    return obj.type == 'MESH' and any(m.type == 'ARMATURE' and m.show_viewport for m in obj.modifiers)
