"""Screenshots of the Properties editor at Blender's factory width, every OPDeform panel open: the Physics tab
(Goal and Regions filled in) and the Modifier tab, for checking that no label is cut. Blender's real window
under a virtual X server (Debian's Blender; the bpy module has no windows):

    xvfb-run -a -s "-screen 0 1920x4000x24" scripts/blender --factory-startup EMPTY.blend \
        -P tests/blender/screenshot_tabs.py -- OUT_DIR

writes OUT_DIR/properties_physics.png and OUT_DIR/properties_modifier.png, and prints "TABS_OK <width>" with the
Properties editor's width in pixels.
"""

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import helpers as H  # noqa: E402

OUT = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
TABS = ("PHYSICS", "MODIFIER")


def _depth(cls):
    parent = getattr(cls, "bl_parent_id", "")
    return 0 if not parent else 1 + _depth(getattr(bpy.types, parent))


def open_all_panels():
    """Registers the add-on's panels again without DEFAULT_CLOSED (a panel's open state has no Python API)."""
    panels = sorted((c for c in bpy.types.Panel.__subclasses__() if c.__module__.startswith(H.ADDON)
                     and c.is_registered), key=_depth)
    for cls in reversed(panels):
        bpy.utils.unregister_class(cls)
    for cls in panels:
        cls.bl_options = set(getattr(cls, "bl_options", set())) - {'DEFAULT_CLOSED'}
        bpy.utils.register_class(cls)


def _setup():
    H.enable_addon()
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    obj = H.bar_object()
    for name in ("Follow", "Soft", "Damp"):
        obj.vertex_groups.new(name=name).add(list(range(len(obj.data.vertices))), 0.5, 'REPLACE')
    bpy.ops.opdeform.enable(object=obj.name)
    s = obj.opdeform
    s.use_goal, s.goal_group, s.softness_group, s.damping_group = True, "Follow", "Soft", "Damp"
    s.use_floor, s.use_solver_units = True, False  # material units: a new object's settings
    bpy.ops.opdeform.handle_add(object=obj.name, location=(2.0, 0.0, 0.0))
    bpy.context.scene.frame_set(2)  # a frame played: the modifier's inputs read the picked groups
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    open_all_panels()
    _show('PHYSICS')
    bpy.app.timers.register(shoot, first_interval=1.5)


def _properties(screen):
    return next(a for a in screen.areas if a.type == 'PROPERTIES')


def _show(tab):
    area = _properties(bpy.context.window_manager.windows[0].screen)
    area.spaces.active.context = tab
    area.tag_redraw()


def shoot(shots=list(TABS)):
    win = bpy.context.window_manager.windows[0]
    area = _properties(win.screen)
    tab = shots.pop(0)
    path = os.path.join(OUT, f"properties_{tab.lower()}.png")
    with bpy.context.temp_override(window=win, screen=win.screen, area=area):
        bpy.ops.screen.screenshot_area(filepath=path)
    print("SCREENSHOT", path)
    if shots:
        _show(shots[0])
        return 1.0
    print("TABS_OK", area.width, bpy.context.preferences.system.ui_scale)
    bpy.ops.wm.quit_blender()
    return None


bpy.context.preferences.view.show_splash = False
H.start_in_ui(_setup)
