"""In-memory cache of solver states per frame (positions, rotations, velocities, angular velocities, the
goals' motion while they carry the rest and the floor's and colliders' carried normal forces) and the handle targets and goal frames that produced them, and for a
member of a contact group the group's state after that frame (``opdeform.ContactGroup.save_state``: the pairs
and forces its next step starts from; about 230-430 kB a frame for two stacked 1,000-particle bodies, shared by
the members' caches: 88 bytes a pair since stop 46's friction anchor, 170-310 kB measured at 64 before), and the
skinned vertices that the frame's colliders and floor pushed out (indices and positions: only those). A few kilobytes per frame for a hundred particles: the skinned vertices are not kept,
they are recomputed from the state when a cached frame is shown.

Bounded: at most ``CACHE_BYTES`` (256 MiB; about 18,000 frames of 100 particles, 1,800 of 1,000). Past it the
oldest frames after the start are dropped (the start frame is always kept); showing a dropped frame replays
from the start (core/frames.py). A bake writes every frame to its file as it goes, so nothing baked is lost.
The bytes counted are what a frame holds: its arrays' objects and data as the allocator hands them out, the
tuples around them and its slot in the dict (counting the data alone let 256 MiB hold 392 MiB for a
20-particle bar, issue 28; now a 128 MiB cap holds 123 MiB in Blender 3.4 and 5.2)."""

import sys

import numpy as np

CACHE_BYTES = 256 * 2 ** 20
# A frame's slot in the dict and its int key: the slot (hash, key, value: 24 bytes) in a table at most 2/3 full
# with its index, and the key object (28 bytes)
SLOT_BYTES = 96
# What a block costs beyond its size class, by measurement: a far jump (tests/blender/check_cache_memory.py,
# 20 particles, a 128 MiB cap) grew Blender 3.4 by 1.07 times the cap with 16 (about 50 bytes a block left
# out: the allocator's bookkeeping, Python's pools left part-used as the oldest frames go); with 64, 0.96 in
# 3.4 and 5.2 (the jump's own 5 MiB taken off); glibc's Python then holds 0.83 of what is counted
ALLOCATION_BYTES = 64


def _allocated(n):
    """The bytes an allocation of n bytes takes: n rounded up to the allocator's size class, four classes per
    doubling as jemalloc has them (Blender's allocator on Linux; glibc rounds to 16 bytes, less), plus
    ALLOCATION_BYTES. Counted as the data alone, a far jump in Blender 3.4 held 298 MiB for 256 (issue 28)."""
    step = max(16, 1 << max(0, (n - 1).bit_length() - 3))
    return -(-n // step) * step + ALLOCATION_BYTES


def _size(value):
    """The bytes value holds: an array's object, its shape and strides, and its data as allocated, a tuple's
    or list's and what it holds (None and numbers: their object, shared or not, so a little more than they
    take)."""
    if isinstance(value, np.ndarray):
        data = _allocated(value.nbytes) if value.flags.owndata else 0
        return sys.getsizeof(value) - (value.nbytes if value.flags.owndata else 0) + _allocated(16 * value.ndim) + data
    if isinstance(value, (tuple, list)):
        return sys.getsizeof(value) + sum(_size(v) for v in value)
    return sys.getsizeof(value)


def _nbytes(entry):
    return SLOT_BYTES + _size(entry)


class StateCache:
    def __init__(self, max_bytes=CACHE_BYTES):
        self.frames = {}
        self.blended = set()  # frames simulated past a jump, from inputs blended over the frames it skipped
        self.sizes = {}  # frame -> the bytes its entry holds (_nbytes), kept: walking an entry took 0.1 ms a frame
        self.last = None
        self.keep = None  # the start frame: never dropped
        self.max_bytes = max_bytes
        self.bytes = 0

    def clear(self):
        self.frames.clear()
        self.blended.clear()
        self.sizes.clear()
        self.last = None
        self.bytes = 0

    def __contains__(self, frame):
        return frame in self.frames

    def __len__(self):
        return len(self.frames)

    @property
    def first(self):
        """The oldest frame kept after the start (None: none)."""
        return next((f for f in self.frames if f != self.keep), None)

    def store(self, frame, state, targets, goals=None, blended=False):
        """A frame's entry; ``blended``: simulated past a jump (its inputs or a frame before it blended)."""
        self._drop(frame)
        if blended:
            self.blended.add(frame)
        entry = (state, None if targets is None else np.array(targets, copy=True), goals, None, None)
        self.frames[frame] = entry
        self.sizes[frame] = _nbytes(entry)
        self.bytes += self.sizes[frame]
        if self.last is None or frame > self.last:
            self.last = frame
        while self.bytes > self.max_bytes and len(self.frames) > 2:
            self._drop(self.first)

    def _drop(self, frame):
        self.blended.discard(frame)
        if self.frames.pop(frame, None) is not None:
            self.bytes -= self.sizes.pop(frame)

    def _store_part(self, frame, k, value):
        """Replaces part k of a cached frame's entry; its bytes change by the part's (the tuple keeps its length)."""
        entry = self.frames.get(frame)
        if entry is not None:
            change = _size(value) - _size(entry[k])
            self.frames[frame] = (*entry[:k], value, *entry[k + 1:])
            self.sizes[frame] += change
            self.bytes += change

    def store_contact(self, frame, contact):
        """The contact group's state after a cached frame (None: none, a new group's)."""
        self._store_part(frame, 3, contact)

    def store_pushed(self, frame, pushed):
        """The skinned vertices a cached frame's colliders and floor pushed out: (indices, world positions)."""
        self._store_part(frame, 4, pushed)

    def contact(self, frame):
        entry = self.frames.get(frame)
        return None if entry is None else entry[3]

    def pushed(self, frame):
        entry = self.frames.get(frame)
        return None if entry is None else entry[4]

    def state(self, frame):
        return self.frames[frame][0]

    def targets(self, frame):
        return self.frames[frame][1]

    def goals(self, frame):
        return self.frames[frame][2]

    def truncate(self, keep_until):
        """Drops the frames after keep_until (what follows is outdated); keeps the rest."""
        for f in [f for f in self.frames if f > keep_until]:
            self._drop(f)
        self.last = max(self.frames) if self.frames else None
