"""Per-object simulation state that lives only in memory (the Engine), and the glue between Blender data and
the bpy-free core: reading meshes, vertex groups, handles and the input at opdeform's modifier, writing the
offset that modifier adds (never the mesh's vertex positions), baking.

Nothing here keeps a bpy pointer across calls: runtimes are keyed by the object's session_uid, so undo and
file loads cannot leave dangling references.
"""

import os
import time

import bpy
import numpy as np

from .. import ADDON_PACKAGE
from ..core import handles as handle_math
from ..core import bake_files, loader
from ..core import settings as core_settings
from ..core.frames import BakeFrames
from ..core.colliders import ColliderError
from ..core.contact import Bodies
from ..core.engine import Engine, EngineError, original_input
from . import catch_up, colliders, modifier, presets

MODIFIER_NAME = "OPDeform Cache"
RECENT_FRAMES = 3  # outputs kept for subframes (motion blur) between the last frames shown
CATCH_UP_SECONDS = 0.1  # simulation per frame change in the UI; a far jump goes on in blender/catch_up.py


class AddonError(Exception):
    """A user-facing problem: shown as an error report (operators) or in the panel (handlers)."""


_runtimes = {}
_bodies = Bodies()  # the contact groups of the live objects (core/contact.py)


class Runtime:
    """What the add-on holds for one object between frames."""

    def __init__(self, engine, graph_key, pins, goal_weights):
        self.engine = engine
        self.graph_key = graph_key  # settings the graph was built with (particles, mode, ...)
        self.pins = pins  # (indices, weights) read from the pin group at Build
        self.goal_weights = goal_weights  # per-vertex weights of the goal group (None: 1 everywhere)
        self.handle_matrices = None  # bytes of the handle transforms last used
        self.shown = None  # what the modifier shows: ("rest"|"frame"|"pose", frame)
        self.recent = {}  # frame -> output (float32), the last RECENT_FRAMES frames shown
        self.baking = False  # a bake computes frames without writing the offset
        # seconds of simulation per frame change (None: all the frames asked for, as scripts and renders need)
        self.budget = None if bpy.app.background else CATCH_UP_SECONDS
        self.timing = {}
        self.started = None  # when the frame being shown began (perf_counter)

    def remember(self, frame, out):
        self.recent[frame] = out.copy()
        for f in sorted(self.recent)[:-RECENT_FRAMES]:
            del self.recent[f]

    @property
    def deformed(self):
        return self.shown is not None and self.shown[0] != "rest"


def key(obj):
    return getattr(obj, "session_uid", None) or obj.name


def get(obj):
    return _runtimes.get(key(obj))


def drop(obj):
    _runtimes.pop(key(obj), None)


def clear():
    _runtimes.clear()
    _bodies.clear()


def items():
    return list(_runtimes.items())


def prune(valid_keys):
    """Forgets the runtimes of objects that are gone (after undo or a file load)."""
    for k in [k for k in _runtimes if k not in valid_keys]:
        del _runtimes[k]


def module():
    od, error = loader.load(ADDON_PACKAGE)
    if od is None:
        raise AddonError(error)
    return od


# -- reading Blender data ------------------------------------------------------------------------------
def check_object(obj):
    if obj is None:
        raise AddonError("no object: select a mesh object or pass object=NAME")
    if obj.type != 'MESH':
        kind = obj.type.lower()
        article = "an" if kind[0] in "aeiou" else "a"
        raise AddonError(f"{obj.name!r} is {article} {kind} object, not a mesh: oriented particles simulate "
                         "meshes")
    mesh = obj.data
    if len(mesh.vertices) == 0:
        raise AddonError(f"mesh {mesh.name!r} has no vertices")
    if len(mesh.polygons) == 0:
        raise AddonError(f"mesh {mesh.name!r} has no faces: oriented particles need a surface or a volume")
    if obj.mode == 'EDIT':
        raise AddonError(f"{obj.name!r} is in Edit Mode: leave it first")


def vertex_positions(mesh):
    buf = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    attr = mesh.attributes.get("position")
    if attr is not None and attr.data_type == 'FLOAT_VECTOR' and attr.domain == 'POINT':
        attr.data.foreach_get("vector", buf)
    else:
        mesh.vertices.foreach_get("co", buf)
    return buf.reshape(-1, 3)


def triangles(mesh):
    mesh.calc_loop_triangles()
    tri = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", tri)
    return tri.reshape(-1, 3)


