"""One operator per button, all usable from scripts: ``bpy.ops.opdeform.build(object="Suzanne")``.

Every operator takes ``object`` (a name; empty = the active object). Bad input gives an error report and
changes nothing (from a script, bpy.ops raises RuntimeError carrying the report)."""

import bpy
import numpy as np
from bpy.props import BoolProperty, FloatVectorProperty, IntProperty, StringProperty

from ..core import loader
from . import modifier, playback, presets, runtime, state, tumbling_runtime
from .compiled import ADDON_PACKAGE, AddonError, module
from .handle_data import bind_handle
from .mesh_data import check_object
from .modal_bake import ModalBake


class _ObjectOperator:
    object: StringProperty(name="Object", default="", description="Object name; empty: the active object",
                           options={'SKIP_SAVE'})

    def target(self, context):
        if self.object:
            obj = bpy.data.objects.get(self.object)
            if obj is None:
                raise AddonError(f"no object named {self.object!r}")
            return obj
        return context.object

    def execute(self, context):
        try:
            return self.run(context, self.target(context))
        except AddonError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}


class OPDEFORM_OT_enable(_ObjectOperator, bpy.types.Operator):
    """Simulate this mesh with oriented particles (and build its particle graph)"""
    bl_idname = "opdeform.enable"
    bl_label = "Enable Oriented Particles"
    bl_options = {'REGISTER', 'UNDO'}

    build: BoolProperty(name="Build", default=True, description="Build the particle graph now")

    def run(self, context, obj):
        check_object(obj)
        s = obj.opdeform
        if self.build:
            module()
            runtime.build(obj, context.scene)
        goal = s.use_goal
        s.enabled = True  # stamps the settings version: the material's units from here on (presets.stamp)
        if s.use_goal and not goal:
            self.report({'INFO'}, f"{obj.name}: Goal ticked: a mesh deformed by an Armature follows its animation "
                                  "and jiggles around it (the Fleshy look; Physics > Oriented Particles > Goal)")
        if self.build:  # its k now, not on the first frame (a beam's measured k: 0.2 s at 100 particles, 2 s at 1,000)
            runtime.configure(state.get(obj), obj, context.scene)
        return {'FINISHED'}


class OPDEFORM_OT_disable(_ObjectOperator, bpy.types.Operator):
    """Stop simulating this object: its OPDeform modifier goes, the mesh shows its input again (a bake and its
    Mesh Cache modifier stay)"""
    bl_idname = "opdeform.disable"
    bl_label = "Disable Oriented Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj):
        if obj is None:
            raise AddonError("no object")
        s = obj.opdeform
        if obj.type == 'MESH':
            modifier.remove(obj)
        state.drop(obj)
        s.enabled = False
        s.built = False
        s.error = ""
        return {'FINISHED'}


class OPDEFORM_OT_build(_ObjectOperator, bpy.types.Operator):
    """Build the particle graph from the mesh (rest shape, pin group and handles are read now)"""
    bl_idname = "opdeform.build"
    bl_label = "Build"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj):
        check_object(obj)
        t = runtime.build(obj, context.scene)
        obj.opdeform.enabled = True
        g = t.engine.graph
        clamped = " (the mesh has too few vertices for more)" if t.engine.particles_clamped else ""
        self.report({'INFO'}, f"{obj.name}: {g.n_particles} particles{clamped}, {g.n_edges} edges, "
                              f"{t.engine.n_vertices} vertices")
        return {'FINISHED'}


class OPDEFORM_OT_reset(_ObjectOperator, bpy.types.Operator):
    """Clear the error, forget the in-memory cache and show the rest shape"""
    bl_idname = "opdeform.reset"
    bl_label = "Reset"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj):
        if obj is None or obj.type != 'MESH':
            raise AddonError("select a mesh object")
        obj.opdeform.error = ""
        t = state.get(obj)
        if t is not None:
            t.engine.invalidate()
            t.engine.sim.set_state(*t.engine._rest_state)
            runtime.show_rest(obj, t)
        return {'FINISHED'}


