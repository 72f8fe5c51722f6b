"""Live playback: every live object of a scene to its current frame (those in contact step together,
core/contact.py), posing mode's static solve, and the start of the catch-up after a far jump in the UI
(the modal operator is blender/catch_up.py). The app handlers (handlers.py) call this.

Nothing here raises from a frame: an error becomes ``obj.opdeform.error`` (shown in the panel and printed),
and that object's simulation pauses until Reset.
"""

import time

import bpy
import numpy as np

from ..core import contact
from ..core.colliders import ColliderError
from ..core.engine import EngineError
from . import colliders, modifier
from .compiled import AddonError, module
from .discovery import enabled_objects
from .handle_data import handle_targets
from .parameters import frame_range
from .runtime import cache_modifier, configure, ensure, evaluated_object, frame_input, show
from .state import bodies, forget_groups, get

_catch_up = {"running": False}  # the modal Catch Up (catch_up.py) is running


def subframe_offset(rt, frame, subframe, incoming):
    """Between frames (motion blur): the outputs of the frame and the next blended as the Mesh Cache modifier
    blends a bake (linearly, in float32), minus this input. None when either was not shown just before: a
    subframe never simulates."""
    if frame not in rt.recent or frame + 1 not in rt.recent:
        return None
    t = np.float32(subframe)
    return rt.recent[frame] * (np.float32(1.0) - t) + rt.recent[frame + 1] * t - incoming


def set_error(obj, message):
    """Pauses the object's simulation with a message (panel, console, scripts: obj.opdeform.error)."""
    if obj.opdeform.error != message:
        obj.opdeform.error = message
    print(f"opdeform: {obj.name}: {message}")


def is_live(obj):
    """Whether playback should simulate obj now (enabled, no error, not baked, not being edited, its
    modifier on)."""
    s = obj.opdeform
    mod = modifier.get(obj) if obj.type == 'MESH' else None
    rt = get(obj)
    baking = rt is not None and rt.baking  # a new bake replaces the old one's modifier when it finishes
    return (s.enabled and s.built and not s.error and mod is not None and mod.show_viewport
            and obj.mode != 'EDIT' and not (s.baked and cache_modifier(obj) is not None and not baking))


# -- per frame -----------------------------------------------------------------------------------------
def frame_run(obj, scene, depsgraph=None):
    """Live playback, first half: the object's runtime and its way to the current frame (core/engine.py
    ``FrameRun``), or None when there is nothing to simulate (posing, a subframe: shown here)."""
    t0 = time.perf_counter()
    rt = ensure(obj, scene, depsgraph)
    if rt is None or obj.opdeform.mode != 'DYNAMIC':
        return None
    evaluated = evaluated_object(obj, depsgraph)
    configure(rt, obj, scene, depsgraph, evaluated)
    incoming, matrix = frame_input(obj, rt, evaluated)
    frame, subframe = scene.frame_current, scene.frame_subframe
    if subframe > 0.0:
        offset = subframe_offset(rt, frame, subframe, incoming)
        if offset is not None:
            show(obj, rt, offset)
        return None
    targets = handle_targets(rt, obj.opdeform, depsgraph)
    try:
        run = rt.engine.begin(frame, targets, incoming, matrix, colliders.surroundings(obj, scene, depsgraph))
    except (EngineError, ColliderError) as exc:
        raise AddonError(f"{obj.name}: {exc}") from None
    rt.started = t0
    return rt, run


def simulate_together(objects, runtimes, runs):
    """Live playback, the middle: the outputs of objects whose runs step together (core/contact.py), in
    contact when more than one. AddonError naming them all on a failure."""
    budget = None if any(rt.baking or rt.budget is None for rt in runtimes) else runtimes[0].budget
    note_overlaps(objects, runtimes, runs)
    try:
        return bodies.simulate(module(), runs, budget)
    except (EngineError, ColliderError, ValueError, module().SolverError) as exc:
        names = ", ".join(o.name for o in objects)
        raise AddonError(f"{names}{' (in contact)' if len(objects) > 1 else ''}: {exc}") from None


def note_overlaps(objects, runtimes, runs):
    """Each runtime's ``overlaps``: the names of the objects stepping with it that overlap it at rest without a
    Goal on both (core/contact.py ``overlapping``), for the panel."""
    names = [[] for _ in runs]
    for k, l in bodies.overlapping(runs):
        names[k].append(objects[l].name)
        names[l].append(objects[k].name)
    for rt, named in zip(runtimes, names):
        rt.overlaps = tuple(named)


