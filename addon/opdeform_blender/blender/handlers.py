"""App handlers: live playback (frame change), posing and handle edits (depsgraph update), file load and undo,
the baked tumbling particles shown on their point clouds (frame change), and the modal bakes a file load stops.

They never raise: an error becomes ``obj.opdeform.error`` (shown in the panel and printed), and that object's
simulation pauses until Reset. They only touch enabled objects and never re-evaluate the whole scene.
"""

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import colliders, modal_bake, modifier, playback, state, tumbling_runtime, versioning
from .compiled import AddonError
from .discovery import enabled_objects, mark_discovery
from .handle_data import handle_signature
from .runtime import kept_transform, show

_guard = {"busy": False}


@persistent
def on_frame_change(scene, depsgraph=None):
    if _guard["busy"]:
        return
    _guard["busy"] = True
    try:
        playback.simulate_frame(scene, depsgraph)
    finally:
        _guard["busy"] = False


@persistent
def on_depsgraph_update(scene, depsgraph=None):
    """Posing mode: a moved handle re-solves the pose. Dynamics: a handle moved by hand outdates the cached
    frames after the current one. Any: an edited mesh's kept collider triangles are dropped, and the painted
    maps of an object in Weight Paint or Edit Mode are read again on its next frame."""
    if depsgraph is not None:
        colliders.forget_triangles(u.id.name for u in depsgraph.updates if u.is_updated_geometry)
    if _guard["busy"] or depsgraph is not None and not depsgraph.id_type_updated('OBJECT'):
        return
    _guard["busy"] = True
    try:
        for obj in enabled_objects(scene):
            rt = state.get(obj)
            if rt is not None and obj.mode != 'OBJECT':  # painting or assigning: the maps are read again
                rt.groups.clear()
            if not playback.is_live(obj) or rt is None:
                continue
            s = obj.opdeform
            if s.mode == 'POSE':
                playback.safely(obj, playback.pose_update, scene, depsgraph)
            elif rt.handle_matrices is not None:
                sig = playback.safely(obj, lambda o: handle_signature(o.opdeform, depsgraph))
                if sig is not None and sig != rt.handle_matrices:
                    rt.engine.invalidate(keep_until=scene.frame_current)
                    rt.handle_matrices = sig
    finally:
        _guard["busy"] = False


@persistent
def on_load_pre(*args):
    """A file is loaded: the modal bakes under way stop (their partial files go, the last bakes stay) before
    Blender drops their operators and the data they bake."""
    modal_bake.stop_all("a file was loaded")


@persistent
def on_load_post(*args):
    """A loaded file shows the simulated pose of its current frame, not the input (the offset is not saved:
    on_save_pre): its objects are simulated up to it again, frame by frame."""
    state.clear()
    colliders.forget_triangles()
    versioning.upgrade(bpy.data.objects)
    mark_discovery()
    playback.replay_to_current(bpy.context.scene)


@persistent
def on_undo_post(*args):
    """Undo and redo replace the data: forget runtimes of objects that are gone or changed shape, and every
    collider's kept triangles."""
    colliders.forget_triangles()
    valid = set()
    for obj in bpy.data.objects:
        rt = state.get(obj)
        if rt is None:
            continue
        s = obj.opdeform
        if (obj.type == 'MESH' and s.enabled and s.built and len(obj.data.vertices) == rt.engine.n_vertices
                and np.array_equal(kept_transform(s), rt.engine.matrix_world)):
            valid.add(state.key(obj))  # an undone re-Build: the transform kept is not the runtime's
    state.prune(valid)
    mark_discovery()


@persistent
def on_save_pre(*args):
    """A saved file carries no offset: opened without the add-on it shows the original mesh and animation."""
    for mesh in bpy.data.meshes:
        if mesh.library is None:
            modifier.clear_offset(mesh)


@persistent
def on_save_post(*args):
    """Shows the simulated frames again after a save."""
    for scene in bpy.data.scenes:
        for obj in enabled_objects(scene):
            rt = state.get(obj)
            if rt is not None and rt.deformed and playback.is_live(obj):
                playback.safely(obj, show, rt, rt.engine.offset)


@persistent
def tumbling_frame_change(scene, depsgraph=None):
    """Shows the baked frame (clamped to the baked range) on every tumbling domain's point cloud."""
    if tumbling_runtime.baking():
        return
    for obj in scene.objects:
        s = getattr(obj, "opdeform_tumbling", None)
        if s is None or not s.enabled or not s.baked:
            continue
        try:
            tumbling_runtime.show_baked(obj, scene)
        except Exception as exc:  # a damaged frame file or a bug: report it, never raise from a handler
            s.error = str(exc) if isinstance(exc, (AddonError, OSError, ValueError)) else \
                f"{type(exc).__name__}: {exc}"


HANDLERS = (
    ("frame_change_post", on_frame_change),
    ("frame_change_post", tumbling_frame_change),
    ("depsgraph_update_post", on_depsgraph_update),
    ("load_pre", on_load_pre),
    ("load_post", on_load_post),
    ("undo_post", on_undo_post),
    ("redo_post", on_undo_post),
    ("save_pre", on_save_pre),
    ("save_post", on_save_post),
)
classes = ()


def register():
    for name, fn in HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if fn not in handlers:
            handlers.append(fn)
    mark_discovery()


def unregister():
    for name, fn in reversed(HANDLERS):
        handlers = getattr(bpy.app.handlers, name)
        while fn in handlers:
            handlers.remove(fn)
    state.clear()
    try:
        on_save_pre()  # disabled or uninstalled: every mesh shows its input again
    except AttributeError:  # Blender is quitting: bpy.data is no longer readable (nothing is saved then)
        pass