class OPDEFORM_OT_solve_pose(_ObjectOperator, bpy.types.Operator):
    """Solve the static ARAP pose for the current handle positions (posing mode)"""
    bl_idname = "opdeform.solve_pose"
    bl_label = "Solve Pose"
    bl_options = {'REGISTER', 'UNDO'}

    iterations: IntProperty(name="Iterations", default=0, min=0,
                            description="0: the object's Pose Iterations setting")

    def run(self, context, obj):
        check_object(obj)
        s = obj.opdeform
        if not s.enabled:
            raise AddonError(f"{obj.name!r}: enable oriented particles first")
        saved = s.pose_iterations
        try:
            if self.iterations:
                s.pose_iterations = self.iterations
            playback.pose_update(obj, context.scene, context.evaluated_depsgraph_get(), force=True)
        finally:
            s.pose_iterations = saved
        return {'FINISHED'}


class OPDEFORM_OT_handle_add(_ObjectOperator, bpy.types.Operator):
    """Add a handle: an empty (new at the 3D cursor, or the one named) bound to the nearest vertex"""
    bl_idname = "opdeform.handle_add"
    bl_label = "Add Handle"
    bl_options = {'REGISTER', 'UNDO'}

    handle: StringProperty(name="Empty", default="", description="An existing empty; empty: create one",
                           options={'SKIP_SAVE'})
    location: FloatVectorProperty(name="Location", size=3, subtype='TRANSLATION',
                                  description="Where a new empty goes (world space)", options={'SKIP_SAVE'})
    use_cursor: BoolProperty(name="At 3D Cursor", default=True, options={'SKIP_SAVE'},
                             description="Put a new empty at the 3D cursor (unless Location is given)")
    use_rotation: BoolProperty(name="Rotation", default=True)

    def run(self, context, obj):
        check_object(obj)
        if self.handle:
            empty = bpy.data.objects.get(self.handle)
            if empty is None or empty.type != 'EMPTY':
                raise AddonError(f"{self.handle!r} is not an empty")
        else:
            loc = tuple(self.location)
            if not self.properties.is_property_set("location") and self.use_cursor:
                loc = tuple(context.scene.cursor.location)
            if not np.all(np.isfinite(loc)):
                raise AddonError("the handle location is not finite")
            empty = bpy.data.objects.new(f"{obj.name} Handle", None)
            empty.empty_display_type = 'ARROWS'
            empty.empty_display_size = max(0.1, 0.25 * max(obj.dimensions))
            empty.location = loc
            (obj.users_collection[0] if obj.users_collection else context.scene.collection).objects.link(empty)
        s = obj.opdeform
        item = s.handles.add()
        item.target = empty
        item.use_rotation = self.use_rotation
        s.handle_index = len(s.handles) - 1
        t = state.get(obj)
        if t is not None:
            try:
                context.view_layer.update()
                bind_handle(item, t.engine.rest)
            except ValueError as exc:
                s.handles.remove(len(s.handles) - 1)
                raise AddonError(str(exc)) from None
        return {'FINISHED'}


class OPDEFORM_OT_handle_remove(_ObjectOperator, bpy.types.Operator):
    """Remove a handle from the list (the empty stays in the scene)"""
    bl_idname = "opdeform.handle_remove"
    bl_label = "Remove Handle"
    bl_options = {'REGISTER', 'UNDO'}

    index: IntProperty(name="Index", default=-1, description="-1: the selected handle")

    def run(self, context, obj):
        if obj is None:
            raise AddonError("no object")
        s = obj.opdeform
        index = s.handle_index if self.index < 0 else self.index
        if not 0 <= index < len(s.handles):
            raise AddonError("no such handle")
        s.handles.remove(index)
        s.handle_index = max(0, min(s.handle_index, len(s.handles) - 1))
        return {'FINISHED'}


class OPDEFORM_OT_bake(ModalBake, _ObjectOperator, bpy.types.Operator):
    """Bake the simulation to a PC2 file and add a Mesh Cache modifier: renders then need neither the add-on
    nor Python. Esc cancels and keeps the frames baked so far"""
    bl_idname = "opdeform.bake"
    bl_label = "Bake"
    bl_options = {'REGISTER', 'UNDO'}

    def _begin(self, context):
        obj = self.target(context)
        check_object(obj)
        return runtime.BakeJob(obj, context.scene)


