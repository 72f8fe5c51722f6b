"""OPDeform for Blender: ARAP deformation with oriented (ellipsoid) particles.

Physics tab > Oriented Particles. Loads as a legacy add-on (bl_info, Blender 3.4+) and as an extension
(blender_manifest.toml, Blender 4.2+). The compiled opdeform module is vendored by scripts/package, or found
through $OPDEFORM_PYTHONPATH (development), see core/loader.py. Layout follows glTF-Blender-IO: core/ is
bpy-free, blender/ holds properties, operators, panels, handlers, the overlay, and the glue to Blender data
(runtime, tumbling_runtime, point_cloud).
"""

bl_info = {
    "name": "OPDeform: Oriented Particles",
    "author": "opdeform developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Physics > Oriented Particles",
    "description": "ARAP soft bodies, jiggle and posing with oriented (ellipsoid) particles; bakes to PC2",
    "doc_url": "",
    "category": "Physics",
}

import importlib
import sys

ADDON_PACKAGE = __package__ or __name__

# Every module of the add-on, each after the modules it imports. A script reload (F8) reloads them all, in this
# order, so that a change anywhere is picked up; tests/test_addon_core.py checks that every file is listed. Those
# with register() (each with one `classes` tuple) are registered in this order and unregistered in the reverse
# order. A new feature (e.g. an MPM panel) adds its modules here.
MODULES = ("core", "core.loader", "core.pc2", "core.frames", "core.cache", "core.handles", "core.tumbling",
           "core.colliders", "core.fields", "core.engine", "blender", "blender.modifier", "blender.colliders",
           "blender.runtime", "blender.point_cloud", "blender.tumbling_runtime",
           "blender.properties", "blender.collider_properties", "blender.operators", "blender.panels",
           "blender.collider_panels", "blender.handlers", "blender.overlay")

if "_modules" in locals():  # F8 / script reload: Blender reloads this file; reload the modules first
    for _name in MODULES:
        if f"{__name__}.{_name}" in sys.modules:
            importlib.reload(sys.modules[f"{__name__}.{_name}"])

try:
    import bpy  # noqa: F401
except ImportError:  # outside Blender: only the bpy-free core/ is usable (tests, tools)
    _modules = ()
else:
    _modules = tuple(m for m in (importlib.import_module("." + name, __name__) for name in MODULES)
                     if hasattr(m, "register"))


def register():
    from .core import loader
    for m in _modules:
        m.register()
    loader.load(ADDON_PACKAGE)  # errors are shown in the panel, never raised


def unregister():
    for m in reversed(_modules):
        m.unregister()
