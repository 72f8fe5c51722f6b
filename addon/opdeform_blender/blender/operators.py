"""One operator per button, all usable from scripts: ``bpy.ops.opdeform.build(object="Suzanne")``.

Every operator takes ``object`` (a name; empty = the active object). Bad input gives an error report and
changes nothing (from a script, bpy.ops raises RuntimeError carrying the report)."""

import bpy
from bpy.props import BoolProperty, FloatVectorProperty, IntProperty, StringProperty

from ..core import loader


def _runtime():
    from . import runtime
    return runtime


class _ObjectOperator:
    object: StringProperty(name="Object", default="", description="Object name; empty: the active object",
                           options={'SKIP_SAVE'})

    def target(self, context):
        if self.object:
            obj = bpy.data.objects.get(self.object)
            if obj is None:
                raise _runtime().AddonError(f"no object named {self.object!r}")
            return obj
        return context.object

    def execute(self, context):
        rt = _runtime()
        try:
            return self.run(context, self.target(context), rt)
        except rt.AddonError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}


class OPDEFORM_OT_enable(_ObjectOperator, bpy.types.Operator):
    """Simulate this mesh with oriented particles (and build its particle graph)"""
    bl_idname = "opdeform.enable"
    bl_label = "Enable Oriented Particles"
    bl_options = {'REGISTER', 'UNDO'}

    build: BoolProperty(name="Build", default=True, description="Build the particle graph now")

    def run(self, context, obj, rt):
        rt.check_object(obj)
        s = obj.opdeform
        if self.build:
            rt.module()
            rt.build(obj, context.scene)
        s.enabled = True  # stamps the settings version: the material's units from here on (versioning.stamp)
        if self.build:  # its k now, not on the first frame (a beam's measured k: 0.2 s at 100 particles, 2 s at 1,000)
            rt.configure(rt.get(obj), obj, context.scene)
        return {'FINISHED'}


class OPDEFORM_OT_disable(_ObjectOperator, bpy.types.Operator):
    """Stop simulating this object: its OPDeform modifier goes, the mesh shows its input again (a bake and its
    Mesh Cache modifier stay)"""
    bl_idname = "opdeform.disable"
    bl_label = "Disable Oriented Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj, rt):
        if obj is None:
            raise rt.AddonError("no object")
        s = obj.opdeform
        if obj.type == 'MESH':
            rt.modifier.remove(obj)
        rt.drop(obj)
        s.enabled = False
        s.built = False
        s.error = ""
        return {'FINISHED'}


class OPDEFORM_OT_build(_ObjectOperator, bpy.types.Operator):
    """Build the particle graph from the mesh (rest shape, pin group and handles are read now)"""
    bl_idname = "opdeform.build"
    bl_label = "Build"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj, rt):
        rt.check_object(obj)
        t = rt.build(obj, context.scene)
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

    def run(self, context, obj, rt):
        if obj is None or obj.type != 'MESH':
            raise rt.AddonError("select a mesh object")
        obj.opdeform.error = ""
        t = rt.get(obj)
        if t is not None:
            t.engine.invalidate()
            t.engine.sim.set_state(*t.engine._rest_state)
            rt.show_rest(obj, t)
        return {'FINISHED'}


