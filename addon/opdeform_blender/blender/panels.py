"""The Physics tab panels "Oriented Particles" (the material in the artist's units and the warnings, then its
sub-panels) and "Tumbling Particles", laid out like Blender's Soft Body and Cloth panels. More sub-panels of
"Oriented Particles": settings_panels.py (Quality, Advanced) and collider_panels.py (Collisions, Field
Weights), registered after this module (a sub-panel needs its parent)."""

import os

import bpy

from ..core import checks, frame_report, loader
from ..core.settings import LOOKS
from . import modifier, presets, runtime, state, versioning
from .compiled import ADDON_PACKAGE
from .panel_base import PhysicsPanel, SubPanel, ToggledSubPanel, split, wrapped
from .parameters import frame_rate, graph_key, settings_key


def draw_material(layout, s, context):
    """The preset menu and the material settings of the main panel (material or solver units)."""
    row = layout.row(align=True)
    row.menu("OPDEFORM_MT_material_presets", text=presets.current_name(s))
    col = layout.column()
    if versioning.uses_solver_units(s):
        col.prop(s, "stiffness")
        col.prop(s, "density")
        if s.mode == 'DYNAMIC':
            col.prop(s, "damping", text="Damping/Step")
            col.prop(s, "iterations")
    else:
        col.prop(s, "modulus", text="Stiffness MPa")
        col.prop(s, "density")
        if s.mode == 'DYNAMIC':
            col.prop(s, "damping_rate", text="Damping (/s)")
            col.prop(s, "tolerance", text="Tolerance")
            col.prop(s, "max_iterations", text="Max Iter.")
    if s.mode == 'DYNAMIC':
        _draw_substeps(layout.column(), s, context.scene)


def _draw_substeps(col, s, scene):
    col.prop(s, "use_frame_rate_substeps", text="Match FPS")
    if s.use_frame_rate_substeps:
        fps = frame_rate(scene)
        col.label(text=f"{presets.substeps(s, fps)} substeps at {fps:g} fps", icon='TIME')
    else:
        col.prop(s, "substeps")


def length_text(scene):
    """A function writing a length in Blender units as the scene's Properties show lengths: its unit system and
    Unit Scale (a character modelled in centimetres, Unit Scale 0.01, reads "1.04 cm", not "1.04 m")."""
    units = scene.unit_settings
    if units.system == 'NONE':
        return lambda x: f"{x:.3g}"
    return lambda x: bpy.utils.units.to_string(units.system, 'LENGTH', x * units.scale_length, precision=3)


def warnings(rt, frame, current=True):
    """The panel's warnings for the frame shown (texts). current=False: the settings changed since the engine was
    last configured (a Follow group just picked is read on the next frame), so what depends on them is left out
    until then rather than shown for the old ones."""
    out = []
    rep = rt.engine.report(frame)
    stretch = frame_report.shown_stretch(rep)
    if stretch > frame_report.STRETCH_LIMIT:
        out.append(f"{'Mesh edges' if rep.mesh is not None else 'Particles'} stretched {stretch:.1f}x the rest "
                   "length: raise Stiffness or Substeps")
    if rep is not None and rep.handle_fast:
        out.append(f"A handle moves {100 * rep.handle_step:.0f} % of the body a step: raise Substeps")
    turn = checks.turn_text(rep.turn, frame_rate(bpy.context.scene)) if rep is not None else None
    if turn:
        out.append(turn)
    length = length_text(bpy.context.scene)
    thin = checks.thin_part_text(rt.engine.thin_part, rt.engine.graph.n_particles, length)
    if thin:
        out.append(thin)
    appendages = checks.appendages_text(rt.engine.thin_appendages, rt.engine.graph.n_particles, length)
    if appendages:
        out.append(appendages)
    unrigged = checks.unrigged_text(rt.unrigged)
    if unrigged:
        out.append(unrigged)
    attached = checks.attached_text(rt.attached, rt.attached_enough)
    if attached:
        out.append(attached)
    overlaps = checks.overlap_text(rt.overlaps)
    if overlaps:
        out.append(overlaps)
    hanging = current and rt.pieces is not None and checks.hanging_text(
        checks.hanging_pieces(rt.pieces, rt.engine.follow, rt.engine.rest_local, rt.engine.pieces()[2]))
    if hanging:
        out.append(hanging)
    if rt.engine.behind:
        out.append(f"Catching up: {rt.engine.behind:,} frames to go (Esc stops)")
    return out


