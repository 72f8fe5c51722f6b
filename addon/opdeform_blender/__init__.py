"""OPDeform for Blender: ARAP deformation with oriented (ellipsoid) particles.

Physics tab > Oriented Particles. Loads as a legacy add-on (bl_info, Blender 3.4+) and as an extension
(blender_manifest.toml, Blender 4.2+). The compiled opdeform module is vendored by scripts/package, or found
through $OPDEFORM_PYTHONPATH (development), see core/loader.py. Layout follows glTF-Blender-IO: core/ is
bpy-free, blender/ holds the bpy code in layers (blender/__init__.py): settings, per-object state, Blender
data read and written, the engines driven, and on top what Blender calls (operators, panels, handlers, overlay).
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

from .blender import LAYERS

ADDON_PACKAGE = __package__ or __name__

# Every module of the add-on, each after the modules it imports: core/ (bpy-free), then blender/ layer by layer
# (blender/__init__.py, LAYERS: a module imports only what is listed before it). A script reload (F8) reloads
# them all, in this order, so that a change anywhere is picked up; tests/test_addon_core.py checks that every
# file is listed. Those with register() (each with one `classes` tuple) are registered in this order and
# unregistered in the reverse order. A new module goes in its layer in blender/__init__.py.
CORE_MODULES = ("core", "core.loader", "core.bake_files", "core.frames", "core.cache", "core.handles",
                "core.settings", "core.checks", "core.frame_report", "core.tumbling", "core.colliders",
                "core.fields", "core.engine", "core.contact")
MODULES = (*CORE_MODULES, "blender", *(f"blender.{name}" for _, names in LAYERS for name in names))

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
    _keep_modules_alive()
    loader.load(ADDON_PACKAGE)  # errors are shown in the panel, never raised


def _keep_modules_alive():
    """Every registered class holds the add-on's module objects, so that Python's finalization wipes their
    dicts. Without this, bpy 4.2 (the module) crashes at exit: it only shuts Blender down when the `bpy` module
    object is freed; Python frees a module object when sys.modules is cleared but not its dict while a function
    (a method, an update or poll callback, the overlay's draw callback) still refers to it as __globals__, and
    Blender holds our classes (registered ones until its shutdown, PropertyGroups even after unregister in
    4.2), so the dict kept `bpy` alive, Blender's static destructors ran after Python's end (bpy_class_free ->
    PyGILState_Ensure: SIGSEGV). A module object still alive at finalization has its dict wiped, which ends
    that chain (docs/packaging.md, "bpy 4.2 at exit")."""
    names = (__name__, *(f"{__name__}.{name}" for name in MODULES))
    alive = tuple(sys.modules[n] for n in names if n in sys.modules)
    for m in _modules:
        for cls in m.classes:
            cls._opdeform_modules = alive


def unregister():
    for m in reversed(_modules):
        m.unregister()
    _retire_modules()


def _retire_modules():
    """Keeps this copy's modules in sys.modules under a private name, so that Python's finalization still wipes
    their dicts after Blender replaced them (Install again over the enabled add-on, an extension's update):
    otherwise the classes Blender keeps hold a module that is no longer listed, its dict keeps `bpy`, and bpy
    4.2 crashes at exit as _keep_modules_alive describes (measured: a segmentation fault after a reinstall)."""
    for n in (__name__, *(f"{__name__}.{name}" for name in MODULES)):
        if n in sys.modules:
            sys.modules[f"_opdeform_retired_{id(sys.modules[n]):x}"] = sys.modules[n]
