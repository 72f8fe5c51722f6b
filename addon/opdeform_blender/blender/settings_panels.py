"""The panel in the artist's units (issue 14): the material preset menu and stiffness, density, damping and
quality (drawn in the Oriented Particles panel), the warnings, the Quality sub-panel (what the solver reached
on the frame shown and the per-frame error plot) and the Advanced sub-panel (solver units: the raw k)."""

import bpy

from ..core import frame_report
from . import presets, versioning
from .panels import _split, _SubPanel, _wrapped


def draw_material(layout, s, context):
    """The preset menu and the material settings of the main panel (material or solver units)."""
    row = layout.row(align=True)
    row.menu("OPDEFORM_MT_material_presets", text=presets.current_name(s))
    col = layout.column()
    if versioning.uses_solver_units(s):
        col.prop(s, "stiffness")
        col.prop(s, "density")
        if s.mode == 'DYNAMIC':
            col.prop(s, "damping")
            col.prop(s, "iterations")
    else:
        col.prop(s, "modulus", text="Stiffness (MPa)")
        col.prop(s, "density")
        if s.mode == 'DYNAMIC':
            col.prop(s, "damping_rate", text="Damping (/s)")
            col.prop(s, "tolerance", text="Quality Tolerance")
            col.prop(s, "max_iterations")
    if s.mode == 'DYNAMIC':
        _draw_substeps(layout.column(), s, context.scene)


def _draw_substeps(col, s, scene):
    from . import runtime
    col.prop(s, "use_frame_rate_substeps")
    if s.use_frame_rate_substeps:
        fps = runtime.frame_rate(scene)
        col.label(text=f"{presets.substeps(s, fps)} substeps at {fps:g} fps", icon='TIME')
    else:
        col.prop(s, "substeps")


def warnings(rt, frame):
    """The panel's warnings for the frame shown (texts)."""
    out = []
    rep = rt.engine.reports.get(frame)
    if rep is not None and rep.stretch > frame_report.STRETCH_LIMIT:
        out.append(f"Stretched {rep.stretch:.1f}x the rest length: raise Stiffness or Substeps")
    if rep is not None and rep.handle_fast:
        out.append(f"A handle moves {100 * rep.handle_step:.0f} % of the body a step: raise Substeps")
    thin = rt.engine.thin_part
    if thin is not None and thin[2]:
        out.append(f"Thinnest part {thin[0]:.3g} m, particles {thin[1]:.3g} m apart: fewer than two across; "
                   "raise Particles")
    if rt.engine.behind:
        out.append(f"Catching up: {rt.engine.behind:,} frames to go (Esc stops)")
    return out


def draw_warnings(layout, obj, scene):
    from . import runtime
    rt = runtime.get(obj)
    if rt is None:
        return
    for text in warnings(rt, scene.frame_current):
        _wrapped(layout, text, 'ERROR')


def report_lines(rt, frame, solver_units):
    """The Quality sub-panel's text for the frame shown."""
    rep = rt.engine.reports.get(frame)
    if rep is None:
        return ["No frame simulated yet: play the timeline"]
    error = "fixed iterations" if solver_units or rep.error < 0 else \
        f"error {100 * rep.error:.4f} % of the size"
    return [f"Frame {frame}: {error}", f"{rep.iterations:.1f} iterations a step (most {rep.most})",
            f"Largest stretch {rep.stretch:.2f}x"]


class PHYSICS_PT_opdeform_quality(_SubPanel, bpy.types.Panel):
    bl_label = "Quality"

    def draw(self, context):
        from . import error_plot, runtime
        layout, obj, s = _split(self.layout, context)
        rt = runtime.get(obj)
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


class PHYSICS_PT_opdeform_advanced(_SubPanel, bpy.types.Panel):
    bl_label = "Advanced"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout, obj, s = _split(self.layout, context)
        layout.prop(s, "use_solver_units")
        col = layout.column()
        col.active = versioning.uses_solver_units(s)
        col.prop(s, "stiffness")
        col.prop(s, "damping")
        col.prop(s, "iterations")


classes = (PHYSICS_PT_opdeform_quality, PHYSICS_PT_opdeform_advanced)
register, unregister = bpy.utils.register_classes_factory(classes)