def draw_warnings(layout, obj, scene):
    rt = state.get(obj)
    if rt is None:
        return
    current = rt.configured is not None and rt.configured[0] == settings_key(obj, scene)
    for text in warnings(rt, scene.frame_current, current) + _undamped(obj.opdeform):
        wrapped(layout, text, 'ERROR')


def _undamped(s):
    """The Goal's damping warning (checks.undamped_goal_text) in a list; none in Solver Units (damping per step)."""
    if versioning.uses_solver_units(s):
        return []
    text = checks.undamped_goal_text(s.use_goal, s.damping_rate, s.region_damping if s.damping_group else None)
    return [text] if text else []


def _cache_settings(layout, s, scene=None):
    """The frame range and folder of a bake (deformation settings, with the scene: Scene Range; tumbling)."""
    col = layout.column(align=True)
    if scene is not None:
        col.prop(s, "use_scene_range")
    if scene is not None and s.use_scene_range:
        col.label(text=f"Frames {scene.frame_start} - {scene.frame_end} (the scene's)")
    else:
        col.prop(s, "frame_start", text="Start")
        col.prop(s, "frame_end", text="End")
    layout.prop(s, "cache_directory")


def _bake_buttons(layout, bake, free):
    row = layout.row(align=True)
    row.operator(bake, icon='REC')
    row.operator(free, icon='TRASH')


class PHYSICS_PT_opdeform(PhysicsPanel, bpy.types.Panel):
    bl_label = "Oriented Particles"

    def draw(self, context):
        layout = self.layout
        obj = context.object
        s = obj.opdeform
        od, error = loader.load(ADDON_PACKAGE)
        if od is None:
            box = layout.box()
            box.alert = True
            wrapped(box, error, 'ERROR')
            box.operator("opdeform.retry_load", icon='FILE_REFRESH')
            return
        if not s.enabled:
            layout.operator("opdeform.enable", icon='PHYSICS')
            return
        row = layout.row()
        row.prop(s, "mode", expand=True)
        row.operator("opdeform.disable", text="", icon='X')
        if s.error:
            box = layout.box()
            box.alert = True
            wrapped(box, s.error, 'ERROR')
            box.operator("opdeform.reset", icon='LOOP_BACK')
        layout.use_property_split = True
        layout.use_property_decorate = False
        draw_material(layout, s, context)
        draw_warnings(layout, obj, context.scene)
        col = layout.column()
        if s.mode == 'DYNAMIC':
            wrapped(col, gravity_text(context.scene, s), 'FORCE_FORCE')
        else:
            col.prop(s, "pose_iterations")
            col.prop(s, "pose_gravity")
            col.operator("opdeform.solve_pose", icon='ARMATURE_DATA')


def gravity_text(scene, s):
    """The scene's gravity, and with Goal how much of it Sag lets pull the flesh off its animation (an outside
    tester read "Gravity 0, 0, -9.81" as the flesh sagging at Sag 0)."""
    if not scene.use_gravity:
        return "Gravity off (scene)"
    text = "Gravity %.3g, %.3g, %.3g" % tuple(scene.gravity)
    if s.use_goal:
        text += f"; Sag {s.sag:.0%} of it pulls the flesh off the animation (Goal)"
    return text


class PHYSICS_PT_opdeform_graph(SubPanel, bpy.types.Panel):
    bl_label = "Particles"

    def draw(self, context):
        layout, obj, s = split(self.layout, context)
        col = layout.column()
        col.prop(s, "particles")
        col.prop(s, "graph_mode")
        col.prop(s, "neighbors", text="Neighbors")
        rt = state.get(obj)
        row = layout.row()
        if rt is not None and rt.graph_key != graph_key(s):
            row.alert = True
            row.operator("opdeform.build", text="Build (settings changed)", icon='FILE_REFRESH')
        else:
            row.operator("opdeform.build", icon='FILE_REFRESH')
        if rt is not None:
            g = rt.engine.graph
            col = layout.column(align=True)
            for k, line in enumerate(checks.particles_text(g.n_particles, g.n_edges, rt.engine.pieces())):
                col.label(text=line, icon='BLANK1' if k else 'INFO')
            col.label(text=f"{rt.engine.n_vertices} vertices skinned", icon='BLANK1')
        elif s.built:
            layout.label(text="Built: rebuilt on the next frame", icon='INFO')
        col = layout.column(heading="Overlay", align=True)
        col.prop(s, "show_particles", text="Ellipsoids")
        sub = col.row()
        sub.active = s.show_particles
        sub.prop(s, "show_edges")


