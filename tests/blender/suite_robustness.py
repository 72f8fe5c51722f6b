"""Blender-side robustness (docs/hardening.md), run by tests/test_addon_robustness.py through runner.py in both
hosts: the add-on's handlers never raise (an error becomes obj.opdeform.error and that object pauses), and
deleting the simulated object or its handle, undo, redo, reloading the file, renaming, and changing the
mesh's vertex count between frames are handled without a crash or an escaped exception.

Every test watches the add-on's app handlers: each registered handler is wrapped so that an exception that
would escape to Blender (which only prints it) is recorded, and the test fails on it."""

import contextlib
import importlib
import os

import bmesh
import bpy
import numpy as np
from bpy.app.handlers import persistent

import helpers as H


def _handlers_module():
    return importlib.import_module(H.ADDON + ".blender.handlers")


def _tumbling_module():
    return importlib.import_module(H.ADDON + ".blender.tumbling_runtime")


@contextlib.contextmanager
def watched():
    """Wraps the add-on's registered app handlers; yields the list of exceptions that escaped them."""
    escaped = []
    hm = _handlers_module()
    pairs = list(hm.HANDLERS)
    swapped = []
    for name, fn in pairs:
        handlers = getattr(bpy.app.handlers, name)
        for i, h in enumerate(list(handlers)):
            if h is fn:
                def wrapper(*args, _fn=fn, _name=name, **kw):
                    try:
                        return _fn(*args, **kw)
                    except BaseException as exc:  # noqa: BLE001 - recorded, then Blender prints it
                        escaped.append(f"{_name}/{_fn.__name__}: {type(exc).__name__}: {exc}")
                        raise
                wrapper = persistent(wrapper)
                handlers[i] = wrapper
                swapped.append((name, wrapper, fn))
    try:
        yield escaped
    finally:
        for name, wrapper, fn in swapped:
            handlers = getattr(bpy.app.handlers, name)
            for i, h in enumerate(list(handlers)):
                if h is wrapper:
                    handlers[i] = fn
    assert not escaped, "exceptions escaped the add-on's handlers:\n" + "\n".join(escaped)


def _enable_bar(name="Bar", **settings):
    obj = H.bar_object(name)
    for k, v in settings.items():
        setattr(obj.opdeform, k, v)
    bpy.ops.opdeform.enable(object=obj.name)
    assert obj.opdeform.enabled and obj.opdeform.built and not obj.opdeform.error, obj.opdeform.error
    return obj


def _frames(frames):
    for f in frames:
        bpy.context.scene.frame_set(f)


def _finite(obj):
    return bool(np.isfinite(H.positions(obj)).all())


def _call_every_handler(scene):
    """Calls each of the add-on's handler functions directly, as Blender would."""
    hm = _handlers_module()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    hm.on_frame_change(scene, depsgraph)
    hm.on_frame_change(scene)
    hm.on_depsgraph_update(scene, depsgraph)
    hm.on_depsgraph_update(scene)
    hm.on_undo_post(scene)
    hm.on_load_post(None)
    hm.tumbling_frame_change(scene, depsgraph)


# -- errors become reports and pause the object ---------------------------------------------------------------

def test_frame_handler_errors_become_reports_and_pause():
    obj = _enable_bar()
    other = _enable_bar("Other")
    with watched():
        _frames(range(1, 6))
        od = H.runtime().module()
        for exc in (od.SolverError("injected solver failure"), MemoryError("injected"), ZeroDivisionError("bug"),
                    ValueError("injected value")):
            rt = H.runtime().get(obj)
            calls = []

            def broken(frame, *inputs, _exc=exc, _calls=calls):
                _calls.append(frame)
                raise _exc

            rt.engine.begin = broken  # an object's own failure (one of a contact group's pauses all)
            bpy.context.scene.frame_set(6)
            assert calls == [6]
            assert str(exc) in obj.opdeform.error, (exc, obj.opdeform.error)
            paused = H.positions(obj)
            _frames(range(7, 12))  # paused: no more calls, the mesh stays as it was
            assert calls == [6]
            np.testing.assert_array_equal(H.positions(obj), paused)
            assert not other.opdeform.error, "an error on one object paused another"
            del rt.engine.begin  # the instance attribute goes: the class's method is back
            bpy.ops.opdeform.reset(object=obj.name)
            assert not obj.opdeform.error
            bpy.context.scene.frame_set(1)
            _frames(range(2, 6))
            assert _finite(obj)
        _call_every_handler(bpy.context.scene)


def test_an_object_hidden_from_renders_or_viewports_waits_without_an_error():
    """An object hidden from renders is not in a render's evaluation, nor one disabled in viewports in the
    viewport's: the frame handler has no mesh of it to read ("the OPDeform modifier is missing", and the object
    paused, before). It waits, with no error, and plays on when it is shown again."""
    obj = _enable_bar()
    scene = bpy.context.scene
    with watched():
        _frames(range(1, 4))
        before = H.positions(obj)
        obj.hide_render = True
        scene.camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        scene.collection.objects.link(scene.camera)
        from opdeform.blender_render import cycles
        cycles(scene, resolution=(8, 8), samples=1)
        bpy.ops.render.render()  # frame 3 evaluated for the render, without the object
        assert not obj.opdeform.error, obj.opdeform.error
        obj.hide_viewport = True
        _frames(range(4, 7))
        assert not obj.opdeform.error, obj.opdeform.error
        obj.hide_viewport = False
        _frames(range(7, 10))
        assert not obj.opdeform.error, obj.opdeform.error
        assert _finite(obj) and np.abs(H.positions(obj) - before).max() > 1e-4, "it did not play on"


