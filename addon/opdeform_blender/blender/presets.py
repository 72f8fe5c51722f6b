"""Material presets (Jelly, Flesh, Rubber, Stiff from ``opdeform.materials.PRESETS``) as a menu in the panel,
like Cloth's presets: each entry runs ``opdeform.apply_preset``. No preset is stored: the menu's label is the
preset whose values the settings hold, or "Custom". Also what the runtime reads from the settings: the Units
(core/settings.py) and the substeps in use."""

import bpy
from bpy.props import StringProperty

from ..core import settings as core_settings
from . import versioning

DEFAULT_PRESET = "Rubber"


def _materials():
    from . import runtime
    return runtime.module().materials


def default_name():
    return _materials().DEFAULT_MATERIAL


def apply(s, name, only_unset=False):
    """Sets the preset's stiffness, density, damping and tolerance (material units; only_unset: only the
    settings never set)."""
    for key, value in core_settings.preset_values(_materials(), name).items():
        if not (only_unset and s.is_property_set(key)):
            setattr(s, key, value)
    if not only_unset:
        s.use_solver_units = False
        if s.settings_version == core_settings.MATERIAL_UNITS_VERSION:  # today's values: no version-1 factor
            s.settings_version = core_settings.SETTINGS_VERSION


def current_name(s):
    if versioning.uses_solver_units(s):
        return "Solver Units"
    values = {k: getattr(s, k) for k in ("density", "damping_rate", "tolerance")}
    values["modulus"] = versioning.modulus(s)
    return core_settings.matching_preset(_materials(), values)


def substeps(s, fps):
    """The substeps in use: substeps_for(fps) (steps of at most 1/240 s) with Match Frame Rate, else the
    setting."""
    return _materials().substeps_for(fps) if s.use_frame_rate_substeps else s.substeps


def units(s, fps):
    return core_settings.Units(versioning.uses_solver_units(s), versioning.modulus(s), s.stiffness, s.density,
                               s.damping_rate, s.damping, s.tolerance, s.max_iterations, s.iterations,
                               substeps(s, fps))


class OPDEFORM_OT_apply_preset(bpy.types.Operator):
    """Set stiffness, density, damping and quality from a material preset"""
    bl_idname = "opdeform.apply_preset"
    bl_label = "Apply Material Preset"
    bl_options = {'REGISTER', 'UNDO'}

    preset: StringProperty(name="Preset", default=DEFAULT_PRESET)
    object: StringProperty(name="Object", default="", options={'SKIP_SAVE'},
                           description="Object name; empty: the active object")

    def execute(self, context):
        from . import runtime
        obj = bpy.data.objects.get(self.object) if self.object else context.object
        try:
            if obj is None or obj.type != 'MESH':
                raise runtime.AddonError("select a mesh object")
            if self.preset not in _materials().PRESETS:
                raise runtime.AddonError(f"no preset {self.preset!r}: one of {', '.join(_materials().PRESETS)}")
            apply(obj.opdeform, self.preset)
        except runtime.AddonError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        return {'FINISHED'}


class OPDEFORM_MT_material_presets(bpy.types.Menu):
    bl_label = "Material Presets"

    def draw(self, context):
        for name in _materials().PRESETS:
            self.layout.operator("opdeform.apply_preset", text=name).preset = name


classes = (OPDEFORM_OT_apply_preset, OPDEFORM_MT_material_presets)
register, unregister = bpy.utils.register_classes_factory(classes)
