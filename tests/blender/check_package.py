"""Installs an add-on zip made by scripts/package into a throw-away user folder and checks it:

    blender -b --factory-startup --python-exit-code 1 -P check_package.py -- ZIP legacy|extension ok|broken
    <python with bpy> check_package.py ZIP legacy|extension ok|broken

"ok": the compiled module loads (legacy: vendored in the zip; extension: from the wheel Blender installed) (without the shape-matching baseline) and a mesh builds, plays and
bakes. "broken": the zip's compiled
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

if kind == "legacy":
    bpy.ops.preferences.addon_install(filepath=zip_path)
    import addon_utils
    module_name = "opdeform_blender"
    assert addon_utils.enable(module_name, default_set=True, handle_error=None) is not None
else:
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    module_name = "bl_ext.user_default.opdeform_blender"
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
    obj.opdeform.particles = 12
    bpy.ops.opdeform.enable()
    obj.opdeform.frame_end = 10
    for f in range(1, 11):
        bpy.context.scene.frame_set(f)
    assert not obj.opdeform.error, obj.opdeform.error
    obj.opdeform.cache_directory = os.path.join(os.path.dirname(zip_path), "cache-" + kind)
    bpy.ops.opdeform.bake()
    assert obj.opdeform.baked
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