def _posing_bar():
    """The bar in posing mode with a handle at its free end: (object, the handle's empty)."""
    obj = _enable_bar(mode='POSE')
    bpy.ops.opdeform.handle_add(object=obj.name, location=(2.0, 0.0, 0.0))
    return obj, obj.opdeform.handles[0].target


def test_pose_handler_errors_become_reports():
    obj, handle = _posing_bar()
    with watched():
        rt = H.runtime().get(obj)

        def broken(*args):
            raise RuntimeError("injected pose failure")

        rt.engine.pose = broken
        handle.location = (1.8, 0.0, 0.5)
        bpy.context.view_layer.update()  # depsgraph_update_post -> pose_update -> error report
        assert "injected pose failure" in obj.opdeform.error
        handle.location = (1.7, 0.0, 0.6)
        bpy.context.view_layer.update()
        _call_every_handler(bpy.context.scene)


def test_bad_values_from_scripts_do_not_escape():
    """Settings a script may set that the UI would not (NaN handle, NaN floor, start after end)."""
    obj = _enable_bar()
    bpy.ops.opdeform.handle_add(object=obj.name, location=(2.0, 0.0, 0.0))
    handle = obj.opdeform.handles[0].target
    with watched():
        _frames(range(1, 4))
        handle.location = (float("nan"), 0.0, 0.0)
        bpy.context.view_layer.update()
        _frames(range(4, 7))
        assert obj.opdeform.error, "a NaN handle was not reported"
        assert _finite(obj)
        handle.location = (2.0, 0.0, 0.0)
        bpy.ops.opdeform.reset(object=obj.name)
        obj.opdeform.use_floor = True
        obj.opdeform.floor_height = float("inf")
        _frames(range(1, 4))
        obj.opdeform.floor_height = 0.0
        obj.opdeform.error = ""
        obj.opdeform.frame_start, obj.opdeform.frame_end = 20, 5
        _frames([1, 6, 25, -3, 10000])
        _call_every_handler(bpy.context.scene)
        assert _finite(obj)


# -- the object, its handle or its mesh changes between frames ------------------------------------------------

def test_delete_simulated_object_between_frames():
    obj = _enable_bar()
    keep = _enable_bar("Keep")
    bpy.ops.opdeform.handle_add(object=keep.name, location=(2.0, 0.0, 0.0))
    with watched():
        _frames(range(1, 6))
        bpy.data.objects.remove(obj, do_unlink=True)
        _frames(range(6, 12))
        _call_every_handler(bpy.context.scene)
        assert not keep.opdeform.error, keep.opdeform.error
        # the handle's empty goes too
        bpy.data.objects.remove(keep.opdeform.handles[0].target, do_unlink=True)
        _frames(range(12, 16))
        _call_every_handler(bpy.context.scene)
        assert _finite(keep)
        # an object deleted with its mesh datablock
        third = _enable_bar("Third")
        _frames(range(1, 3))
        mesh = third.data
        bpy.data.objects.remove(third, do_unlink=True)
        bpy.data.meshes.remove(mesh)
        _frames(range(3, 6))
        _call_every_handler(bpy.context.scene)


def _remove_vertices(mesh, count):
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bmesh.ops.delete(bm, geom=list(bm.verts)[:count], context='VERTS')
    bm.to_mesh(mesh)
    bm.free()
    mesh.update()


def _subdivision_before_opdeform(obj):
    """A Subdivision modifier put before OPDeform: the input at OPDeform has more vertices than the mesh."""
    obj.modifiers.new("Subdivision", 'SUBSURF')
    H.runtime().modifier.remove(obj)
    H.runtime().modifier.ensure(obj)  # re-added last: after the Subdivision
    assert [m.type for m in obj.modifiers] == ['SUBSURF', 'NODES']


