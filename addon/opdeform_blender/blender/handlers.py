"""App handlers: live playback (frame change), posing and handle edits (depsgraph update), file load and undo,
and the baked tumbling particles shown on their point clouds (frame change).

They never raise: an error becomes ``obj.opdeform.error`` (shown in the panel and printed), and that object's
simulation pauses until Reset. They only touch enabled objects and never re-evaluate the whole scene.
"""

import bpy
from bpy.app.handlers import persistent

_discovery = {"dirty": True, "names": {}}
_guard = {"busy": False}


def mark_discovery():
    _discovery["dirty"] = True


def enabled_objects(scene):
    """The scene's objects with oriented particles enabled (the list is refreshed only when marked dirty)."""
    names = _discovery["names"]
    if _discovery["dirty"]:
        names.clear()
        _discovery["dirty"] = False
    key = scene.name
    if key not in names:
        names[key] = [o.name for o in scene.objects if o.type == 'MESH' and o.opdeform.enabled]
    out = []
    for name in names[key]:
        obj = scene.objects.get(name)
        if obj is None or not obj.opdeform.enabled:
            mark_discovery()
            continue
        out.append(obj)
    return out


def _message(exc):
    from . import runtime
    return str(exc) if isinstance(exc, runtime.AddonError) else f"{type(exc).__name__}: {exc}"


def _safely(obj, fn, *args, **kw):
    from . import runtime
    try:
        return fn(obj, *args, **kw)
    except Exception as exc:  # AddonError, a solver failure or a bug: report it, never raise from a handler
        runtime.set_error(obj, _message(exc))
    return None


def live_dynamic(scene):
    from . import runtime
    return [o for o in enabled_objects(scene) if runtime.is_live(o) and o.opdeform.mode == 'DYNAMIC']


def simulate_frame(scene, depsgraph=None):
    """Every live object to the scene's frame: those that can step together in contact (core/contact.py), the
    others alone. A failure pauses the objects it concerns."""
    from ..core import contact
    from . import runtime
    started = [(obj, r) for obj in live_dynamic(scene) if (r := _safely(obj, runtime.frame_run, scene, depsgraph))]
    by_run = {id(run): (obj, rt) for obj, (rt, run) in started}
    for runs in contact.partition([run for _, (_, run) in started]):
        objects, runtimes = zip(*(by_run[id(r)] for r in runs))
        try:
            outputs = runtime.simulate_together(objects, runtimes, runs)
        except Exception as exc:  # AddonError naming them, or a bug: report it, never raise from a handler
            for obj in objects:
                runtime.set_error(obj, _message(exc))
            continue
        for obj, rt, run, out in zip(objects, runtimes, runs, outputs):
            _safely(obj, runtime.frame_shown, rt, run, out)
    runtime.forget_groups()


@persistent
def on_frame_change(scene, depsgraph=None):
    if _guard["busy"]:
        return
    _guard["busy"] = True
    try:
        simulate_frame(scene, depsgraph)
    finally:
        _guard["busy"] = False


@persistent
def on_depsgraph_update(scene, depsgraph=None):
    """Posing mode: a moved handle re-solves the pose. Dynamics: a handle moved by hand outdates the cached
    frames after the current one. Any: an edited mesh's kept collider triangles are dropped."""
    from . import colliders, runtime
    if depsgraph is not None:
        colliders.forget_triangles(u.id.name for u in depsgraph.updates if u.is_updated_geometry)
    if _guard["busy"] or depsgraph is not None and not depsgraph.id_type_updated('OBJECT'):
        return
    _guard["busy"] = True
    try:
        for obj in enabled_objects(scene):
            rt = runtime.get(obj)
            if not runtime.is_live(obj) or rt is None:
                continue
            s = obj.opdeform
            if s.mode == 'POSE':
                _safely(obj, runtime.pose_update, scene, depsgraph)
            elif rt.handle_matrices is not None:
                sig = _safely(obj, lambda o: runtime.handle_signature(o.opdeform, depsgraph))
                if sig is not None and sig != rt.handle_matrices:
                    rt.engine.invalidate(keep_until=scene.frame_current)
                    rt.handle_matrices = sig
    finally:
        _guard["busy"] = False


@persistent
def on_load_post(*args):
    from . import colliders, runtime, versioning
    runtime.clear()
    colliders.forget_triangles()
    versioning.upgrade(bpy.data.objects)
    mark_discovery()


@persistent
def on_undo_post(*args):
    """Undo and redo replace the data: forget runtimes of objects that are gone or changed shape, and every
    collider's kept triangles."""
    from . import colliders, runtime
    colliders.forget_triangles()
    valid = set()
    for obj in bpy.data.objects:
        rt = runtime.get(obj)
        if rt is None:
            continue
        s = obj.opdeform
        if (obj.type == 'MESH' and s.enabled and s.built
                and len(obj.data.vertices) == rt.engine.n_vertices):
            valid.add(runtime.key(obj))
    runtime.prune(valid)
    mark_discovery()


@persistent
def on_save_pre(*args):
    """A saved file carries no offset: opened without the add-on it shows the original mesh and animation."""
    from . import modifier
    for mesh in bpy.data.meshes:
        if mesh.library is None:
            modifier.clear_offset(mesh)


@persistent
def on_save_post(*args):
    """Shows the simulated frames again after a save."""
    from . import runtime
    for scene in bpy.data.scenes:
        for obj in enabled_objects(scene):
            rt = runtime.get(obj)
            if rt is not None and rt.deformed and runtime.is_live(obj):
                _safely(obj, runtime.show, rt, rt.engine.offset)


@persistent
def tumbling_frame_change(scene, depsgraph=None):
    """Shows the baked frame (clamped to the baked range) on every tumbling domain's point cloud."""
    from . import runtime, tumbling_runtime
    if tumbling_runtime.baking():
        return
    for obj in scene.objects:
        s = getattr(obj, "opdeform_tumbling", None)
        if s is None or not s.enabled or not s.baked:
            continue
        try:
            tumbling_runtime.show_baked(obj, scene)
        except Exception as exc:  # a damaged frame file or a bug: report it, never raise from a handler
            s.error = str(exc) if isinstance(exc, (runtime.AddonError, OSError, ValueError)) else \
                f"{type(exc).__name__}: {exc}"


HANDLERS = (
    ("frame_change_post", on_frame_change),
    ("frame_change_post", tumbling_frame_change),
    ("depsgraph_update_post", on_depsgraph_update),
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
    from . import runtime
    runtime.clear()
    try:
        on_save_pre()  # disabled or uninstalled: every mesh shows its input again
    except AttributeError:  # Blender is quitting: bpy.data is no longer readable (nothing is saved then)
        pass
