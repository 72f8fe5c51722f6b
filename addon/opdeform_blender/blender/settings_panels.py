"""The panel in the artist's units (issue 14), besides what the Oriented Particles panel draws (panels.py: the
material and the warnings): the material preset menu, the Quality sub-panel (what the solver reached on the
frame shown and the per-frame error plot) and the Advanced sub-panel (solver units: the raw k)."""

import bpy

from . import error_plot, presets, state, versioning
from .panel_base import SubPanel, split


def report_lines(rt, frame, solver_units):
    """The Quality sub-panel's text for the frame shown."""
    rep = rt.engine.report(frame)
    if rep is None:
        return ["No frame simulated yet: play the timeline"]
    error = "fixed iterations" if solver_units or rep.error < 0 else \
        f"error {100 * rep.error:.4f} % of the size"
    return [f"Frame {frame}: {error}", f"{rep.iterations:.1f} iterations a step (most {rep.most})",
            *([] if rep.mesh is None else [f"Largest stretch (mesh edges) {rep.mesh:.2f}x"]),
            f"Largest stretch (particles) {rep.stretch:.2f}x"]


class PHYSICS_PT_opdeform_quality(SubPanel, bpy.types.Panel):
    bl_label = "Quality"

    def draw(self, context):
        layout, obj, s = split(self.layout, context)
        rt = state.get(obj)
        if rt is None:
            layout.label(text="Not built yet", icon='INFO')
            return
        frame = context.scene.frame_current
        col = layout.column(align=True)
        for text in report_lines(rt, frame, versioning.uses_solver_units(s)):
            col.label(text=text)
        if not versioning.uses_solver_units(s):
            p = error_plot.preview(rt, frame, s.tolerance / 100.0)
            layout.template_icon(icon_value=p.icon_id, scale=6.0)
            layout.label(text="Error per frame (log; yellow: the tolerance)")


class PHYSICS_PT_opdeform_advanced(SubPanel, bpy.types.Panel):
    bl_label = "Advanced"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout, obj, s = split(self.layout, context)
        layout.prop(s, "use_solver_units")
        layout.prop(s, "use_physical_scaling")
        col = layout.column()
        col.active = versioning.uses_solver_units(s)
        col.prop(s, "stiffness")
        col.prop(s, "damping", text="Damping/Step")
        col.prop(s, "iterations")


class OPDEFORM_MT_material_presets(bpy.types.Menu):
    bl_label = "Material Presets"

    def draw(self, context):
        for name in presets.materials().PRESETS:
            self.layout.operator("opdeform.apply_preset", text=name).preset = name


classes = (OPDEFORM_MT_material_presets, PHYSICS_PT_opdeform_quality, PHYSICS_PT_opdeform_advanced)
register, unregister = bpy.utils.register_classes_factory(classes)
