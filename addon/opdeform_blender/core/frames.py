"""Which simulation work a frame change needs: pure frame logic, no numpy and no bpy.

The in-memory cache always holds a contiguous run of frames ``start..last``. Going to ``frame``:
- before the start: show the rest shape; nothing is simulated;
- the start frame: reset the state to rest (the cache keeps its frames);
- a cached frame: show it (scrubbing back replays from the cache);
- past the cache: restore the last cached state (unless the solver already holds it) and step forward frame by
  frame up to ``frame`` (jumping past the cache simulates forward);
- past the end: hold the end frame.

The frames to simulate are a ``range`` (planned lazily: a jump of a million frames costs nothing to plan). The
cache may have dropped its oldest frames (``first``: its oldest frame after the start); going back before them
replays from the start.
"""

from collections import namedtuple

MAX_FRAMES = 100_000  # the longest cache range (a range of -2**31.. is refused, not planned)

Plan = namedtuple("Plan", "kind frame restore steps")
# kind: "rest" (before start), "reset" (the start frame), "show" (cached), "simulate"
# frame: the frame whose state is shown (clamped to end); restore: cached frame to load into the solver first,
# or None; steps: frames to simulate in order (empty unless kind == "simulate")


def plan(frame, start, end, last, solver_frame, first=None):
    """last: the last cached frame (None: nothing cached); solver_frame: the frame the solver holds (None);
    first: the oldest cached frame after the start (None: start + 1)."""
    frame = int(frame)
    end = max(int(end), int(start))
    if frame < start:
        return Plan("rest", frame, None, ())
    frame = min(frame, end)
    if frame == start:
        return Plan("reset", frame, None, ())
    first = start + 1 if first is None else first
    if last is not None and first <= frame <= last:
        return Plan("show", frame, None, ())
    if last is None or last < start or frame < first:
        # nothing usable cached (or the frame was dropped): simulate from a fresh start state
        return Plan("simulate", frame, "reset", range(start + 1, frame + 1))
    restore = None if solver_frame == last else last
    return Plan("simulate", frame, restore, range(last + 1, frame + 1))


def range_error(start, end):
    """Why a cache range cannot be simulated (None: it can)."""
    if end - start + 1 > MAX_FRAMES:
        return (f"the cache range {start} - {end} is {end - start + 1:,} frames: at most {MAX_FRAMES:,} "
                "(set Start and End in the Cache panel)")
    return None


class BakeFrames:
    """The frame count of a bake job (the deformation's and the tumbling particles'): the job sets ``start``,
    ``end`` and ``frame``, the next frame to bake; the Bake operators show ``total`` and stop at ``done``."""

    @property
    def total(self):
        return self.end - self.start + 1

    @property
    def done(self):
        return self.frame > self.end