def test_mesh_changes_between_frames_rebuild_or_report():
    """The mesh is the rest shape (the add-on never writes it): a mesh with more or fewer vertices rebuilds on
    the next frame; another mesh without the pin group, or a modifier before OPDeform that changes the
    vertex count, is a report naming the object, and the last good frame stays."""
    obj = _enable_bar()
    with watched():
        _frames(range(1, 6))
        n = len(obj.data.vertices)
        bm = bmesh.new()  # more vertices (subdivided edges)
        bm.from_mesh(obj.data)
        bmesh.ops.subdivide_edges(bm, edges=list(bm.edges)[:4], cuts=1)
        bm.to_mesh(obj.data)
        bm.free()
        obj.data.update()
        _frames(range(6, 9))
        assert not obj.opdeform.error, obj.opdeform.error
        assert H.runtime().get(obj).engine.n_vertices == len(obj.data.vertices) > n
        _remove_vertices(obj.data, 2)  # fewer vertices
        _frames(range(9, 12))
        assert not obj.opdeform.error and H.runtime().get(obj).engine.n_vertices == len(obj.data.vertices)
        own = obj.data  # another mesh datablock put in place of the object's (without the pin group)
        other = bpy.data.meshes.new("Other")
        v, t = H.box_mesh((0, 0, 0), (1, 1, 1), (3, 3, 3))
        other.from_pydata([tuple(map(float, p)) for p in v], [], [tuple(map(int, f)) for f in t])
        obj.data = other
        _frames(range(12, 14))
        assert "Pin" in obj.opdeform.error and "Bar" in obj.opdeform.error, obj.opdeform.error
        obj.data = own
        bpy.ops.opdeform.build(object=obj.name)
        _frames(range(1, 6))
        assert not obj.opdeform.error, obj.opdeform.error
        shown = H.runtime().get(obj).engine.offset.copy()
        _subdivision_before_opdeform(obj)
        _frames(range(6, 8))
        assert "vertex count" in obj.opdeform.error and "Bar" in obj.opdeform.error, obj.opdeform.error
        assert "before OPDeform (Subdivision)" in obj.opdeform.error, obj.opdeform.error  # the modifier named
        np.testing.assert_array_equal(H.runtime().get(obj).engine.offset, shown)  # the last good frame
        assert _finite(obj)
        _call_every_handler(bpy.context.scene)


def test_vertex_count_change_in_posing_mode():
    obj, handle = _posing_bar()
    with watched():
        _subdivision_before_opdeform(obj)
        handle.location = (1.8, 0.0, 0.4)
        bpy.context.view_layer.update()
        assert "vertex count" in obj.opdeform.error, obj.opdeform.error
        _call_every_handler(bpy.context.scene)


def test_rename_between_frames_continues():
    obj = _enable_bar()
    with watched():
        _frames(range(1, 6))
        obj.name = "Renamed"
        _frames(range(6, 12))
        assert not obj.opdeform.error, obj.opdeform.error
        rt = H.runtime().get(obj)
        assert rt is not None and rt.shown == ("frame", 11)


# -- undo, redo, reload ----------------------------------------------------------------------------------------

def test_undo_redo_between_frames():
    obj = H.bar_object()
    bpy.ops.ed.undo_push(message="bar")
    with watched():
        bpy.ops.opdeform.enable(object=obj.name)
        bpy.ops.ed.undo_push(message="enabled")
        _frames(range(1, 8))
        live = H.positions(bpy.data.objects["Bar"])
        bpy.ops.ed.undo()  # back to before Enable
        _frames(range(8, 12))
        obj = bpy.data.objects["Bar"]
        assert not obj.opdeform.enabled
        bpy.ops.ed.redo()
        obj = bpy.data.objects["Bar"]
        assert obj.opdeform.enabled
        bpy.context.scene.frame_set(1)
        _frames(range(2, 8))
        np.testing.assert_array_equal(H.positions(obj), live)
        # undo a deletion: the object comes back and plays again (rebuilt from its stored settings)
        bpy.ops.ed.undo_push(message="before delete")
        bpy.data.objects.remove(obj, do_unlink=True)
        bpy.ops.ed.undo_push(message="deleted")
        _frames(range(8, 10))
        bpy.ops.ed.undo()
        obj = bpy.data.objects["Bar"]
        bpy.context.scene.frame_set(1)
        _frames(range(2, 8))
        assert not obj.opdeform.error, obj.opdeform.error
        np.testing.assert_array_equal(H.positions(obj), live)
        for _ in range(3):  # undo and redo in quick succession between frames
            bpy.ops.ed.undo()
            bpy.context.scene.frame_set(3)
            bpy.ops.ed.redo()
            bpy.context.scene.frame_set(4)
        _call_every_handler(bpy.context.scene)


def test_undo_of_a_vertex_count_change():
    obj = _enable_bar()
    bpy.ops.ed.undo_push(message="built")
    with watched():
        _frames(range(1, 4))
        _remove_vertices(obj.data, 1)
        bpy.ops.ed.undo_push(message="vertex deleted")
        _frames(range(4, 6))
        bpy.ops.ed.undo()
        obj = bpy.data.objects["Bar"]
        _frames(range(6, 9))
        bpy.ops.ed.redo()
        _frames(range(9, 11))
        _call_every_handler(bpy.context.scene)


def test_reload_between_frames():
    obj = _enable_bar()
    path = os.path.join(H.tmpdir(), "robust_reload.blend")
    with watched():
        _frames(range(1, 5))
        bpy.ops.wm.save_as_mainfile(filepath=path)
        _frames(range(5, 9))
        bpy.ops.wm.revert_mainfile()  # reload in the middle of playback
        _frames(range(9, 12))
        obj = bpy.data.objects["Bar"]
        assert not obj.opdeform.error, obj.opdeform.error
        # a file saved with an error pauses the object after loading, without raising
        obj.opdeform.error = "paused before saving"
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        _frames(range(1, 4))
        assert bpy.data.objects["Bar"].opdeform.error == "paused before saving"
        # a file whose mesh lost vertices before saving (it is rebuilt from what it has), then one whose
        # simulated object was deleted
        obj = bpy.data.objects["Bar"]
        obj.opdeform.error = ""
        _remove_vertices(obj.data, 1)
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        _frames(range(1, 4))
        assert _finite(bpy.data.objects["Bar"])
        bpy.data.objects.remove(bpy.data.objects["Bar"], do_unlink=True)
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        _frames(range(1, 4))
        _call_every_handler(bpy.context.scene)


