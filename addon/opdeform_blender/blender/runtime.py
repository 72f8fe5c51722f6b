"""An object's engine in Blender: built from the mesh and its settings (core/engine.py), configured, fed the
input that reaches opdeform's modifier, shown through the offset that modifier adds (never the mesh's vertex
positions), and baked to a PC2 file played by a Mesh Cache modifier. Live playback frame by frame is
playback.py; what is kept in memory per object is state.py.

Nothing here keeps a bpy pointer across calls (state.py keys runtimes by session_uid).
"""

import os
import time
import zlib

import bpy
import numpy as np

from ..core import bake_files, checks
from ..core import handles as handle_math
from ..core.engine import Engine, EngineError, original_input
from ..core.frames import BakeFrames
from ..core.settings import region_damping
from . import modifier, presets
from .compiled import AddonError, module
from .discovery import mark_discovery
from .handle_data import active_handles, bind_handle, bind_new_handles, handle_matrix
from .mesh_data import (bone_moved, check_object, edges, group_index, read_vertex_group, read_weights,
                        triangles, vertex_positions)
from .parameters import (body_contact, cache_folder, floor, frame_range, frame_rate, gravity, goal_strength,
                         graph_key, maps, self_contact, settings_key, sim_settings)
from .state import Runtime, get, put, renamed

MODIFIER_NAME = "OPDeform Cache"
MAP_NAMES = ("follow", "softness", "damping")  # the painted maps as errors name them (modifier.MAPS order)


# -- build ---------------------------------------------------------------------------------------------
def configure(rt, obj, scene, depsgraph=None, evaluated=None):
    """Applies the current settings to the engine (a change clears the in-memory cache). Skipped while what it
    reads is as last time (parameters.settings_key, 0.01 ms; configuring the character: 0.15 ms a frame) and no
    painted map is to be read again (group_weights; changed_maps with ``evaluated``, the object of this frame's
    evaluation)."""
    key = settings_key(obj, scene)
    changed = evaluated is not None and changed_maps(rt, obj, evaluated)
    if (key, tuple(rt.groups)) == rt.configured and not changed and obj.mode == 'OBJECT':
        return
    rt.configured = None  # a failure below leaves it to be configured again
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
    set_maps(rt, obj, scene)
    if obj.mode != 'OBJECT':  # where bone weights are painted and assigned too
        find_unrigged(rt, obj)
    e.set_contact(self_contact(obj.opdeform_contact), body_contact(obj.opdeform_contact))
    rt.configured = (key, tuple(rt.groups))


def find_unrigged(rt, obj):
    """Keeps in the runtime the mesh's pieces that no bone moves (checks.unrigged_pieces), for the panel: found at
    Build and again, as the painted maps, while the object is in another mode than Object Mode."""
    rt.unrigged = checks.unrigged_pieces(rt.pieces, bone_moved(obj), rt.engine.rest_local)


def picked_groups(s):
    """The vertex groups the painted maps use (modifier.MAPS order: follow, softness, damping; "" for none)."""
    group, _, _, soft_group, _, damp_group, _, _ = maps(s)
    return (group if goal_strength(s) is not None else "", soft_group, damp_group)


def changed_maps(rt, obj, evaluated):
    """Whether a picked group's weights differ from those read (group_weights reads them again): compared with
    the weights OPDeform's modifier stored in the evaluated object (modifier.read_maps), so a change by a script,
    Weight Paint or Edit Mode is applied on the next frame. A picked group that is gone (removed, renamed) raises
    AddonError naming it. The modifier's inputs are fed again only when the picked groups change."""
    names = picked_groups(obj.opdeform)
    for what, name in zip(MAP_NAMES, names):
        if name:
            group_index(obj, name, what)
    if feed_maps(rt, obj, names):  # evaluated again after this frame: nothing of these groups to read yet
        return False
    read = [k for k, name in enumerate(names) if name and name in rt.groups]
    weights = modifier.read_maps(evaluated.data, rt.engine.n_vertices) if read else None
    if weights is None:
        return False
    changed = [names[k] for k in read if not np.array_equal(weights[:, k], rt.groups[names[k]])]
    for name in set(changed):
        del rt.groups[name]
    return bool(changed)