class PHYSICS_PT_opdeform_floor(ToggledSubPanel, bpy.types.Panel):
    bl_label = "Floor"
    bl_options = {'DEFAULT_CLOSED'}
    toggle = "use_floor"

    def draw(self, context):
        layout, _, s = self.body(context)
        layout.prop(s, "floor_height")
        layout.prop(s, "floor_friction")


class PHYSICS_PT_opdeform_pins(SubPanel, bpy.types.Panel):
    bl_label = "Pins"

    def draw(self, context):
        layout, obj, s = split(self.layout, context)
        layout.prop_search(s, "pin_group", obj, "vertex_groups", text="Pin Group")
        layout.prop(s, "pin_strength", text="Strength")
        if s.pin_group:
            soft = "" if s.use_goal and s.goal_group else "; for a soft hold paint a Follow Group (Goal)"
            wrapped(layout, "Pins hold firmly at any weight" + soft, 'INFO')


class OPDEFORM_MT_looks(bpy.types.Menu):
    bl_label = "Jiggle Looks"

    def draw(self, context):
        for name in LOOKS:
            self.layout.operator("opdeform.apply_preset", text=name).preset = name


class PHYSICS_PT_opdeform_goal(ToggledSubPanel, bpy.types.Panel):
    bl_label = "Goal"
    toggle = "use_goal"

    def draw(self, context):
        layout, obj, s = self.body(context)
        layout.menu("OPDEFORM_MT_looks", text=f"Look: {presets.current_look(s)}")
        layout.prop_search(s, "goal_group", obj, "vertex_groups", text="Follow")
        col = layout.column(align=True)
        if s.goal_group:
            col.prop(s, "goal_min", text="Follow Min")
            col.prop(s, "goal_max", text="Max")
            col.prop(s, "shell_follow_min")
        else:
            col.prop(s, "goal_strength")
        layout.prop(s, "sag")
        mod = modifier.get(obj)
        if mod is None:
            layout.label(text="The OPDeform modifier is missing: Build adds it", icon='ERROR')
        else:
            wrapped(layout, f"Follows the stack above OPDeform (modifier {modifier.index(obj) + 1} of "
                            f"{len(obj.modifiers)})", 'MODIFIER')


class PHYSICS_PT_opdeform_regions(SubPanel, bpy.types.Panel):
    bl_label = "Regions"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout, obj, s = split(self.layout, context)
        layout.prop_search(s, "softness_group", obj, "vertex_groups", text="Softness")
        row = layout.row()
        row.active = bool(s.softness_group)
        row.prop(s, "soft_stiffness", text="Stiffness")
        row = layout.row()
        row.active = not s.softness_group and bool(s.goal_group)
        row.prop(s, "jiggle_hz", text="Jiggle (Hz)")
        layout.prop_search(s, "damping_group", obj, "vertex_groups", text="Damping")
        row = layout.row()
        row.active = bool(s.damping_group)
        row.prop(s, "region_damping", text="Rate (/s)")


