"""In-memory cache of solver states per frame (positions, rotations, velocities, angular velocities) and the
handle targets and goal frames that produced them. A few kilobytes per frame for a hundred particles: the skinned vertices are
not kept, they are recomputed from the state when a cached frame is shown."""

import numpy as np


class StateCache:
    def __init__(self):
        self.frames = {}
        self.last = None

    def clear(self):
        self.frames.clear()
        self.last = None

    def __contains__(self, frame):
        return frame in self.frames

    def __len__(self):
        return len(self.frames)

    def store(self, frame, state, targets, goals=None):
        self.frames[frame] = (state, None if targets is None else np.array(targets, copy=True), goals)
        if self.last is None or frame > self.last:
            self.last = frame

    def state(self, frame):
        return self.frames[frame][0]

    def targets(self, frame):
        return self.frames[frame][1]

    def goals(self, frame):
        return self.frames[frame][2]

    def truncate(self, keep_until):
        """Drops the frames after keep_until (what follows is outdated); keeps the rest."""
        for f in [f for f in self.frames if f > keep_until]:
            del self.frames[f]
        self.last = max(self.frames) if self.frames else None