def feed_maps(rt, obj, names):
    """Feeds OPDeform's modifier the picked groups ``names`` (picked_groups) where they changed since it was last
    fed; returns whether they did."""
    if names == rt.fed:
        return False
    rt.fed = names if modifier.get(obj) is not None else None
    if rt.fed is not None:
        modifier.set_maps(obj, names)
    return True


def group_weights(rt, obj, name, what):
    """A painted map's per-vertex weights (None without a group), kept in the runtime until they change
    (changed_maps) or the object is seen in another mode than Object Mode (Edit Mode, where the modifier does not
    run): reading a group walks every vertex in Python (about 5 ms for 6,000 vertices), too slow for every
    frame."""
    if obj.mode != 'OBJECT':
        rt.groups.clear()
    if name not in rt.groups:
        rt.groups[name] = read_weights(obj, name, what)
    return rt.groups[name]


def set_maps(rt, obj, scene):
    """The goal's follow values and the softness and damping maps, applied on the next frame (no Build)."""
    s, e = obj.opdeform, rt.engine
    group, follow_range, shell_min, soft_group, soft, damp_group, damping, jiggle_hz = maps(s)
    strength = goal_strength(s)
    try:
        follow_w = None if strength is None else group_weights(rt, obj, group, MAP_NAMES[0])
        e.set_goal(strength, follow_w, follow_range, shell_min)
        soft_w = group_weights(rt, obj, soft_group, MAP_NAMES[1])
        damp_w = group_weights(rt, obj, damp_group, MAP_NAMES[2])
        units = presets.units(s, frame_rate(scene))
        jiggle = follow_w is not None and soft_w is None and jiggle_hz > 0.0  # painted flesh, no Softness group
        e.set_regions(None if soft_w is None else soft ** soft_w,
                      None if damp_w is None else region_damping(units, e.timestep[0], damp_w, damping),
                      jiggle_hz if jiggle else None)
    except EngineError as exc:
        raise AddonError(f"{obj.name}: {exc}") from None


def build(obj, scene, depsgraph=None, kept=False):
    """Builds (or rebuilds) the graph, the skin and the simulation of obj; ``kept``: rebuilt after a file load or
    undo, in the transform and with the handles' bindings the last Build kept (build_transform). Raises
    AddonError and changes nothing on bad input."""
    check_object(obj)
    od = module()
    s = obj.opdeform
    rest = vertex_positions(obj.data)
    pins = read_vertex_group(obj, s.pin_group, "pin")
    key = build_key(obj, rest)
    kept = kept and s.build_key == key
    matrix = build_transform(obj, depsgraph, kept)
    for h in active_handles(s):  # validate before changing anything
        try:
            handle_math.check_matrix(h.target.name, handle_matrix(h, depsgraph))
        except handle_math.HandleError as exc:
            raise AddonError(str(exc)) from None
    try:
        engine = Engine(od, rest, triangles(obj.data), matrix, s.particles, s.graph_mode, s.neighbors,
                        small_pieces(obj), edges(obj.data))
    except EngineError as exc:
        raise AddonError(f"{obj.name}: {exc}") from None
    rt = Runtime(engine, graph_key(s), pins)
    rt.attached = checks.attached_pieces(od, engine.graph, engine.rest, engine.triangles, engine.rest_local)
    if small_pieces(obj) == "own":
        rt.attached_enough = checks.shells_enough(od, engine.graph, engine.rest, engine.triangles)
        piece, count = checks.vertex_pieces(engine.rest, engine.triangles)
        rt.pieces = piece if count > 1 else None
        find_unrigged(rt, obj)
    for h in active_handles(s) if not kept else ():
        bind_handle(h, engine.rest, depsgraph)
    try:
        configure(rt, obj, scene, depsgraph)
    except (EngineError, ValueError, od.SolverError) as exc:
        raise AddonError(f"{obj.name}: {exc}") from None
    # committed: from here on the object changes
    modifier.ensure(obj)
    feed_maps(rt, obj, picked_groups(s))
    put(obj, rt)
    s.built = True
    if not np.array_equal(kept_transform(s), matrix):
        s.build_matrix = matrix.T.ravel()
    if s.build_key != key:
        s.build_key = key
    if s.error:
        s.error = ""
    show_rest(obj, rt)
    return rt


