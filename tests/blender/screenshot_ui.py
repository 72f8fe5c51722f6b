"""Documentation screenshot of the add-on's UI: Blender's real window under a virtual X server (no display
needed), the creature built with 100 particles, a pin group and a handle, a few frames played, the viewport
overlay on and the Physics tab showing the panel.

    OPDEFORM_PYTHONPATH=<build>/python xvfb-run -s "-screen 0 1500x2100x24" scripts/blender --factory-startup \
        EMPTY.blend -P tests/blender/screenshot_ui.py -- docs/img/blender_panel.png

(opening a .blend skips the splash screen; any saved file will do, e.g. one saved by ``blender -b``).
"""

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import helpers as H  # noqa: E402

OUT = os.path.abspath((sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else ["blender_panel.png"])[0])


def _setup():
    import numpy as np
    H.enable_addon()
    from opdeform import meshes
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    v, t = meshes.creature()
    v = np.asarray(v, float)
    v[:, 2] -= v[:, 2].min() - 0.05
    obj = H.mesh_object("Creature", v, t)
    z = v[:, 2]
    group = obj.vertex_groups.new(name="Feet")
    group.add([int(i) for i in np.where(z < z.min() + 0.08 * (z.max() - z.min()))[0]], 1.0, 'REPLACE')
    s = obj.opdeform
    s.pin_group = "Feet"
    s.particles = 100
    s.stiffness = 2e7
    bpy.ops.opdeform.enable(object=obj.name)
    top = v[int(np.argmax(z))]
    bpy.ops.opdeform.handle_add(object=obj.name, location=tuple(top))
    handle = s.handles[0].target
    handle.location.x += 0.15 * (v[:, 0].max() - v[:, 0].min())
    for f in range(1, 12):
        bpy.context.scene.frame_set(f)
    for area in bpy.context.screen.areas:
        if area.type == 'PROPERTIES':
            for space in area.spaces:
                if space.type == 'PROPERTIES':
                    space.context = 'PHYSICS'
        if area.type == 'VIEW_3D':
            for space in area.spaces:
                if space.type == 'VIEW_3D':
                    space.shading.type = 'SOLID'
                    space.overlay.show_floor = True
            with bpy.context.temp_override(area=area, region=[r for r in area.regions if r.type == 'WINDOW'][0]):
                bpy.ops.view3d.view_selected()
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.app.timers.register(shoot, first_interval=2.0)


def shoot():
    win = bpy.context.window_manager.windows[0]
    with bpy.context.temp_override(window=win, screen=win.screen, area=win.screen.areas[0]):
        bpy.ops.screen.screenshot(filepath=OUT)
    print("SCREENSHOT", OUT)
    for kind, suffix in (('PROPERTIES', "_physics.png"), ('VIEW_3D', "_viewport.png")):
        area = next(a for a in win.screen.areas if a.type == kind)
        path = OUT.replace(".png", suffix)
        with bpy.context.temp_override(window=win, screen=win.screen, area=area):
            bpy.ops.screen.screenshot_area(filepath=path)
        print("SCREENSHOT", path)
    bpy.ops.wm.quit_blender()


bpy.context.preferences.view.show_splash = False
H.start_in_ui(_setup)
