"""Installs an add-on zip made by scripts/package into a throw-away user folder and checks it:

    blender -b --factory-startup --python-exit-code 1 -P check_package.py -- ZIP legacy|extension ok|broken
    <python with bpy> check_package.py ZIP legacy|extension ok|broken

"ok": the compiled module loads (legacy: vendored in the zip; extension: from the wheel Blender installed) (without
the shape-matching baseline), a mesh builds, plays and bakes, and after the same zip is installed again over the
enabled add-on (an update) another mesh plays. "broken": the zip's compiled
module is damaged; the add-on still registers, the panel says what is wrong and the operators report it.
The caller points BLENDER_USER_SCRIPTS / BLENDER_USER_RESOURCES at an empty folder and leaves
OPDEFORM_PYTHONPATH unset.
"""

import os
import sys

import bpy

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
zip_path, kind, expect = args
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import helpers as H  # noqa: E402  (paths, fake panel layout; the repo's addon/ is dropped from sys.path below)

sys.path[:] = [p for p in sys.path if os.path.abspath(p) != os.path.abspath(H.ADDON_DIR)]
assert "OPDEFORM_PYTHONPATH" not in os.environ


def play(obj, frames=10):
    obj.opdeform.particles = 12
    bpy.ops.opdeform.enable(object=obj.name)
    obj.opdeform.frame_end = frames
    for f in range(1, frames + 1):
        bpy.context.scene.frame_set(f)
    assert not obj.opdeform.error, obj.opdeform.error


module_name = H.install_package(zip_path, kind)
addon = sys.modules[module_name]
assert os.path.abspath(addon.__file__).startswith(os.path.abspath(os.environ.get("BLENDER_USER_RESOURCES") or
                                                                  os.environ["BLENDER_USER_SCRIPTS"]))
H.ADDON = module_name
loader = sys.modules[module_name + ".core.loader"]
loaded, where = loader.status()
print("loader:", loaded, where)

bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, location=(0, 0, 1))
obj = bpy.context.object
if expect == "ok":
    if kind == "legacy":  # the wheel's files vendored inside the add-on
        assert loaded and "vendored" in where, where
        module = sys.modules[module_name + ".vendor.opdeform"]
        assert module.__file__.startswith(os.path.dirname(addon.__file__))
    else:  # the extension's wheel, which Blender installed into the user's extension site-packages
        assert loaded and "import opdeform" in where, where
        module = sys.modules["opdeform"]
        assert os.path.abspath(module.__file__).startswith(os.path.abspath(os.environ["BLENDER_USER_RESOURCES"]))
        assert os.sep + "site-packages" + os.sep in module.__file__, module.__file__
    print("module:", module.__file__)
    assert not hasattr(module, "ShapeMatching") and not hasattr(module._core, "ShapeMatching")
    play(obj)
    obj.opdeform.cache_directory = os.path.join(os.path.dirname(zip_path), "cache-" + kind)
    bpy.ops.opdeform.bake()
    assert obj.opdeform.baked
    # Installed again over the enabled add-on, as an update is: Blender 3.4 extracted the legacy zip over the
    # loaded compiled module (a bus error) while the zip named no folder, and bpy 4.2 crashed at exit after it
    H.install_package(zip_path, kind)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, location=(3, 0, 1))
    play(bpy.context.object)
    print("installed again: plays")
else:
    assert not loaded and "could not be loaded" in where, where
    text = H.labels(H.draw_panels())
    assert "could not be loaded" in text, text
    try:
        bpy.ops.opdeform.enable()
    except RuntimeError as exc:
        assert "could not be loaded" in str(exc), exc
    else:
        raise AssertionError("enable did not report the missing module")
    assert not obj.opdeform.enabled
print(f"PACKAGE_OK {kind} {expect} {bpy.app.version_string}")