def build_transform(obj, depsgraph, kept):
    """The transform the simulation is built in (its graph in world space, a free body's world): the object's in
    this evaluation, or the one the last Build kept (``build_matrix``, column-major) when ``kept``. Blender 3.4's
    first frame handler after a file load still sees the transform of the frame saved: the galloping pony, built
    2.5 m ahead of its start, reopened 26 mm off the pose saved at frame 30."""
    if kept:
        return kept_transform(obj.opdeform)
    return np.array((obj if depsgraph is None else obj.evaluated_get(depsgraph)).matrix_world, dtype=np.float64)


def kept_transform(settings):
    """The transform the last Build kept (``build_matrix``, column-major) as a 4 x 4 array."""
    return np.array(settings.build_matrix, dtype=np.float64).reshape(4, 4).T


def build_key(obj, rest):
    """What the last Build's transform and handle bindings belong to: the object's name and its rest vertices. A
    copy of the object (another name), a file from before (no key) or a mesh changed since (Apply Transform, Set
    Origin) is built afresh, in its own transform."""
    return f"{obj.name_full}:{zlib.crc32(np.ascontiguousarray(rest).tobytes()):08x}"


def small_pieces(obj):
    """What the graph makes of a detached shell under a tenth of the largest piece (opdeform.graph): on a mesh
    an Armature deforms, particles of its own ("own": a kitbashed ear, trunk, tail, eye or button follows its
    painted Follow and jiggles; attached, each moved rigidly with the body whatever was painted); else
    attached rigidly to the nearest large piece ("attach")."""
    return "own" if presets.rigged(obj) else "attach"


def ensure(obj, scene, depsgraph=None):
    """The object's runtime; rebuilt from the stored settings after a file load or undo, and when the mesh
    changed since Build (Edit Mode edits reach the rest shape)."""
    rt = get(obj)
    if rt is None and obj.opdeform.built:
        return build(obj, scene, depsgraph, kept=True)
    if rt is not None and not np.array_equal(vertex_positions(obj.data), rt.engine.rest_local):
        rt = build(obj, scene, depsgraph)
    return rt


def show_rest(obj, rt):
    rt.engine.rest_output()
    modifier.clear_offset(obj.data)
    rt.shown = ("rest", None)


# -- a frame's input and output ------------------------------------------------------------------------
def check_writable(obj):
    """Live playback writes the offset into the mesh: refused for a linked mesh and a mesh shared by objects."""
    mesh = obj.data
    if mesh.library is not None:
        raise AddonError(f"{obj.name}: its mesh {mesh.name!r} is linked from a library (a library override?): "
                         "live playback cannot write it; Bake instead, the bake plays on the override")
    if mesh.users <= 1 + mesh.use_fake_user:  # no other object: the scan below took 0.03 ms a frame in a big file
        return
    users = [o.name for o in bpy.data.objects if o.data == mesh and o != obj]
    if users:
        raise AddonError(f"{obj.name}: its mesh {mesh.name!r} is shared with {', '.join(users)} (linked "
                         "duplicates): live playback would move them all; Object > Relations > Make Single User, "
                         "or Bake (each object plays its own bake)")


def evaluated_object(obj, depsgraph):
    return obj.evaluated_get(bpy.context.evaluated_depsgraph_get() if depsgraph is None else depsgraph)


