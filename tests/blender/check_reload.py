"""A script reload (F8, ``bpy.ops.script.reload``) picks up a change in every module of the add-on and leaves it
working:

    blender -b --factory-startup --python-exit-code 1 -P check_reload.py -- OUT_DIR
    <python with bpy> check_reload.py OUT_DIR

The caller copies addon/opdeform_blender into $BLENDER_USER_SCRIPTS/addons (Blender reloads only the add-ons
of its add-on folders) and sets $OPDEFORM_PYTHONPATH. The add-on is enabled, every one of its files gets a new
line, and ``bpy.utils.load_scripts(reload_scripts=True)`` runs: what ``script.reload`` does (from a timer).
Then every module must hold the new line, the panels and operators must be the reloaded classes, each app
handler must be there once, and both bakes must run.
"""

import importlib
import os
import sys

import bpy

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
out = args[0]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import helpers as H  # noqa: E402  (object builders, fake panel layout; the repo's addon/ is dropped below)

sys.path[:] = [p for p in sys.path if os.path.abspath(p) != os.path.abspath(H.ADDON_DIR)]
H.enable_addon()
addon = sys.modules[H.ADDON]
assert addon.__file__.startswith(os.environ["BLENDER_USER_SCRIPTS"]), addon.__file__
names = ("",) + tuple("." + name for name in addon.MODULES)
for name in names:
    with open(sys.modules[H.ADDON + name].__file__, "a") as f:
        f.write(f"\nRELOADED = {name!r}\n")

bpy.utils.load_scripts(reload_scripts=True)

stale = [H.ADDON + n for n in names if getattr(sys.modules[H.ADDON + n], "RELOADED", None) != n]
assert not stale, f"not reloaded: {stale}"
panels = importlib.import_module(H.ADDON + ".blender.panels")
operators = importlib.import_module(H.ADDON + ".blender.operators")
assert bpy.types.PHYSICS_PT_opdeform is panels.PHYSICS_PT_opdeform
assert bpy.types.PHYSICS_PT_opdeform_tumbling is panels.PHYSICS_PT_opdeform_tumbling
assert bpy.types.OPDEFORM_OT_tumbling_bake is operators.OPDEFORM_OT_tumbling_bake
handlers = importlib.import_module(H.ADDON + ".blender.handlers")
for kind, fn in handlers.HANDLERS:
    found = [h for h in getattr(bpy.app.handlers, kind) if h.__name__ == fn.__name__]
    assert found == [fn], (kind, fn.__name__, found)

H.fresh()
bar = H.bar_object()
bar.opdeform.frame_end = 5
bar.opdeform.cache_directory = os.path.join(out, "cache")
bpy.ops.opdeform.enable(object=bar.name)
bpy.ops.opdeform.bake(object=bar.name)
assert bar.opdeform.baked and not bar.opdeform.error, bar.opdeform.error
v, t = H.box_mesh((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (2, 2, 2))
domain = H.mesh_object("Domain", v, t)
bpy.ops.opdeform.tumbling_enable(object=domain.name)
s = domain.opdeform_tumbling
s.dx, s.count, s.frame_start, s.frame_end = 0.1, 30, 1, 3
s.cache_directory = os.path.join(out, "tumbling")
bpy.ops.opdeform.tumbling_bake(object=domain.name)
assert s.baked and bpy.data.objects.get(s.points_name) is not None
assert ("operator", "opdeform.tumbling_free_bake", None) in H.draw_panels()
H.disable_addon()
assert not hasattr(bpy.types.Object, "opdeform_tumbling")
print(f"RELOAD_OK {bpy.app.version_string}")
