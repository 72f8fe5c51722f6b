"""What both Bake buttons (operators.py) share: the modal bake with its progress bar and Esc, or a blocking one
from scripts and in background mode."""

import bpy

from .compiled import AddonError


class ModalBake:
    """What both Bake buttons share: a bake job (``step()``, ``done``, ``frame``, ``start``, ``total``,
    ``obj_name``, ``path``, ``finish()``) run blocking from scripts and in background mode, else modal with a
    progress bar and Esc, which keeps the frames baked so far. The operator gives ``_begin(context)``, which
    makes the job. A mixin, never registered itself: Blender loses the Python class of a registered operator
    that another one subclasses."""

    _job = None
    _timer = None

    def execute(self, context):
        """Blocking (background mode, scripts)."""
        try:
            job = self._begin(context)
        except AddonError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        try:
            while not job.done:
                job.step()
                if job.frame % 10 == 0 or job.done:
                    print(f"opdeform: baking {job.obj_name}: frame {job.frame - 1} "
                          f"({job.frame - job.start}/{job.total})")
        except AddonError as exc:
            job.finish()
            self.report({'ERROR'}, f"bake stopped at frame {job.frame}: {exc}")
            return {'CANCELLED'}
        count = job.finish()
        self.report({'INFO'}, f"baked {count} frames of {job.obj_name} to {job.path}")
        return {'FINISHED'}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        try:
            self._job = self._begin(context)
        except AddonError as exc:
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
        job = self._job
        if event.type == 'ESC':
            count = job.finish()
            self._end(context, f"bake cancelled: kept {count} frames", 'WARNING')
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'}
        try:
            job.step()
        except AddonError as exc:
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