# -- a modal bake stopped part-way ---------------------------------------------------------------------------------

class _Window:
    """Stands in for the window manager and its timer events: background hosts have no window."""

    def __getattr__(self, name):  # progress_begin/update/end, event_timer_add/remove, modal_handler_add
        return lambda *args, **kw: None


def _modal_bake(obj):
    """obj's Bake button as the UI runs it: start_modal, then modal() at each timer event. Returns the operator
    (its reports in ``reports``), the context it is given and its timer event."""
    import types
    modal_bake = importlib.import_module(H.ADDON + ".blender.modal_bake")

    class Bake(modal_bake.ModalBake):
        reports = []

        def report(self, level, message):
            self.reports.append((set(level), message))

        def _begin(self, context):
            return H.runtime().BakeJob(obj, context.scene)

    op = Bake()
    context = types.SimpleNamespace(window_manager=_Window(), window=None, workspace=None, scene=bpy.context.scene)
    assert op.start_modal(context) == {'RUNNING_MODAL'}, op.reports
    timer = types.SimpleNamespace(type='TIMER')
    for _ in range(5):
        assert op.modal(context, timer) == {'RUNNING_MODAL'}, op.reports
    return op, context, timer


def _baked_bar(folder):
    """A bar with a finished bake of frames 1-6 in folder (the last good bake); its PC2 path and bytes."""
    obj = _enable_bar(cache_directory=folder, frame_end=6)
    bpy.ops.opdeform.bake(object=obj.name)
    path = bpy.path.abspath(obj.opdeform.bake_file)
    assert obj.opdeform.baked and H.pc2().pc2_header(path)[3] == 6
    with open(path, "rb") as f:
        return obj, path, f.read()


def _last_bake_kept(obj, path, data):
    names = os.listdir(os.path.dirname(path))
    assert not [n for n in names if n.endswith(".part")], names
    with open(path, "rb") as f:
        assert f.read() == data, "the last good bake was written over"
    assert obj.opdeform.baked and H.runtime().cache_modifier(obj) is not None