def read_vertex_group(obj, name, what):
    """(indices, weights) of the group's vertices with a weight above zero; None without a group name."""
    if not name:
        return None
    group = obj.vertex_groups.get(name)
    if group is None:
        raise AddonError(f"{what} group {name!r} is not a vertex group of {obj.name!r}")
    gi = group.index
    idx, w = [], []
    for v in obj.data.vertices:
        for g in v.groups:
            if g.group == gi and g.weight > 0.0:
                idx.append(v.index)
                w.append(g.weight)
    if not idx:
        raise AddonError(f"{what} group {name!r} of {obj.name!r} has no vertices (or only zero weights)")
    return np.array(idx, dtype=np.int64), np.array(w, dtype=np.float64)


def read_goal_weights(obj, settings):
    """The goal group as one weight per vertex (0 outside the group); None without a group."""
    group = read_vertex_group(obj, settings.goal_group, "goal")
    if group is None:
        return None
    weights = np.zeros(len(obj.data.vertices))
    weights[group[0]] = group[1]
    return weights


def handle_matrix(item, depsgraph=None):
    target = item.target
    if depsgraph is not None:
        target = target.evaluated_get(depsgraph)
    return np.array(target.matrix_world, dtype=np.float64)


def active_handles(settings):
    return [h for h in settings.handles if h.target is not None]


def bind_handle(item, rest_world, depsgraph=None):
    m = handle_math.check_matrix(item.target.name, handle_matrix(item, depsgraph))
    item.vertex = handle_math.nearest_vertex(rest_world, m[:3, 3])
    item.rest_matrix = m.T.reshape(-1)  # column-major like Blender's matrices
    item.bound_name = item.target.name


def _rest_matrix(item):
    return np.array(item.rest_matrix, dtype=np.float64).reshape(4, 4).T


def handle_targets(rt, settings, depsgraph=None):
    """(H, 4, 3) targets of the handles now, or None without handles. Raises AddonError on a NaN or degenerate
    handle transform."""
    hs = active_handles(settings)
    if not hs:
        rt.handle_matrices = b""
        return None
    rest = rt.engine.rest
    out = np.empty((len(hs), 4, 3))
    seen = []
    for i, h in enumerate(hs):
        try:
            m = handle_math.check_matrix(h.target.name, handle_matrix(h, depsgraph))
        except handle_math.HandleError as exc:
            raise AddonError(str(exc)) from None
        seen.append(m)
        out[i] = handle_math.targets(rest[h.vertex], _rest_matrix(h), m)
    rt.handle_matrices = np.array(seen).tobytes()
    return out


def handle_signature(settings, depsgraph=None):
    hs = active_handles(settings)
    if not hs:
        return b""
    return np.array([handle_matrix(h, depsgraph) for h in hs]).tobytes()


# -- settings ------------------------------------------------------------------------------------------
def graph_key(settings):
    return (settings.particles, settings.graph_mode, settings.neighbors, settings.pin_group, settings.goal_group)


def frame_range(settings, scene):
    """(start, end) of the cache: the scene's frame range while Scene Range is on, else the object's own."""
    if settings.use_scene_range:
        return scene.frame_start, scene.frame_end
    return settings.frame_start, settings.frame_end


def frame_rate(scene):
    return scene.render.fps / scene.render.fps_base


def gravity(settings, scene):
    use = scene.use_gravity and (settings.mode == 'DYNAMIC' or settings.pose_gravity)
    return tuple(scene.gravity) if use else (0.0, 0.0, 0.0)


def sim_settings(settings, scene, graph):
    """(Simulation parameters, set_solver arguments) of the settings for this graph (core/settings.py)."""
    fps = frame_rate(scene)
    return core_settings.solver_settings(module(), graph, presets.units(settings, fps), fps,
                                         gravity(settings, scene))


def floor(settings):
    return (settings.floor_height, settings.floor_friction) if settings.use_floor else None


def signature(settings, scene, contact):
    """Everything a bake depends on, as text: a bake whose signature differs is outdated."""
    hs = tuple((h.target.name, h.vertex, h.use_rotation, round(h.strength, 9)) for h in active_handles(settings))
    parts = (graph_key(settings), presets.units(settings, frame_rate(scene)), gravity(settings, scene),
             floor(settings), settings.pin_strength,
             hs, frame_range(settings, scene), settings.mode, goal_strength(settings))
    return repr((*parts, self_contact(contact), body_contact(contact)))


