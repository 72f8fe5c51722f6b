"""What the add-on keeps in memory per object between frames: its Runtime (the Engine and what the frames
shown need), and the contact groups of the live objects (core/contact.py). A new per-object field goes in
Runtime.__init__.

Nothing here keeps a bpy pointer across calls: runtimes are keyed by the object's session_uid (its name before
Blender 3.5), so undo and file loads cannot leave dangling references.
"""

import bpy

from ..core.contact import Bodies

RECENT_FRAMES = 3  # outputs kept for subframes (motion blur) between the last frames shown
CATCH_UP_SECONDS = 0.1  # simulation per frame change in the UI; a far jump goes on in blender/catch_up.py

_runtimes = {}
bodies = Bodies()  # the contact groups of the live objects (core/contact.py)


class Runtime:
    """What the add-on holds for one object between frames."""

    def __init__(self, engine, graph_key, pins):
        self.engine = engine
        self.graph_key = graph_key  # settings the graph was built with (particles, mode, ...)
        self.pins = pins  # (indices, weights) read from the pin group at Build
        self.attached = ()  # the mesh's pieces without particles, found at Build (core/checks.attached_pieces)
        self.attached_enough = None  # the Particles that gives them particles of their own (checks.shells_enough)
        self.pieces = None  # each vertex's mesh piece where detached shells have particles of their own, else None
        self.unrigged = ()  # the mesh's pieces that no bone moves, found at Build (core/checks.unrigged_pieces)
        self.overlaps = ()  # the objects stepping with it that overlap it at rest without a Goal on both
        # group name -> per-vertex weights of the painted maps (follow, softness, damping), read when first
        # used and again when they changed or the object was in Edit Mode (runtime.group_weights, changed_maps)
        self.groups = {}
        self.fed = None  # the groups OPDeform's modifier was last given for the maps (runtime.changed_maps)
        self.handle_matrices = None  # bytes of the handle transforms last used
        self.configured = None  # (settings_key, groups read) of the last runtime.configure
        self.shown = None  # what the modifier shows: ("rest"|"frame"|"pose", frame)
        self.written = None  # a copy of the offset last written into the mesh, None: not known (runtime.show)
        self.recent = {}  # frame -> output (float32), the last RECENT_FRAMES frames shown
        self.baking = False  # a bake computes frames without writing the offset
        # seconds of simulation per frame change (None: all the frames asked for, as scripts and renders need)
        self.budget = None if bpy.app.background else CATCH_UP_SECONDS
        self.timing = {}
        self.started = None  # when the frame being shown began (perf_counter)

    def remember(self, frame, out):
        """Keeps a copy of the frame's output among the RECENT_FRAMES latest frames, in the buffer of the frame it
        pushes out (no array made a frame once they are kept)."""
        recent = self.recent
        kept = recent.pop(frame, None)
        if kept is None and len(recent) >= RECENT_FRAMES:
            lowest = min(recent)
            if lowest > frame:  # older than every kept frame: not kept
                return
            kept = recent.pop(lowest)
        if kept is None or kept.shape != out.shape or kept.dtype != out.dtype:
            kept = out.copy()
        else:
            kept[...] = out
        recent[frame] = kept

    @property
    def deformed(self):
        return self.shown is not None and self.shown[0] != "rest"


def key(obj):
    return getattr(obj, "session_uid", None) or obj.name


def get(obj):
    return _runtimes.get(key(obj))


def put(obj, rt):
    _runtimes[key(obj)] = rt


def drop(obj):
    _runtimes.pop(key(obj), None)


def renamed(old_name, obj, rt):
    """obj, renamed from old_name, keeps rt (keyed by name before Blender 3.5)."""
    _runtimes.pop(old_name, None)
    put(obj, rt)


def clear():
    _runtimes.clear()
    bodies.clear()


def items():
    return list(_runtimes.items())


def prune(valid_keys):
    """Forgets the runtimes of objects that are gone (after undo or a file load), and what the others last wrote
    into their meshes (undo brings back the offset a mesh held then)."""
    for k in [k for k in _runtimes if k not in valid_keys]:
        del _runtimes[k]
    for rt in _runtimes.values():
        rt.written = None


def forget_groups():
    """Forgets the contact groups of objects rebuilt or gone (groups of other scenes stay)."""
    bodies.keep_only({id(rt.engine.sim) for rt in _runtimes.values()})
