"""The interactive bake in Blender's real UI (a virtual X server, no display): Bake from a button runs modal
with progress, Esc cancels and keeps the frames baked so far, and a second bake runs to the end.

    OPDEFORM_PYTHONPATH=<build>/python xvfb-run -a scripts/blender --factory-startup --enable-event-simulate \
        FILE.blend -P tests/blender/ui_bake.py -- OUT_DIR
"""

import os
import sys
import traceback

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import helpers as H  # noqa: E402

OUT = os.path.abspath((sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else ["."])[0])
DEADLINE_S = 150.0  # the script quits by itself, whatever happens
state = {"phase": "start", "ticks": 0}


def fail_and_quit():
    traceback.print_exc()
    print("UI_BAKE_FAILED")
    bpy.ops.wm.quit_blender()


def window_context():
    win = bpy.context.window_manager.windows[0]
    area = next(a for a in win.screen.areas if a.type == 'VIEW_3D')
    return dict(window=win, screen=win.screen, area=area, region=[r for r in area.regions if r.type == 'WINDOW'][0])


def tick():
    import time
    state.setdefault("t0", time.monotonic())
    if time.monotonic() - state["t0"] > DEADLINE_S:
        print(f"UI_BAKE_FAILED: still in phase {state['phase']} after {DEADLINE_S} s")
        bpy.ops.wm.quit_blender()
        return None
    try:
        return step()
    except Exception:
        fail_and_quit()
        return None


def step():
    import numpy as np
    obj = bpy.data.objects.get("Bar")
    win = bpy.context.window_manager.windows[0]
    if state["phase"] == "start":
        H.enable_addon()
        for o in list(bpy.data.objects):
            bpy.data.objects.remove(o)
        obj = H.bar_object()
        obj.opdeform.frame_end = 200
        obj.opdeform.cache_directory = os.path.join(OUT, "cache")
        bpy.ops.opdeform.enable(object=obj.name)
        with bpy.context.temp_override(**window_context()):
            bpy.ops.opdeform.bake('INVOKE_DEFAULT', object=obj.name)
        state["phase"] = "baking"
        return 0.05
    if state["phase"] == "baking":
        frame = bpy.context.scene.frame_current
        if frame >= 8:  # some frames baked: press Esc
            win.event_simulate(type='ESC', value='PRESS')
            win.event_simulate(type='ESC', value='RELEASE')
            state["phase"] = "cancelled"
        return 0.05
    if state["phase"] == "cancelled":
        s = obj.opdeform
        assert s.baked, "a cancelled bake must keep its frames"
        n, start, rate, count = H.pc2().pc2_header(bpy.path.abspath(s.bake_file))
        assert 4 <= count < 200, count
        print(f"UI_BAKE cancelled after {count} frames")
        obj.opdeform.frame_end = 12
        with bpy.context.temp_override(**window_context()):
            bpy.ops.opdeform.bake('INVOKE_DEFAULT', object=obj.name)
        state["phase"] = "second"
        return 0.1
    if state["phase"] == "second":
        state["ticks"] += 1
        s = obj.opdeform
        path = bpy.path.abspath(s.bake_file) if s.baked else ""
        if s.baked and path and H.runtime().cache_modifier(obj) is not None:
            count = H.pc2().pc2_header(path)[3]
            if count == 12:
                frames = H.pc2().read_pc2(path)[2]
                assert np.abs(frames[-1] - frames[0]).max() > 1e-3
                print("UI_BAKE_OK")
                bpy.ops.wm.quit_blender()
                return None
        if state["ticks"] > 600:
            raise AssertionError("the second bake did not finish")
        return 0.05
    return None


bpy.context.preferences.view.show_splash = False
bpy.app.timers.register(tick, first_interval=1.0)