def test_modal_bake_stopped_by_a_file_load_leaves_no_part_file():
    """A file loaded while a modal bake runs (the load_pre handler; Blender then cancels the operator): the
    partial file is removed, the object says why its bake stopped, the last good bake and the mesh stay."""
    folder = os.path.join(H.tmpdir(), "modal_load")
    obj, path, data = _baked_bar(folder)
    rest = H.base_positions(obj)
    blend = os.path.join(H.tmpdir(), "modal_load.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    obj.opdeform.frame_end = 60
    op, context, _ = _modal_bake(obj)
    assert os.path.isfile(path + ".part")
    seen = []

    def note_error(*args):  # runs after the add-on's load_pre handler, while the object is still there
        seen.append(bpy.data.objects["Bar"].opdeform.error)

    bpy.app.handlers.load_pre.append(note_error)
    try:
        with watched():
            bpy.ops.wm.open_mainfile(filepath=blend)
    finally:
        if note_error in bpy.app.handlers.load_pre:
            bpy.app.handlers.load_pre.remove(note_error)
    if hasattr(op, "cancel"):  # Blender cancels the modal operators of the windows it rebuilds
        op.cancel(context)
    obj = bpy.data.objects["Bar"]
    _last_bake_kept(obj, path, data)
    assert seen and "file" in seen[0] and "load" in seen[0], seen
    np.testing.assert_array_equal(H.base_positions(obj), rest)
    assert not obj.opdeform.error, "the error of the file left reached the file loaded"


def test_modal_bake_stopped_by_a_vertex_count_change_leaves_no_part_file():
    """The mesh loses vertices part-way through a modal bake: the bake stops at the next frame, removes its
    partial file and says why on the object; the last good bake and the edited mesh stay as they are."""
    folder = os.path.join(H.tmpdir(), "modal_count")
    obj, path, data = _baked_bar(folder)
    obj.opdeform.frame_end = 60
    op, context, timer = _modal_bake(obj)
    _remove_vertices(obj.data, 2)
    edited = H.base_positions(obj)
    try:
        result = op.modal(context, timer)
    except Exception as exc:  # noqa: BLE001 - in the UI Blender prints it and drops the operator
        result = f"{type(exc).__name__}: {exc}"
    _last_bake_kept(obj, path, data)
    assert "vertex count" in obj.opdeform.error and "bake" in obj.opdeform.error, obj.opdeform.error
    assert any("vertex count" in message for _, message in op.reports), op.reports
    assert result == {'CANCELLED'}, result
    np.testing.assert_array_equal(H.base_positions(obj), edited)


def test_modal_bake_of_a_deleted_object_leaves_no_part_file():
    folder = os.path.join(H.tmpdir(), "modal_deleted")
    obj, path, data = _baked_bar(folder)
    obj.opdeform.frame_end = 60
    op, context, timer = _modal_bake(obj)
    bpy.data.objects.remove(obj, do_unlink=True)
    assert op.modal(context, timer) == {'CANCELLED'}, op.reports
    assert any("disappeared" in message for _, message in op.reports), op.reports
    assert sorted(os.listdir(folder)) == ["Bar.pc2", "Bar.pc2.opdeform"], os.listdir(folder)
    with open(path, "rb") as f:
        assert f.read() == data


# -- meshes of several pieces ------------------------------------------------------------------------------------

def _moved(obj, frames):
    """How far each vertex moved over the frames (from the first), with the handlers watched; no error."""
    with watched():
        bpy.context.scene.frame_set(frames[0])
        first = H.positions(obj)
        _frames(frames[1:])
    assert not obj.opdeform.error, obj.opdeform.error
    return np.linalg.norm(H.positions(obj) - first, axis=1)


def test_two_part_object_enables_and_simulates():
    """Two cubes in one object, Goal off and on (Sag 1, so that gravity pulls it off its goal): Enable builds
    without a traceback and both parts move in 10 frames."""
    v, t = H.box_mesh((0.0, 0.0, 1.0), (1.0, 1.0, 2.0), (3, 3, 3))
    for goal in (False, True):
        obj = H.mesh_object(f"Two parts {goal}", np.vstack([v, v + (2.0, 0.0, 0.0)]),
                            np.vstack([t, t + len(v)]))
        obj.opdeform.use_goal, obj.opdeform.sag = goal, 1.0
        bpy.ops.opdeform.enable(object=obj.name)
        assert obj.opdeform.built and not obj.opdeform.error, obj.opdeform.error
        d = _moved(obj, range(1, 12))
        assert d[:len(v)].min() > 1e-3 and d[len(v):].min() > 1e-3, (goal, d[:len(v)].min(), d[len(v):].min())


SHELLS = 9


def _creature():
    """A body (an icosphere of radius 0.5 m) and SHELLS small detached ones (radius 0.06 m: ears, tail, feet)
    in one mesh; (object, the small shells' centres)."""
    from mathutils import Matrix
    centres = [(0.6 * np.cos(a), 0.6 * np.sin(a), 1.0 + 0.1 * k)
               for k, a in enumerate(np.linspace(0.0, 2.0 * np.pi, SHELLS, endpoint=False))]
    mesh = bpy.data.meshes.new("Creature")
    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=3, radius=0.5, matrix=Matrix.Translation((0.0, 0.0, 1.0)))
    for c in centres:
        bmesh.ops.create_icosphere(bm, subdivisions=2, radius=0.06, matrix=Matrix.Translation(c))
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new("Creature", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj, np.array(centres)


def test_detached_shells_are_named():
    """The small shells get no particles (attached rigidly to the body): the panel's warning says how many,
    where, and what to do; they move with the body, without an error."""
    obj, centres = _creature()
    bpy.ops.opdeform.enable(object=obj.name)
    rt = H.runtime().get(obj)
    assert len(rt.attached) == SHELLS, rt.attached
    found = np.array([c for _, c in rt.attached])
    assert np.abs(found[:, None] - centres[None]).max(axis=2).min(axis=0).max() < 1e-5, (found, centres)
    assert {n for n, _ in rt.attached} == {42}, rt.attached  # an icosphere of 2 subdivisions
    panels = importlib.import_module(H.ADDON + ".blender.panels")
    text = [w for w in panels.warnings(rt, 1) if "detached" in w]
    assert len(text) == 1 and f"{SHELLS} detached shells" in text[0] and "rigidly" in text[0], text
    assert "0.60, 0.00, 1.00" in text[0] and "6 more" in text[0], text[0]
    thin = rt.engine.thin_part  # measured on the body only: the shells' own size is no reason to add particles
    assert thin is None or thin[0] > 0.3, thin
    assert _moved(obj, range(1, 12)).min() > 1e-3  # the body falls, the shells with it


def _rigged(obj, follow):
    """obj deformed by a one-bone Armature (every vertex weight 1) that swings 0.3 m aside in 5 frames and back
    in 5, then holds to frame 30; Goal on, the "follow" group painted ``follow`` (one weight a vertex).
    Returns a twin without OPDeform (the armature-only pose)."""
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    bpy.context.scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode='EDIT')
    bone = rig.data.edit_bones.new("Bone")
    bone.head, bone.tail = (0.0, 0.0, 0.5), (0.0, 0.0, 1.5)
    bpy.ops.object.mode_set(mode='OBJECT')
    for frame, x in ((1, 0.0), (6, 0.3), (11, 0.0)):
        rig.pose.bones["Bone"].location[0] = x
        rig.pose.bones["Bone"].keyframe_insert("location", index=0, frame=frame)
    everything = list(range(len(obj.data.vertices)))
    obj.vertex_groups.new(name="Bone").add(everything, 1.0, 'REPLACE')
    group = obj.vertex_groups.new(name="follow")
    for value in np.unique(follow):
        group.add([int(i) for i in np.where(follow == value)[0]], float(value), 'REPLACE')
    obj.modifiers.new("Armature", 'ARMATURE').object = rig
    twin = obj.copy()
    twin.data = obj.data.copy()
    bpy.context.scene.collection.objects.link(twin)
    obj.opdeform.use_goal, obj.opdeform.goal_group = True, "follow"
    return twin