class OPDEFORM_OT_free_bake(_ObjectOperator, bpy.types.Operator):
    """Remove the Mesh Cache modifier and delete the baked PC2 file; live playback resumes"""
    bl_idname = "opdeform.free_bake"
    bl_label = "Free Bake"
    bl_options = {'REGISTER', 'UNDO'}

    delete_file: BoolProperty(name="Delete File", default=True)

    def run(self, context, obj):
        if obj is None:
            raise AddonError("no object")
        kept = runtime.free_bake(obj, self.delete_file)
        if kept:
            self.report({'WARNING'}, f"kept {kept}: this add-on's bake did not write it")
        return {'FINISHED'}


class OPDEFORM_OT_retry_load(bpy.types.Operator):
    """Try to load the compiled opdeform module again"""
    bl_idname = "opdeform.retry_load"
    bl_label = "Retry Loading opdeform"

    def execute(self, context):
        od, error = loader.load(ADDON_PACKAGE, force=True)
        if od is None:
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        self.report({'INFO'}, f"opdeform {od.__version__} loaded")
        return {'FINISHED'}


class OPDEFORM_OT_apply_preset(bpy.types.Operator):
    """Set stiffness, density, damping and quality from a material preset, or the material and the painted
    regions' softness and damping from a jiggle look"""
    bl_idname = "opdeform.apply_preset"
    bl_label = "Apply Material Preset"
    bl_options = {'REGISTER', 'UNDO'}

    preset: StringProperty(name="Preset", default=presets.DEFAULT_PRESET)
    object: StringProperty(name="Object", default="", options={'SKIP_SAVE'},
                           description="Object name; empty: the active object")

    def execute(self, context):
        obj = bpy.data.objects.get(self.object) if self.object else context.object
        try:
            if obj is None or obj.type != 'MESH':
                raise AddonError("select a mesh object")
            presets.apply_named(obj.opdeform, self.preset)
        except AddonError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        return {'FINISHED'}


# -- tumbling particles ----------------------------------------------------------------------------------
class OPDEFORM_OT_tumbling_enable(_ObjectOperator, bpy.types.Operator):
    """Make this mesh the domain of a tumbling-particle simulation (its bounding box)"""
    bl_idname = "opdeform.tumbling_enable"
    bl_label = "Enable Tumbling Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj):
        if obj is None or obj.type != 'MESH':
            raise AddonError("select a mesh object: its bounding box becomes the domain")
        s = obj.opdeform_tumbling
        s.enabled = True
        s.frame_start, s.frame_end = context.scene.frame_start, context.scene.frame_end
        obj.display_type = 'WIRE'
        return {'FINISHED'}


class OPDEFORM_OT_tumbling_disable(_ObjectOperator, bpy.types.Operator):
    """Stop using this mesh as a tumbling-particle domain (the baked frames stay on disk)"""
    bl_idname = "opdeform.tumbling_disable"
    bl_label = "Disable Tumbling Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj):
        if obj is None:
            raise AddonError("no object")
        obj.opdeform_tumbling.enabled = False
        return {'FINISHED'}


class OPDEFORM_OT_tumbling_bake(ModalBake, _ObjectOperator, bpy.types.Operator):
    """Bake the tumbling particles to one PLY file per frame and show them as instanced flakes. Esc cancels
    and keeps the frames baked so far"""
    bl_idname = "opdeform.tumbling_bake"
    bl_label = "Bake Tumbling Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def _begin(self, context):
        return tumbling_runtime.BakeJob(self.target(context), context.scene)


class OPDEFORM_OT_tumbling_free_bake(_ObjectOperator, bpy.types.Operator):
    """Delete the baked frames and the point cloud"""
    bl_idname = "opdeform.tumbling_free_bake"
    bl_label = "Free Bake"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj):
        if obj is None:
            raise AddonError("no object")
        tumbling_runtime.free_bake(obj)
        return {'FINISHED'}


classes = (OPDEFORM_OT_enable, OPDEFORM_OT_disable, OPDEFORM_OT_build, OPDEFORM_OT_reset,
           OPDEFORM_OT_solve_pose, OPDEFORM_OT_handle_add, OPDEFORM_OT_handle_remove, OPDEFORM_OT_bake,
           OPDEFORM_OT_free_bake, OPDEFORM_OT_retry_load, OPDEFORM_OT_apply_preset,
           OPDEFORM_OT_tumbling_enable, OPDEFORM_OT_tumbling_disable,
           OPDEFORM_OT_tumbling_bake, OPDEFORM_OT_tumbling_free_bake)

# registers in the order of `classes`, unregisters in the reverse order
register, unregister = bpy.utils.register_classes_factory(classes)