def frame_shown(obj, rt, run, out):
    """Live playback, second half: writes the frame reached (the catch-up goes on when frames are missing)."""
    frame = run.frame
    shown = frame - rt.engine.behind
    if rt.engine.behind:
        start_catch_up()  # the frames still missing are simulated in the background of the UI
    else:
        rt.remember(frame, out)
    t1 = time.perf_counter()
    show(obj, rt, rt.engine.offset, simulated=run.plan.kind == "simulate")
    rt.shown = ("rest" if frame <= rt.engine.start else "frame", shown)
    t2 = time.perf_counter()
    rt.timing = dict(rt.engine.timing, total=t2 - rt.started, write=t2 - t1)
    return rt


def pose_update(obj, scene, depsgraph=None, force=False):
    """Posing mode: re-solve the static pose when a handle moved (or when forced). Returns True if solved."""
    rt = ensure(obj, scene, depsgraph)
    if rt is None:
        return False
    s = obj.opdeform
    configure(rt, obj, scene, depsgraph)
    before = rt.handle_matrices
    targets = handle_targets(rt, s, depsgraph)
    if not force and rt.handle_matrices == before and rt.shown is not None and rt.shown[0] == "pose":
        return False
    incoming = frame_input(obj, rt, evaluated_object(obj, depsgraph))[0]
    try:
        rt.engine.pose(targets, s.pose_iterations, incoming)
    except EngineError as exc:
        raise AddonError(str(exc)) from None
    show(obj, rt, rt.engine.offset)
    rt.shown = ("pose", None)
    return True


def message(exc):
    return str(exc) if isinstance(exc, AddonError) else f"{type(exc).__name__}: {exc}"


def safely(obj, fn, *args, **kw):
    try:
        return fn(obj, *args, **kw)
    except Exception as exc:  # AddonError, a solver failure or a bug: report it, never raise from a handler
        set_error(obj, message(exc))
    return None


def live_dynamic(scene):
    return [o for o in enabled_objects(scene) if is_live(o) and o.opdeform.mode == 'DYNAMIC']


def in_evaluation(obj, depsgraph):
    """Whether this evaluation has obj: an object hidden from renders (in a render's evaluation) or disabled in
    viewports, or in an excluded collection, has no evaluated mesh to read; it waits, and its frames catch up
    when an evaluation has it again."""
    return obj.evaluated_get(depsgraph).is_evaluated


def replay_to_current(scene):
    """A file just opened: its live objects simulated frame by frame from the start of their caches to the
    scene's frame, as playback made them (a jump would blend the animation over the frames it skips), so the
    file shows the pose it was saved with. Returns the frames played."""
    objects = live_dynamic(scene)
    current = scene.frame_current
    first = min((frame_range(o.opdeform, scene)[0] for o in objects), default=current)
    for frame in range(first, current):
        scene.frame_set(frame)
    scene.frame_set(current)
    return max(0, current - first + 1) if objects else 0


def simulate_frame(scene, depsgraph=None):
    """Every live object to the scene's frame: those that can step together in contact (core/contact.py), the
    others alone. A failure pauses the objects it concerns."""
    evaluation = depsgraph or bpy.context.evaluated_depsgraph_get()  # once a frame, not once an object
    objects = [obj for obj in live_dynamic(scene) if in_evaluation(obj, evaluation)]
    started = [(obj, r) for obj in objects if (r := safely(obj, frame_run, scene, depsgraph))]
    by_run = {id(run): (obj, rt) for obj, (rt, run) in started}
    for runs in contact.partition([run for _, (_, run) in started]):
        objects, runtimes = zip(*(by_run[id(r)] for r in runs))
        try:
            outputs = simulate_together(objects, runtimes, runs)
        except Exception as exc:  # AddonError naming them, or a bug: report it, never raise from a handler
            for obj in objects:
                set_error(obj, message(exc))
            continue
        for obj, rt, run, out in zip(objects, runtimes, runs, outputs):
            safely(obj, frame_shown, rt, run, out)
    forget_groups()


# -- catch-up --------------------------------------------------------------------------------------------
def catch_up_running(running):
    """The modal Catch Up started or ended."""
    _catch_up["running"] = running


def _invoke_catch_up():
    wm = bpy.context.window_manager
    if not _catch_up["running"] and wm.windows:
        with bpy.context.temp_override(window=wm.windows[0]):
            bpy.ops.opdeform.catch_up('INVOKE_DEFAULT')
    return None


def start_catch_up():
    """Starts the catch-up after this handler returns (operators cannot run inside a frame handler)."""
    invoke = _invoke_catch_up
    if not bpy.app.background and not _catch_up["running"] and not bpy.app.timers.is_registered(invoke):
        bpy.app.timers.register(invoke, first_interval=0.0)