def _trunked():
    """A body (an icosphere of radius 0.5 m at z = 1) and a trunk, a detached tube (radius 0.06 to 0.03 m,
    0.8 m long, 16 rings) hanging from inside the body's side to z = 0.4, in one mesh (a kitbashed creature);
    (object, how far down the trunk each vertex is: 0 on the body and at the trunk's top, 1 at its tip)."""
    from mathutils import Matrix
    mesh = bpy.data.meshes.new("Trunked")
    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=3, radius=0.5, matrix=Matrix.Translation((0.0, 0.0, 1.0)))
    body = len(bm.verts)
    tube = bmesh.ops.create_cone(bm, cap_ends=True, segments=12, radius1=0.03, radius2=0.06, depth=0.8,
                                 matrix=Matrix.Translation((0.45, 0.0, 0.8)))
    sides = [e for e in bm.edges if abs(e.verts[0].co.z - e.verts[1].co.z) > 0.4]
    bmesh.ops.subdivide_edges(bm, edges=sides, cuts=15, use_grid_fill=True)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new("Trunked", mesh)
    bpy.context.scene.collection.objects.link(obj)
    z = np.array([v.co.z for v in mesh.vertices])
    down = np.clip((1.2 - z) / 0.8, 0.0, 1.0)
    down[:body] = 0.0
    return obj, down


def _played(obj, twin, frames):
    """Frames 1 .. frames - 1 played: each frame's distance of every vertex from the armature-only twin's
    (frame, vertex)."""
    off = []
    with watched():
        for frame in range(1, frames):
            bpy.context.scene.frame_set(frame)
            off.append(np.linalg.norm(H.positions(obj) - H.positions(twin), axis=1))
    assert not obj.opdeform.error, obj.opdeform.error
    return np.array(off)


def test_every_look_settles_a_detached_trunk():
    """Each look of the Goal panel on the kitbashed trunk (below), alone in the scene: it swings more than 50 mm
    off the rig during the motion (frames 1-11) and is within 2 mm from 1 s after the motion (frame 35), the
    issue's aim. Floppy at 5/s and Shell Min 0.3 (before stop 41) was 13.7 mm off there (0.36 now)."""
    got = {}
    for look in ("Subtle", "Fleshy", "Floppy"):
        obj, down = _trunked()
        twin = _rigged(obj, 1.0 - 0.9 * down)
        bpy.ops.opdeform.enable(object=obj.name)
        bpy.ops.opdeform.apply_preset(object=obj.name, preset=look)
        off = _played(obj, twin, 38)
        got[look] = (off[:12].max(), off[34:].max())
        for o in (obj, twin, obj.modifiers["Armature"].object):
            bpy.data.objects.remove(o)
    assert all(swing > 0.05 and after < 2e-3 for swing, after in got.values()), got


def test_detached_shells_of_a_rigged_mesh_jiggle():
    """On a mesh an Armature deforms (a kitbashed creature: ears, trunk, eyes as separate shells) every small
    shell gets particles of its own, so it follows its painted Follow: the trunk, 1 at its top to 0.1 at its
    tip, swings off the armature's pose and settles back, the body at 1 stays on it (attached, the trunk moved
    rigidly with the body whatever was painted: 0.0 mm; the outside tester's kitbashed elephant, docs/goals.md).
    Linked to the body from every particle, the trunk moved at most 6 mm while the rig moved it 0.3 m; linked at
    its root (od_BeamShell), 278 mm, and it swung back at 0.8 Hz under Fleshy's damping (9/s: 16 times less
    each half swing): 3.1 mm 1 s after the motion (the motion ends at frame 11), under 2 mm from 1.08 s (frame
    37). With a detached shell's Follow mapped into [Shell Min, 1] (the panel's, 0.3 by default: the tip's 0.1 ->
    0.37, a 0.2 -> 0.64 Hz goal) it is within 2 mm from 1 s after the motion (frame 35), the issue's aim; Shell
    Min 0 gives back the painted Follow on the next frame."""
    obj, down = _trunked()
    twin = _rigged(obj, 1.0 - 0.9 * down)
    bpy.ops.opdeform.enable(object=obj.name)
    rt = H.runtime().get(obj)
    assert rt.attached == () and not obj.opdeform.error, (rt.attached, obj.opdeform.error)
    panels = importlib.import_module(H.ADDON + ".blender.panels")
    assert not [w for w in panels.warnings(rt, 1) if "detached" in w]  # the trunk's top follows at 1
    off = _played(obj, twin, 38)
    assert off[:, down == 0.0].max() < 1e-3, off[:, down == 0.0].max()
    assert off[:12, down > 0.9].max() > 0.05, off[:12, down > 0.9].max()
    assert off[34:].max() < 2e-3, off[34:].max(axis=1)
    held = H.runtime().get(obj).engine.goal_strength.copy()
    obj.opdeform.shell_follow_min = 0.0
    bpy.context.scene.frame_set(38)
    painted = H.runtime().get(obj).engine.goal_strength
    assert not obj.opdeform.error and held.min() > 0.3 and painted.min() < 0.2, (held.min(), painted.min())


def _galloping(obj):
    """obj's rig (``_rigged``) made obj's parent, carried 2.5 m forward and turned 1 radian over frames 1-30,
    easing in and out (the outside pony's gallop, scripts/outside_pony.py, round a bend): the object's own
    transform moves."""
    rig = obj.modifiers["Armature"].object
    obj.parent = rig
    for frame, y, turn in ((1, 0.0, 0.0), (30, -2.5, 1.0)):
        rig.location[1], rig.rotation_euler[2] = y, turn
        rig.keyframe_insert("location", index=1, frame=frame)
        rig.keyframe_insert("rotation_euler", index=2, frame=frame)


