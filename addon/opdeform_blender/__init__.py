"""OPDeform for Blender: ARAP deformation with oriented (ellipsoid) particles.

Physics tab > Oriented Particles. Loads as a legacy add-on (bl_info, Blender 3.4+) and as an extension
(blender_manifest.toml, Blender 4.2+). The compiled opdeform module is vendored by scripts/package, or found
through $OPDEFORM_PYTHONPATH (development), see core/loader.py. Layout follows glTF-Blender-IO: core/ is
bpy-free, blender/ holds properties, operators, panels, handlers and the overlay.
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

ADDON_PACKAGE = __package__ or __name__

if "_modules" in locals():  # F8 / script reload: reload the submodules too
    import importlib
    for _m in _modules:  # noqa: F821
        importlib.reload(_m)

try:
    import bpy  # noqa: F401
except ImportError:  # outside Blender: only the bpy-free core/ is usable (tests, tools)
    _modules = ()
else:
    from .blender import handlers, operators, overlay, panels, properties, tumbling

    # Registered in this order, unregistered in the reverse order. Other features (e.g. an MPM panel) add
    # their module here; each module has a `classes` tuple and register()/unregister().
    _modules = (properties, operators, panels, handlers, overlay, tumbling)


def register():
    from .core import loader
    for m in _modules:
        m.register()
    loader.load(ADDON_PACKAGE)  # errors are shown in the panel, never raised


def unregister():
    for m in reversed(_modules):
        m.unregister()