class OPDEFORM_OT_solve_pose(_ObjectOperator, bpy.types.Operator):
    """Solve the static ARAP pose for the current handle positions (posing mode)"""
    bl_idname = "opdeform.solve_pose"
    bl_label = "Solve Pose"
    bl_options = {'REGISTER', 'UNDO'}

    iterations: IntProperty(name="Iterations", default=0, min=0,
                            description="0: the object's Pose Iterations setting")

    def run(self, context, obj, rt):
        rt.check_object(obj)
        s = obj.opdeform
        if not s.enabled:
            raise rt.AddonError(f"{obj.name!r}: enable oriented particles first")
        saved = s.pose_iterations
        try:
            if self.iterations:
                s.pose_iterations = self.iterations
            rt.pose_update(obj, context.scene, context.evaluated_depsgraph_get(), force=True)
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

    def run(self, context, obj, rt):
        import numpy as np
        rt.check_object(obj)
        if self.handle:
            empty = bpy.data.objects.get(self.handle)
            if empty is None or empty.type != 'EMPTY':
                raise rt.AddonError(f"{self.handle!r} is not an empty")
        else:
            loc = tuple(self.location)
            if not self.properties.is_property_set("location") and self.use_cursor:
                loc = tuple(context.scene.cursor.location)
            if not np.all(np.isfinite(loc)):
                raise rt.AddonError("the handle location is not finite")
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
        t = rt.get(obj)
        if t is not None:
            try:
                context.view_layer.update()
                rt.bind_handle(item, t.engine.rest)
            except ValueError as exc:
                s.handles.remove(len(s.handles) - 1)
                raise rt.AddonError(str(exc)) from None
        return {'FINISHED'}


class OPDEFORM_OT_handle_remove(_ObjectOperator, bpy.types.Operator):
    """Remove a handle from the list (the empty stays in the scene)"""
    bl_idname = "opdeform.handle_remove"
    bl_label = "Remove Handle"
    bl_options = {'REGISTER', 'UNDO'}

    index: IntProperty(name="Index", default=-1, description="-1: the selected handle")

    def run(self, context, obj, rt):
        if obj is None:
            raise rt.AddonError("no object")
        s = obj.opdeform
        index = s.handle_index if self.index < 0 else self.index
        if not 0 <= index < len(s.handles):
            raise rt.AddonError("no such handle")
        s.handles.remove(index)
        s.handle_index = max(0, min(s.handle_index, len(s.handles) - 1))
        return {'FINISHED'}


class _ModalBake:
    """What both Bake buttons share: a bake job (``step()``, ``done``, ``frame``, ``start``, ``total``,
    ``obj_name``, ``path``, ``finish()``) run blocking from scripts and in background mode, else modal with a
    progress bar and Esc, which keeps the frames baked so far. The operator gives ``_begin(context)``, which
    makes the job. A mixin, never registered itself: Blender loses the Python class of a registered operator
    that another one subclasses."""

    _job = None
    _timer = None

    def execute(self, context):
        """Blocking (background mode, scripts)."""
        rt = _runtime()
        try:
            job = self._begin(context)
        except rt.AddonError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        try:
            while not job.done:
                job.step()
                if job.frame % 10 == 0 or job.done:
                    print(f"opdeform: baking {job.obj_name}: frame {job.frame - 1} "
                          f"({job.frame - job.start}/{job.total})")
        except rt.AddonError as exc:
            job.finish()
            self.report({'ERROR'}, f"bake stopped at frame {job.frame}: {exc}")
            return {'CANCELLED'}
        count = job.finish()
        self.report({'INFO'}, f"baked {count} frames of {job.obj_name} to {job.path}")
        return {'FINISHED'}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        rt = _runtime()
        try:
            self._job = self._begin(context)
        except rt.AddonError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        wm = context.window_manager
        wm.progress_begin(0, self._job.total)
        self._timer = wm.event_timer_add(0.001, window=context.window)
        wm.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def _end(self, context, message, level):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        self.report({level}, message)

    def modal(self, context, event):
        rt = _runtime()
        job = self._job
        if event.type == 'ESC':
            count = job.finish()
            self._end(context, f"bake cancelled: kept {count} frames", 'WARNING')
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'}
        try:
            job.step()
        except rt.AddonError as exc:
            job.finish()
            self._end(context, f"bake stopped at frame {job.frame}: {exc}", 'ERROR')
            return {'CANCELLED'}
        done = job.frame - job.start
        context.window_manager.progress_update(done)
        if context.workspace is not None:
            context.workspace.status_text_set(f"Baking {job.obj_name}: frame {job.frame - 1} "
                                              f"({done}/{job.total}), Esc to cancel")
        if job.done:
            count = job.finish()
            self._end(context, f"baked {count} frames to {job.path}", 'INFO')
            return {'FINISHED'}
        return {'RUNNING_MODAL'}