def test_a_reopened_file_shows_the_pose_saved():
    """A rigged mesh of loose parts (the kitbashed trunk, below) whose rig gallops away (_galloping), Built at
    frame 5, the Floppy look applied, played and saved at frame 20: opened again it shows the pose saved, within
    0.01 mm, on load and after a frame change. Rebuilt on load in the transform of frame 1 it was 5.6 mm off (bpy
    5.2); in the transform of the frame saved, which Blender 3.4's first frame handler after a load sees, 17.8 mm
    (the outside pony reopened 26 mm off, docs/blender.md)."""
    obj, down = _trunked()
    _rigged(obj, 1.0 - 0.9 * down)
    _galloping(obj)
    bpy.context.scene.frame_set(5)
    bpy.ops.opdeform.enable(object=obj.name)
    bpy.ops.opdeform.apply_preset(object=obj.name, preset="Floppy")
    with watched():
        _frames(range(1, 21))
        saved = H.positions(obj)
        path = os.path.join(H.tmpdir(), "galloping.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        obj = bpy.data.objects["Trunked"]
        shown = H.positions(obj)
        _frames((21, 20))
    assert not obj.opdeform.error, obj.opdeform.error
    assert np.abs(saved - H.animated_positions(obj)).max() > 0.01  # the trunk is off its rig at frame 20
    assert np.abs(shown - saved).max() < 1e-5 and np.abs(H.positions(obj) - saved).max() < 1e-5, \
        (np.abs(shown - saved).max(), np.abs(H.positions(obj) - saved).max())


def test_a_copy_or_an_applied_scale_is_built_where_it_stands():
    """The transform Build kept (runtime.build_transform) is used again only by the object it was kept for and
    with the mesh it was built from (runtime.build_key): a copy of a Built bar moved 3 m up, and the bar after
    Apply Scale saved and reopened, are built where they stand. Before, the copy was laid out in the original's
    place (its runtime at z 1, the copy at 4) and the reopened bar counted its scale twice (8 m for a 4 m bar)."""
    obj = H.bar_object()
    obj.location.z, obj.scale = 1.0, (2.0, 2.0, 2.0)
    bpy.context.view_layer.update()
    bpy.ops.opdeform.enable(object=obj.name)
    copy = obj.copy()
    copy.data = obj.data.copy()
    bpy.context.scene.collection.objects.link(copy)
    copy.location.z = 4.0
    bpy.context.view_layer.update()  # the depsgraph update that finds a new enabled object
    with watched():
        _frames((1, 2))
        assert abs(H.runtime().get(copy).engine.matrix_world[2][3] - 4.0) < 1e-6
        for o in bpy.context.view_layer.objects:
            o.select_set(o == obj)
        bpy.context.view_layer.objects.active = obj
        bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
        path = os.path.join(H.tmpdir(), "applied.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        _frames((1, 2))
        obj = bpy.data.objects["Bar"]
        rest = H.runtime().get(obj).engine.rest
    assert not obj.opdeform.error, obj.opdeform.error
    assert abs(np.ptp(rest[:, 0]) - 4.0) < 1e-4, np.ptp(rest[:, 0])


def test_rigged_shells_painted_loose_all_over_are_named():
    """The small shells of a rigged mesh painted 0.1 all over hold to the body only by their particles' links to
    the nearest body particle: the panel names them and says to paint Follow 1 where they meet the body; painted 1
    somewhere, nothing is said."""
    obj, centres = _creature()
    body = np.arange(len(obj.data.vertices)) < len(obj.data.vertices) - SHELLS * 42  # the shells come last
    _rigged(obj, np.where(body, 1.0, 0.1))
    bpy.ops.opdeform.enable(object=obj.name)
    rt = H.runtime().get(obj)
    panels = importlib.import_module(H.ADDON + ".blender.panels")
    text = [w for w in panels.warnings(rt, 1) if "Follow under 1" in w]
    assert len(text) == 1 and f"{SHELLS} detached shells" in text[0], text
    assert "42 vertices at (0.60, 0.00, 1.00)" in text[0] and "Follow 1 where it meets" in text[0], text
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='WEIGHT_PAINT')  # a repaint is read again after the object leaves Object Mode
    obj.vertex_groups["follow"].add(np.where(~body)[0][:1].tolist(), 1.0, 'REPLACE')  # the first shell's
    bpy.context.view_layer.update()
    bpy.ops.object.mode_set(mode='OBJECT')
    bpy.context.scene.frame_set(2)
    text = [w for w in panels.warnings(rt, 2) if "Follow under 1" in w]
    assert len(text) == 1 and f"{SHELLS - 1} detached shells" in text[0], text


def test_shells_no_bone_moves_are_named():
    """Shells of a rigged mesh with no weight in a bone's vertex group stay where they were modelled while the rig
    moves the rest (the audit's dog: automatic weights left its ears unweighted, and they moved 0.03 mm off a rig
    that did not move them, docs/goals.md): the panel names them and says to weight them to a bone; weighted to it
    in Weight Paint mode, nothing is said."""
    obj, centres = _creature()
    shells = np.arange(len(obj.data.vertices)) >= len(obj.data.vertices) - SHELLS * 42  # the shells come last
    _rigged(obj, np.where(shells, 0.5, 1.0))
    loose = np.where(shells)[0][:2 * 42].tolist()  # the first two shells
    obj.vertex_groups["Bone"].remove(loose)
    bpy.ops.opdeform.enable(object=obj.name)
    rt = H.runtime().get(obj)
    panels = importlib.import_module(H.ADDON + ".blender.panels")
    text = [w for w in panels.warnings(rt, 1) if "no bone moves" in w]
    assert len(text) == 1 and "2 detached shells that no bone moves (42 vertices at (0.60, 0.00, 1.00)" in text[0], text
    assert "bone's vertex group" in text[0], text
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='WEIGHT_PAINT')
    obj.vertex_groups["Bone"].add(loose, 1.0, 'REPLACE')
    bpy.context.view_layer.update()
    bpy.context.scene.frame_set(2)
    bpy.ops.object.mode_set(mode='OBJECT')
    bpy.context.scene.frame_set(3)
    assert not obj.opdeform.error and not [w for w in panels.warnings(rt, 3) if "no bone moves" in w], panels.warnings(rt, 3)


