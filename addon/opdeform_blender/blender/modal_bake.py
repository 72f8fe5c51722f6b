"""What both Bake buttons (operators.py) share: the modal bake with its progress bar and Esc, or a blocking one
from scripts and in background mode.

A bake ends one of two ways. It finishes (every frame, or Esc: the user keeps the frames baked so far), and its
file replaces the last bake. Or it stops: a file is loaded (handlers.on_load_pre, before Blender drops the
operator), the object is deleted or its mesh changes under it, the simulation or the file fails, or Blender
cancels the operator; then ``job.abort`` removes the partial file (the add-on has no resume: a bake always
starts at its first frame), the last good bake stays, and the object's error says why it stopped."""

import bpy

from .compiled import AddonError

_running = []  # the jobs of the modal bakes under way (stop_all stops them)


def stop_all(reason):
    """Stops every modal bake under way (handlers.on_load_pre: the file they bake is being left)."""
    for job in list(_running):
        stop(job, reason)


def stop(job, reason):
    """Stops a bake without its frames; returns the message the object shows (see the module's note)."""
    if job in _running:
        _running.remove(job)
    message = f"bake stopped at frame {job.frame}: {reason}"
    job.abort(message)
    print(f"opdeform: {job.obj_name}: {message}")
    return message


def why(exc):
    """An exception as the reason a bake stopped (its type named unless it is a message for the user)."""
    return str(exc) if isinstance(exc, (AddonError, OSError)) else f"{type(exc).__name__}: {exc}"


class ModalBake:
    """What both Bake buttons share: a bake job (``step()``, ``done``, ``frame``, ``start``, ``total``,
    ``obj_name``, ``path``, ``finish()``, ``abort(message)``) run blocking from scripts and in background mode,
    else modal with a progress bar and Esc, which keeps the frames baked so far. The operator gives
    ``_begin(context)``, which makes the job. A mixin, never registered itself: Blender loses the Python class
    of a registered operator that another one subclasses."""

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
        except Exception as exc:  # noqa: BLE001 - any failure stops the bake without its partial file
            self.report({'ERROR'}, stop(job, why(exc)))
            return {'CANCELLED'}
        count = job.finish()
        self.report({'INFO'}, f"baked {count} frames of {job.obj_name} to {job.path}")
        return {'FINISHED'}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        return self.start_modal(context)

    def start_modal(self, context):
        """Makes the job and hands it to the window manager: its timer events step it (modal())."""
        try:
            self._job = self._begin(context)
        except AddonError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        _running.append(self._job)
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

    def _stop(self, context, reason):
        self._end(context, stop(self._job, reason), 'ERROR')
        return {'CANCELLED'}

    def _stopped_by_load(self, context):
        """stop_all stopped the job (a file load; Blender then drops the operator, or the load failed)."""
        self._end(context, f"bake of {self._job.obj_name} stopped: a file was loaded", 'ERROR')
        return {'CANCELLED'}

    def modal(self, context, event):
        job = self._job
        if job not in _running:  # a file load that then failed: the operator lives on
            return self._stopped_by_load(context)
        if event.type == 'ESC':
            _running.remove(job)
            count = job.finish()
            self._end(context, f"bake cancelled: kept {count} frames", 'WARNING')
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'}
        try:
            job.step()
        except Exception as exc:  # noqa: BLE001 - any failure stops the bake without its partial file
            return self._stop(context, why(exc))
        done = job.frame - job.start
        context.window_manager.progress_update(done)
        if context.workspace is not None:
            context.workspace.status_text_set(f"Baking {job.obj_name}: frame {job.frame - 1} "
                                              f"({done}/{job.total}), Esc to cancel")
        if job.done:
            _running.remove(job)
            count = job.finish()
            self._end(context, f"baked {count} frames to {job.path}", 'INFO')
            return {'FINISHED'}
        return {'RUNNING_MODAL'}

    def cancel(self, context):
        """Blender drops the operator (a file loaded, its window closed, Blender quitting)."""
        if self._job in _running:
            self._stop(context, "Blender cancelled it (its window closed or Blender quit)")
        else:
            self._stopped_by_load(context)