def self_contact(contact):
    """set_self_contact's arguments from the object's contact settings (None: Self Collision off)."""
    if not contact.use_self_collision:
        return None
    return dict(thickness=contact.self_distance, friction=colliders.FRICTION_SCALE * contact.self_friction)


def body_contact(contact):
    return contact.object_distance, colliders.FRICTION_SCALE * contact.object_friction


def goal_strength(settings):
    """The goal strength in use: None when off (and in posing mode, which has no animation to follow)."""
    return settings.goal_strength if settings.use_goal and settings.mode == 'DYNAMIC' else None


def bind_new_handles(rt, settings, depsgraph=None):
    """Binds handles seen for the first time (or given another empty) to their nearest rest vertex."""
    rest = rt.engine.rest
    for h in active_handles(settings):
        if h.vertex < 0 or h.bound_name != h.target.name or h.vertex >= len(rest):
            try:
                bind_handle(h, rest, depsgraph)
            except handle_math.HandleError as exc:
                raise AddonError(str(exc)) from None


def configure(rt, obj, scene, depsgraph=None):
    """Applies the current settings to the engine (a change clears the in-memory cache)."""
    s = obj.opdeform
    bind_new_handles(rt, s, depsgraph)
    e = rt.engine
    params, solver = sim_settings(s, scene, e.graph)
    try:
        e.configure(params, presets.substeps(s, frame_rate(scene)), floor(s), *frame_range(s, scene), solver)
    except EngineError as exc:
        raise AddonError(f"{obj.name}: {exc}") from None
    pins = rt.pins or (np.zeros(0, np.int64), None)
    handles = [(h.vertex, h.use_rotation, h.strength) for h in active_handles(s)]
    e.set_constraints(pins[0], pins[1], s.pin_strength, handles)
    e.set_goal(goal_strength(s), rt.goal_weights)
    e.set_contact(self_contact(obj.opdeform_contact), body_contact(obj.opdeform_contact))


# -- build ---------------------------------------------------------------------------------------------
def build(obj, scene, depsgraph=None):
    """Builds (or rebuilds) the graph, the skin and the simulation of obj. Raises AddonError and changes
    nothing on bad input."""
    check_object(obj)
    od = module()
    s = obj.opdeform
    rest = vertex_positions(obj.data)
    pins = read_vertex_group(obj, s.pin_group, "pin")
    goal_weights = read_goal_weights(obj, s)
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    for h in active_handles(s):  # validate before changing anything
        try:
            handle_math.check_matrix(h.target.name, handle_matrix(h, depsgraph))
        except handle_math.HandleError as exc:
            raise AddonError(str(exc)) from None
    try:
        engine = Engine(od, rest, triangles(obj.data), matrix, s.particles, s.graph_mode, s.neighbors)
    except EngineError as exc:
        raise AddonError(f"{obj.name}: {exc}") from None
    rt = Runtime(engine, graph_key(s), pins, goal_weights)
    for h in active_handles(s):
        bind_handle(h, engine.rest, depsgraph)
    try:
        configure(rt, obj, scene, depsgraph)
    except (EngineError, ValueError, od.SolverError) as exc:
        raise AddonError(f"{obj.name}: {exc}") from None
    # committed: from here on the object changes
    modifier.ensure(obj)
    _runtimes[key(obj)] = rt
    s.built = True
    if s.error:
        s.error = ""
    show_rest(obj, rt)
    return rt


def ensure(obj, scene, depsgraph=None):
    """The object's runtime; rebuilt from the stored settings after a file load or undo, and when the mesh
    changed since Build (Edit Mode edits reach the rest shape)."""
    rt = get(obj)
    if rt is None and obj.opdeform.built or rt is not None and not np.array_equal(
            vertex_positions(obj.data), rt.engine.rest_local):
        rt = build(obj, scene, depsgraph)
    return rt


def show_rest(obj, rt):
    rt.engine.rest_output()
    modifier.clear_offset(obj.data)
    rt.shown = ("rest", None)


def check_writable(obj):
    """Live playback writes the offset into the mesh: refused for a linked mesh and a mesh shared by objects."""
    mesh = obj.data
    if mesh.library is not None:
        raise AddonError(f"{obj.name}: its mesh {mesh.name!r} is linked from a library (a library override?): "
                         "live playback cannot write it; Bake instead, the bake plays on the override")
    users = [o.name for o in bpy.data.objects if o.data == mesh and o != obj]
    if users:
        raise AddonError(f"{obj.name}: its mesh {mesh.name!r} is shared with {', '.join(users)} (linked "
                         "duplicates): live playback would move them all; Object > Relations > Make Single User, "
                         "or Bake (each object plays its own bake)")