def test_a_follow_group_just_picked_names_no_shell_until_read():
    """Enable first (which ticks Goal on a rigged mesh), then a Follow group picked that paints every shell 1 (the
    order an artist clicks in): until the next frame reads the group the engine still has Follow 0.7 everywhere, and the
    panel named every shell "with Follow under 1 all over" (the audit's dog, stop 38: its head and legs); it says
    nothing about the shells until the group is read, and nothing after, the shells being at 1."""
    obj, _ = _creature()
    _rigged(obj, np.ones(len(obj.data.vertices)))
    s = obj.opdeform
    s.property_unset("use_goal")  # as never clicked: Enable ticks Goal on a rigged mesh (Follow 0.7 everywhere)
    s.property_unset("goal_group")
    bpy.context.view_layer.objects.active = obj
    bpy.ops.opdeform.enable(object=obj.name)
    assert s.use_goal
    s.goal_group = "follow"

    def shown():  # the panel's labels as one text (a long warning is wrapped over several)
        return " ".join(e[1] for e in H.draw_panels() if e[0] == "label")
    assert "Follow under 1" not in shown(), shown()
    bpy.context.scene.frame_set(2)
    assert not s.error and "Follow under 1" not in shown(), (s.error, shown())
    s.goal_group = ""  # Follow 0.7 everywhere, read on the next frame: then every shell is named
    bpy.context.scene.frame_set(3)
    assert f"{SHELLS} detached shells with Follow under 1" in shown(), shown()


def test_one_piece_names_no_shell():
    """A mesh of one piece, and a two-part object whose parts both have particles: no shell named."""
    obj = _enable_bar()
    assert H.runtime().get(obj).attached == ()
    v, t = H.box_mesh((0.0, 0.0, 1.0), (1.0, 1.0, 2.0), (3, 3, 3))
    two = H.mesh_object("Two parts", np.vstack([v, v + (2.0, 0.0, 0.0)]), np.vstack([t, t + len(v)]))
    bpy.ops.opdeform.enable(object=two.name)
    assert H.runtime().get(two).attached == ()


# -- tumbling particles: the baked point cloud's handler ---------------------------------------------------------

def test_tumbling_frames_survive_broken_data():
    v, t = H.box_mesh((0.0, 0.0, -0.1), (1.0, 1.0, 1.0), (2, 2, 2))
    obj = H.mesh_object("Domain", v, t)
    bpy.ops.opdeform.tumbling_enable(object=obj.name)
    s = obj.opdeform_tumbling
    s.dx, s.count, s.frame_start, s.frame_end = 0.1, 60, 1, 4
    s.layer_height, s.layer_thickness = 0.5, 0.2
    s.cache_directory = os.path.join(H.tmpdir(), "robust_domain")
    bpy.ops.opdeform.tumbling_bake(object=obj.name)
    assert s.baked
    tm = _tumbling_module()
    folder = s.baked_folder
    with watched():
        _frames(range(1, 5))
        # a frame file cut short, another one emptied, another one gone
        frames = tm.core.baked_frames(folder)
        with open(tm.core.frame_file(folder, frames[1]), "r+b") as f:
            f.truncate(max(1, os.path.getsize(f.name) // 2))
        open(tm.core.frame_file(folder, frames[2]), "wb").close()
        os.remove(tm.core.frame_file(folder, frames[3]))
        s.error = ""
        _frames([1, 2, 3, 4])
        assert s.error, "damaged or missing baked frames were not reported"
        # the point cloud loses vertices, then is replaced by an empty of the same name
        points = bpy.data.objects[s.points_name]
        bm = bmesh.new()
        bm.from_mesh(points.data)
        bmesh.ops.delete(bm, geom=list(bm.verts)[:10], context='VERTS')
        bm.to_mesh(points.data)
        bm.free()
        _frames([1, 2])
        name = points.name
        bpy.data.objects.remove(points, do_unlink=True)
        empty = bpy.data.objects.new(name, None)
        bpy.context.scene.collection.objects.link(empty)
        _frames([1, 2, 3])
        _call_every_handler(bpy.context.scene)
