"""Far jumps on the timeline in the UI (issue 15, item 4). A frame change simulates at most
``state.CATCH_UP_SECONDS`` and shows the last frame reached; when frames are still missing, the modal
``opdeform.catch_up`` goes on a slice at a time between events, with a progress bar and a status line, until
every live object has reached the current frame. Esc stops it: the objects keep showing their last good frame
until the next frame change. Scripts and renders (background mode) never need it: there a frame change
simulates every frame it needs (at most core/frames.MAX_FRAMES). playback.start_catch_up invokes it.
"""

import bpy

from . import playback, state
from .discovery import enabled_objects


def behind(context):
    """(object, its runtime) of the live objects still short of the current frame."""
    out = []
    for obj in enabled_objects(context.scene):
        rt = state.get(obj)
        if rt is not None and rt.engine.behind and playback.is_live(obj):
            out.append((obj, rt))
    return out


class OPDEFORM_OT_catch_up(bpy.types.Operator):
    """Simulate the frames up to the current one after a far jump on the timeline (Esc stops: the last frame
    reached stays shown)"""
    bl_idname = "opdeform.catch_up"
    bl_label = "Catch Up"

    _timer = None

    def invoke(self, context, event):
        playback.catch_up_running(True)
        self._total = max((rt.engine.behind for _, rt in behind(context)), default=0)
        wm = context.window_manager
        wm.progress_begin(0, max(1, self._total))
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def _end(self, context, message):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        playback.catch_up_running(False)
        self.report({'INFO'}, message)

    def modal(self, context, event):
        if event.type == 'ESC':
            self._end(context, "catch-up stopped: the last frame reached stays shown")
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'PASS_THROUGH'}
        playback.simulate_frame(context.scene)  # all live objects: those in contact step together
        left = max((rt.engine.behind for _, rt in behind(context)), default=0)
        if not left:
            self._end(context, "caught up")
            return {'FINISHED'}
        self._total = max(self._total, left)
        context.window_manager.progress_update(self._total - left)
        if context.workspace is not None:
            context.workspace.status_text_set(f"OPDeform: simulating up to frame {context.scene.frame_current}, "
                                              f"{left:,} frames to go (Esc to stop)")
        for area in context.screen.areas if context.screen else ():
            area.tag_redraw()
        return {'RUNNING_MODAL'}


classes = (OPDEFORM_OT_catch_up,)
register, unregister = bpy.utils.register_classes_factory(classes)