class OPDEFORM_OT_bake(_ModalBake, _ObjectOperator, bpy.types.Operator):
    """Bake the simulation to a PC2 file and add a Mesh Cache modifier: renders then need neither the add-on
    nor Python. Esc cancels and keeps the frames baked so far"""
    bl_idname = "opdeform.bake"
    bl_label = "Bake"
    bl_options = {'REGISTER', 'UNDO'}

    def _begin(self, context):
        rt = _runtime()
        obj = self.target(context)
        rt.check_object(obj)
        return rt.BakeJob(obj, context.scene)


class OPDEFORM_OT_free_bake(_ObjectOperator, bpy.types.Operator):
    """Remove the Mesh Cache modifier and delete the baked PC2 file; live playback resumes"""
    bl_idname = "opdeform.free_bake"
    bl_label = "Free Bake"
    bl_options = {'REGISTER', 'UNDO'}

    delete_file: BoolProperty(name="Delete File", default=True)

    def run(self, context, obj, rt):
        if obj is None:
            raise rt.AddonError("no object")
        kept = rt.free_bake(obj, self.delete_file)
        if kept:
            self.report({'WARNING'}, f"kept {kept}: this add-on's bake did not write it")
        return {'FINISHED'}


class OPDEFORM_OT_retry_load(bpy.types.Operator):
    """Try to load the compiled opdeform module again"""
    bl_idname = "opdeform.retry_load"
    bl_label = "Retry Loading opdeform"

    def execute(self, context):
        from .. import ADDON_PACKAGE
        od, error = loader.load(ADDON_PACKAGE, force=True)
        if od is None:
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        self.report({'INFO'}, f"opdeform {od.__version__} loaded")
        return {'FINISHED'}


# -- tumbling particles ----------------------------------------------------------------------------------
class OPDEFORM_OT_tumbling_enable(_ObjectOperator, bpy.types.Operator):
    """Make this mesh the domain of a tumbling-particle simulation (its bounding box)"""
    bl_idname = "opdeform.tumbling_enable"
    bl_label = "Enable Tumbling Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj, rt):
        if obj is None or obj.type != 'MESH':
            raise rt.AddonError("select a mesh object: its bounding box becomes the domain")
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

    def run(self, context, obj, rt):
        if obj is None:
            raise rt.AddonError("no object")
        obj.opdeform_tumbling.enabled = False
        return {'FINISHED'}


class OPDEFORM_OT_tumbling_bake(_ModalBake, _ObjectOperator, bpy.types.Operator):
    """Bake the tumbling particles to one PLY file per frame and show them as instanced flakes. Esc cancels
    and keeps the frames baked so far"""
    bl_idname = "opdeform.tumbling_bake"
    bl_label = "Bake Tumbling Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def _begin(self, context):
        from . import tumbling_runtime
        return tumbling_runtime.BakeJob(self.target(context), context.scene)


class OPDEFORM_OT_tumbling_free_bake(_ObjectOperator, bpy.types.Operator):
    """Delete the baked frames and the point cloud"""
    bl_idname = "opdeform.tumbling_free_bake"
    bl_label = "Free Bake"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj, rt):
        from . import tumbling_runtime
        if obj is None:
            raise rt.AddonError("no object")
        tumbling_runtime.free_bake(obj)
        return {'FINISHED'}


classes = (OPDEFORM_OT_enable, OPDEFORM_OT_disable, OPDEFORM_OT_build, OPDEFORM_OT_reset,
           OPDEFORM_OT_solve_pose, OPDEFORM_OT_handle_add, OPDEFORM_OT_handle_remove, OPDEFORM_OT_bake,
           OPDEFORM_OT_free_bake, OPDEFORM_OT_retry_load, OPDEFORM_OT_tumbling_enable, OPDEFORM_OT_tumbling_disable,
           OPDEFORM_OT_tumbling_bake, OPDEFORM_OT_tumbling_free_bake)

# registers in the order of `classes`, unregisters in the reverse order
register, unregister = bpy.utils.register_classes_factory(classes)