class OPDEFORM_UL_handles(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        split = layout.split(factor=0.6, align=True)  # the target's name whole at the factory width
        split.prop(item, "target", text="", icon='EMPTY_AXIS')
        row = split.row(align=True)
        row.prop(item, "use_rotation", text="", icon='ORIENTATION_GIMBAL')
        row.prop(item, "strength", text="")


class PHYSICS_PT_opdeform_handles(SubPanel, bpy.types.Panel):
    bl_label = "Handles"

    def draw(self, context):
        obj = context.object
        s = obj.opdeform
        row = self.layout.row()
        row.template_list("OPDEFORM_UL_handles", "", s, "handles", s, "handle_index", rows=3)
        col = row.column(align=True)
        col.operator("opdeform.handle_add", text="", icon='ADD')
        col.operator("opdeform.handle_remove", text="", icon='REMOVE')
        if 0 <= s.handle_index < len(s.handles):
            h = s.handles[s.handle_index]
            if h.target is not None and h.vertex >= 0:
                self.layout.label(text=f"Bound to vertex {h.vertex}", icon='VERTEXSEL')


class PHYSICS_PT_opdeform_cache(SubPanel, bpy.types.Panel):
    bl_label = "Cache"

    def draw(self, context):
        layout, obj, s = split(self.layout, context)
        _cache_settings(layout, s, context.scene)
        rt = state.get(obj)
        if rt is not None:
            layout.label(text=f"In memory: {len(rt.engine.cache)} frames", icon='MEMORY')
        _bake_buttons(layout, "opdeform.bake", "opdeform.free_bake")
        if s.baked:
            mod = runtime.cache_modifier(obj)
            layout.label(text=f"Baked: {s.bake_file}", icon='CHECKMARK' if mod else 'ERROR')
            if mod is None:
                layout.label(text="The Mesh Cache modifier was removed", icon='ERROR')
            elif not os.path.isfile(bpy.path.abspath(mod.filepath)):
                wrapped(layout, f"The baked file is missing ({mod.filepath}): the input shows without the "
                        "simulation; Free Bake and bake again, or copy the file back", 'ERROR')
            if runtime.bake_outdated(obj, context.scene):
                row = layout.row()
                row.alert = True
                row.label(text="Cache outdated: settings changed since the bake", icon='ERROR')


WIND_SETTINGS = ("wind_velocity", "wind_amplitude", "wind_wavelength", "wind_octaves", "wind_persistence",
                 "wind_drift", "wind_drag", "wind_exponent")


def _tumbling_columns(s):
    """(heading, settings) of the Tumbling Particles panel's columns, for the settings' current choices."""
    emitter = ("emitter_object",) if s.emitter == 'VOLUME' else ("count", "layer_height", "layer_thickness")
    floor = ("floor_height", "floor_friction") if s.use_floor else ()
    return (("", ("dx", "spin", "material", "density", "young_modulus", "poisson_ratio")),
            ("Emitter", ("emitter", *emitter, "spacing", "seed")),
            ("Wind", ("wind", *(WIND_SETTINGS if s.wind != "off" else ()))),
            ("Colliders", ("use_floor", *floor, "colliders", "collider_contact", "collider_friction")),
            ("Display", ("instance_object", "flake_size")))


class PHYSICS_PT_opdeform_tumbling(PhysicsPanel, bpy.types.Panel):
    bl_label = "Tumbling Particles"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = self.layout
        s = context.object.opdeform_tumbling
        if not s.enabled:
            layout.operator("opdeform.tumbling_enable", icon='MOD_PARTICLES')
            return
        row = layout.row()
        row.label(text="Domain: this object's bounding box", icon='MESH_CUBE')
        row.operator("opdeform.tumbling_disable", text="", icon='X')
        if s.error:
            box = layout.box()
            box.alert = True
            wrapped(box, s.error, 'ERROR')
        layout.use_property_split = True
        layout.use_property_decorate = False
        for heading, names in _tumbling_columns(s):
            col = layout.column(heading=heading)
            for name in names:
                col.prop(s, name)
        _cache_settings(layout, s)
        _bake_buttons(layout, "opdeform.tumbling_bake", "opdeform.tumbling_free_bake")
        if s.baked:
            layout.label(text=f"Baked to {s.baked_folder}", icon='CHECKMARK')


classes = (PHYSICS_PT_opdeform, PHYSICS_PT_opdeform_graph, PHYSICS_PT_opdeform_floor, PHYSICS_PT_opdeform_pins,
           OPDEFORM_MT_looks, PHYSICS_PT_opdeform_goal, PHYSICS_PT_opdeform_regions, OPDEFORM_UL_handles, PHYSICS_PT_opdeform_handles, PHYSICS_PT_opdeform_cache, PHYSICS_PT_opdeform_tumbling)

# registers in the order of `classes`, unregisters in the reverse order
register, unregister = bpy.utils.register_classes_factory(classes)
