"""bpy half of the add-on, in layers with one direction of import (glTF-Blender-IO's blender/ over its bpy-free
core/, which sits below all of them). LAYERS lists them lowest first: a module may import (at its top or inside a
function) only modules of a lower layer, or of its own layer listed before it; so there is no import cycle, and
the add-on's MODULES (its reload and register order) is LAYERS read in order. Every module of blender/ is in
exactly one layer; scripts/architecture checks the rule.

- base: AddonError and the compiled opdeform module as the add-on found it.
- settings: what the .blend stores (``Object.opdeform``, ``opdeform_tumbling``, ``opdeform_contact``), its
  versions and material presets, and which objects have it enabled. A new setting goes in properties.py.
- state: what the add-on keeps in memory per object (state.Runtime; a new per-object field goes there).
- scene: Blender data read and written for the engines: meshes, handles, opdeform's modifier, colliders and
  force fields, the parameters the settings give the engine (a new setting that reaches it is read in
  parameters.py), the tumbling point cloud.
- engine: an object's engine built, configured, shown and baked (runtime.py), live playback (playback.py), the
  tumbling bake.
- ui: what Blender calls: operators, panels (a new row goes in the panel that shows its setting; their shared
  base classes are panel_base.py), the catch-up, the app handlers and the viewport overlay.

A lower layer never triggers a higher one by import: the enabled-objects list a property update marks dirty
lives in settings (discovery.py), the catch-up's start in playback.py invokes its operator by name.
"""

LAYERS = (
    ("base", ("compiled",)),
    ("settings", ("versioning", "presets", "discovery", "properties", "collider_properties")),
    ("state", ("state",)),
    ("scene", ("mesh_data", "handle_data", "modifier", "colliders", "parameters", "point_cloud")),
    ("engine", ("runtime", "playback", "tumbling_runtime")),
    ("ui", ("modal_bake", "operators", "catch_up", "panel_base", "error_plot", "panels", "settings_panels",
            "collider_panels", "handlers", "overlay")),
)