def frame_input(obj, rt, depsgraph):
    """(the object-space positions reaching opdeform's modifier, the object's transform) in this evaluation."""
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    positions, index = modifier.read_input(evaluated.data, rt.engine.n_vertices)
    if positions is None:
        raise AddonError(f"{obj.name}: the OPDeform modifier is missing or disabled: press Build to add it")
    try:
        incoming = original_input(positions, index, rt.engine.n_vertices)
    except EngineError as exc:
        raise AddonError(f"{obj.name}: {exc}") from None
    return incoming, np.array(evaluated.matrix_world, dtype=np.float64)


def show(obj, rt, offset):
    """Writes the offset (float32 (V, 3)) the modifier adds, unless a bake computes the frames."""
    if rt.baking:
        return
    check_writable(obj)
    modifier.write_offset(obj.data, offset)


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


def cache_modifier(obj):
    mod = obj.modifiers.get(MODIFIER_NAME)
    return mod if mod is not None and mod.type == 'MESH_CACHE' else None


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
    configure(rt, obj, scene, depsgraph)
    incoming, matrix = frame_input(obj, rt, depsgraph)
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
    try:
        return _bodies.simulate(module(), runs, budget)
    except (EngineError, ColliderError, ValueError, module().SolverError) as exc:
        names = ", ".join(o.name for o in objects)
        raise AddonError(f"{names}{' (in contact)' if len(objects) > 1 else ''}: {exc}") from None


def forget_groups():
    """Forgets the contact groups of objects rebuilt or gone (groups of other scenes stay)."""
    _bodies.keep_only({id(rt.engine.sim) for rt in _runtimes.values()})


def frame_shown(obj, rt, run, out):
    """Live playback, second half: writes the frame reached (the catch-up goes on when frames are missing)."""
    frame = run.frame
    shown = frame - rt.engine.behind
    if rt.engine.behind:
        catch_up.start()  # the frames still missing are simulated in the background of the UI
    else:
        rt.remember(frame, out)
    t1 = time.perf_counter()
    show(obj, rt, rt.engine.offset)
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
    incoming = frame_input(obj, rt, depsgraph)[0]
    try:
        rt.engine.pose(targets, s.pose_iterations, incoming)
    except EngineError as exc:
        raise AddonError(str(exc)) from None
    show(obj, rt, rt.engine.offset)
    rt.shown = ("pose", None)
    return True


# -- bake ----------------------------------------------------------------------------------------------
def cache_folder(folder):
    """The absolute path of a cache folder setting ('//': next to the .blend, which must be saved then)."""
    if folder.startswith("//") and not bpy.data.filepath:
        raise AddonError("save the .blend file first, or choose an absolute cache folder")
    return bpy.path.abspath(folder)


def bake_path(obj):
    folder = obj.opdeform.cache_directory or "//opdeform_cache"
    name = bpy.path.clean_name(obj.name) + ".pc2"
    return os.path.join(cache_folder(folder), name), os.path.join(folder, name)


def identity(obj):
    """What finds an object again after a rename: its session_uid (Blender 3.5+), else its address."""
    return getattr(obj, "session_uid", None) or obj.as_pointer()


def find_object(ident, name):
    """The object of an identity(), else of the name."""
    return next((o for o in bpy.data.objects if identity(o) == ident), None) or bpy.data.objects.get(name)