def frame_input(obj, rt, evaluated):
    """(the object-space positions reaching opdeform's modifier, the object's transform) in this evaluation
    (``evaluated``: the object there, evaluated_object)."""
    positions, index = modifier.read_input(evaluated.data, rt.engine.n_vertices)
    if positions is None:
        raise AddonError(f"{obj.name}: the OPDeform modifier is missing or disabled: press Build to add it")
    try:
        incoming = original_input(positions, index, rt.engine.n_vertices, modifier.above(obj))
    except EngineError as exc:
        raise AddonError(f"{obj.name}: {exc}") from None
    return incoming, np.array(evaluated.matrix_world, dtype=np.float64)


def show(obj, rt, offset, simulated=False):
    """Writes the offset (float32 (V, 3)) the modifier adds, unless a bake computes the frames or the mesh holds
    this offset already (a cached frame shown again, the frames past the cache's end, a pose at rest): a write
    makes Blender evaluate the object again after the frame handler (the character: 1.5 ms a frame in 3.4, 0.25
    ms in 5.2), where the offset unchanged is shown by the frame's first evaluation. ``simulated``: the offset
    of a frame simulated just now, written without comparing or keeping a copy (0.02 ms a frame in 5.2)."""
    if rt.baking:
        return
    check_writable(obj)
    attr = modifier.offset_attribute(obj.data)
    if attr is not None and not simulated and rt.written is not None and np.array_equal(offset, rt.written):
        return
    modifier.write_offset(obj.data, offset, attr)
    rt.written = None if simulated else offset.copy()


# -- bake ----------------------------------------------------------------------------------------------
def signature(settings, scene, contact):
    """Everything a bake depends on, as text: a bake whose signature differs is outdated."""
    hs = tuple((h.target.name, h.vertex, h.use_rotation, round(h.strength, 9)) for h in active_handles(settings))
    parts = (graph_key(settings), presets.units(settings, frame_rate(scene)), gravity(settings, scene),
             floor(settings), settings.pin_strength,
             hs, frame_range(settings, scene), settings.mode, goal_strength(settings), maps(settings))
    return repr((*parts, self_contact(contact), body_contact(contact)))


def cache_modifier(obj):
    mod = obj.modifiers.get(MODIFIER_NAME)
    return mod if mod is not None and mod.type == 'MESH_CACHE' else None


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
    every frame to a PC2 file. Everything is checked and the output file opened (core/bake_files.py) before the
    scene changes; the previous bake and its Mesh Cache modifier stay until this one finishes with frames
    (``finish``: Esc keeps the frames written so far); a bake that stops (``abort``, blender/modal_bake.py)
    leaves them as they were."""

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
            renamed(self.obj_name, obj, self.rt)
            self.obj_name = obj.name
            mark_discovery()
        return obj

    def step(self):
        """Bakes one frame. Raises AddonError when the simulation reported an error."""
        obj = self.obj
        if obj is None:
            raise AddonError(f"object {self.obj_name!r} disappeared during the bake")
        count = len(obj.data.vertices) if obj.type == 'MESH' else 0
        if count != self.rt.engine.n_vertices:  # checked before the frame handler rebuilds the runtime
            raise AddonError(f"{obj.name}: the mesh's vertex count changed during the bake "
                             f"({self.rt.engine.n_vertices} -> {count})")
        self.scene.frame_set(self.frame)
        rt = get(obj)
        if obj.opdeform.error:
            raise AddonError(obj.opdeform.error)
        if rt is not None and rt is not self.rt:
            raise AddonError(f"{obj.name}: the mesh was edited during the bake (its simulation was rebuilt)")
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


    def abort(self, message):
        """Stops without the frames: the partial file goes, the last bake stays, the object's error says why."""
        self.rt.baking = False
        try:
            self.writer.close()
        finally:
            bake_files.discard(self.path)
        obj = find_object(self.obj_ident, self.obj_name)
        if obj is not None:
            kept = "the last bake is kept" if obj.opdeform.baked else "nothing was baked"
            obj.opdeform.error = f"{message}; {kept}"


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