class BakeJob(BakeFrames):
    """A bake one frame at a time: live playback's own code path (frame_set runs the frame handler) writing
    every frame to a PC2 file. Stopping early keeps the frames written so far. Everything is checked and the
    output file opened (core/bake_files.py) before the scene changes; the previous bake and its Mesh Cache
    modifier stay until this one finishes with frames."""

    def __init__(self, obj, scene):
        s = obj.opdeform
        if not s.enabled:
            raise AddonError(f"{obj.name!r}: enable oriented particles first")
        if s.mode != 'DYNAMIC':
            raise AddonError(f"{obj.name!r}: bake needs Dynamics mode (posing mode has no frames to bake)")
        if s.error:
            raise AddonError(f"{obj.name!r}: {s.error} (press Reset)")
        self.start, self.end = frame_range(s, scene)
        if self.end < self.start:
            raise AddonError("the cache's end frame is before its start frame")
        self.path, self.stored_path = bake_path(obj)
        self.rt = ensure(obj, scene) or build(obj, scene)
        if self.rt.baking:
            raise AddonError(f"{obj.name!r} is being baked already")
        try:
            self.writer = module().io.PC2Writer(bake_files.prepare(self.path), self.rt.engine.n_vertices, self.start, 1.0,
                                                atomic=False)
        except OSError as exc:
            raise AddonError(f"{obj.name}: {exc}") from None
        self.obj_name, self.obj_ident = obj.name, identity(obj)
        self.scene = scene
        self.frame = self.start
        self.original_frame = scene.frame_current
        self.rt.engine.invalidate()
        self.rt.baking = True
        self.started = time.perf_counter()

    @property
    def obj(self):
        obj = find_object(self.obj_ident, self.obj_name)
        if obj is not None and obj.name != self.obj_name:  # renamed: the runtime follows (keyed by name < 3.5)
            _runtimes.pop(self.obj_name, None)
            _runtimes[key(obj)] = self.rt
            self.obj_name = obj.name
            from . import handlers
            handlers.mark_discovery()
        return obj

    def step(self):
        """Bakes one frame. Raises AddonError when the simulation reported an error."""
        obj = self.obj
        if obj is None:
            raise AddonError(f"object {self.obj_name!r} disappeared during the bake")
        self.scene.frame_set(self.frame)
        rt = get(obj)
        if obj.opdeform.error:
            raise AddonError(obj.opdeform.error)
        if rt is None or rt.shown is None or rt.shown[1] != self.frame:
            raise AddonError(f"frame {self.frame} was not simulated")
        self.writer.write(rt.engine.out)
        self.frame += 1

    def finish(self):
        """Closes the file and adds the Mesh Cache modifier (first in the stack). Returns frames baked."""
        self.writer.close()
        self.rt.baking = False
        obj = self.obj
        count = self.writer.count
        if obj is None or count == 0:
            bake_files.discard(self.path)
            return count
        bake_files.commit(self.path)
        s = obj.opdeform
        old = cache_modifier(obj)
        if old is not None:
            obj.modifiers.remove(old)
        mod = obj.modifiers.new(MODIFIER_NAME, 'MESH_CACHE')
        mod.cache_format = 'PC2'
        mod.filepath = self.stored_path
        mod.frame_start = self.start
        mod.frame_scale = 1.0
        mod.time_mode = 'FRAME'
        mod.play_mode = 'SCENE'
        mod.forward_axis = 'POS_Y'
        mod.up_axis = 'POS_Z'
        mod.deform_mode = 'OVERWRITE'
        mod.interpolation = 'LINEAR'  # subframes (motion blur) blend frames, as live playback does
        _move_after_opdeform(obj, mod)
        s.baked = True
        s.bake_file = self.stored_path
        s.bake_signature = signature(s, self.scene, obj.opdeform_contact)
        modifier.clear_offset(obj.data)  # the Mesh Cache modifier shows the frames
        self.scene.frame_set(self.original_frame)
        return count


def _move_after_opdeform(obj, mod):
    """The baked frames replace the OPDeform modifier's output where it sits in the stack (the bake holds the
    input too: Armature and all); modifiers after it (a Subdivision) still apply."""
    index = list(obj.modifiers).index(mod)
    target = modifier.index(obj) + 1 if modifier.get(obj) is not None else 0
    if target == index:
        return
    if hasattr(obj.modifiers, "move"):
        obj.modifiers.move(index, target)
        return
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=target)


def free_bake(obj, delete_file=True):
    """Removes the Mesh Cache modifier; deletes the PC2 file only if this add-on's bake wrote it. Returns the
    path of a file kept because it was not (None otherwise)."""
    s = obj.opdeform
    mod = cache_modifier(obj)
    path = bpy.path.abspath(mod.filepath) if mod is not None else (bpy.path.abspath(s.bake_file)
                                                                  if s.bake_file else "")
    if mod is not None:
        obj.modifiers.remove(mod)
    kept = path if delete_file and path and os.path.isfile(path) and not bake_files.delete(path) else None
    s.baked = False
    s.bake_file = ""
    s.bake_signature = ""
    rt = get(obj)
    if rt is not None:
        rt.engine.invalidate()
    return kept


def bake_outdated(obj, scene):
    s = obj.opdeform
    return s.baked and s.bake_signature != signature(s, scene, obj.opdeform_contact)
