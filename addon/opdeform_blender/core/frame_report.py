"""What the solver reached on each simulated frame (issue 14), free of bpy: the achieved error and the
iterations of its steps, the largest edge stretch and a driven handle's motion per step, and the panel's
per-frame error plot drawn with numpy into an RGBA image.

The error is the step residual of ``Simulation.step_report``: the largest displacement of a particle's
material in a step's last local/global pair, as a fraction of the body's size (-1 in solver units, which run
a fixed number of iterations)."""

from collections import namedtuple

import numpy as np

Report = namedtuple("Report", "error iterations most stretch handle_step handle_fast turn mesh", defaults=(None,))
# error: the largest residual of the frame's steps (fraction of the size, -1: fixed iterations); iterations:
# local/global pairs per step (mean); most: in one step; stretch: the largest particle edge length / rest length;
# handle_step: the fastest handle's travel in one step / the body's size; handle_fast: too fast for the steps;
# turn: the fastest goal's turn into the frame, degrees (checks.goal_turn); mesh: the mesh's largest edge length /
# rest length in the frame shown (what the artist sees: a thin card's edges stretch beyond the particles'), None
# until asked while that frame was shown (Engine.report)
HISTORY = 2000  # frames of reports kept (the plot shows the last PLOT_FRAMES)
PLOT_FRAMES = 250
STRETCH_LIMIT = 2.0  # warn beyond twice the rest length


class Stretch:
    """The largest edge length / rest length of the edges (E, 2) between points at rest at ``rest``, for given
    positions: of a graph's edges between its particles (``Stretch(graph.edges, graph.centers)``), the ratio of
    ``materials.stretch_warning`` with the edges' ends and rest lengths kept (0.016 ms a frame
    for the character's 447 edges at 100 particles, where the warning took 0.044 ms). The ends' positions are
    gathered by ``np.take`` (the same rows; indexing took 0.045 ms a gather for its 5,495 edges at 1,000
    particles, take 0.008)."""

    def __init__(self, edges, rest):
        e, c = np.asarray(edges).reshape(-1, 2), np.asarray(rest, dtype=np.float64)
        length = np.linalg.norm(c[e[:, 0]] - c[e[:, 1]], axis=1)
        e = e[length > 0.0]  # an edge of zero length at rest (welded vertices) has no stretch
        self.ends = np.ascontiguousarray(e[:, 0]), np.ascontiguousarray(e[:, 1])
        self.rest = length[length > 0.0]
        self.inverse_squares = {}  # dtype -> 1 / rest length squared: squared ratios, one root (of the largest)

    def __call__(self, positions):
        scale = self.inverse_squares.get(positions.dtype)
        if scale is None:
            scale = self.inverse_squares[positions.dtype] = (1.0 / self.rest ** 2).astype(positions.dtype)
        d = np.take(positions, self.ends[0], axis=0)
        d -= np.take(positions, self.ends[1], axis=0)
        return float(np.sqrt(float((np.einsum("ij,ij->i", d, d) * scale).max(initial=0.0))))


def report(stretch, sim, handle, turn=0.0):
    """The Report of the frame just simulated; stretch: the graph's Stretch; handle: (travel per step / size, too
    fast) of checks.handle; turn: degrees of checks.goal_turn."""
    r = sim.step_report
    return Report(float(r["error"]), r["iterations"] / max(1, r["steps"]), int(r["most_iterations"]),
                  stretch(sim.positions), *handle, turn)


def shown_stretch(rep):
    """The largest stretch a frame's report gives: the mesh's edges' where the frame was shown, else the
    particles' (0 without a report)."""
    if rep is None:
        return 0.0
    return rep.stretch if rep.mesh is None else rep.mesh


class FrameReports:
    """Reports by frame, at most HISTORY (the oldest go first)."""

    def __init__(self):
        self.frames = {}

    def store(self, frame, rep):
        self.frames.pop(frame, None)
        self.frames[frame] = rep
        while len(self.frames) > HISTORY:
            del self.frames[next(iter(self.frames))]

    def truncate(self, keep_until=None):
        for f in [f for f in self.frames if keep_until is None or f > keep_until]:
            del self.frames[f]

    def get(self, frame):
        return self.frames.get(frame)

    def note_mesh(self, frame, stretch, positions):
        """Adds the mesh's stretch (a Stretch of its edges) at ``positions`` to the frame's report, once."""
        rep = self.frames.get(frame)
        if rep is not None and rep.mesh is None:
            self.frames[frame] = rep._replace(mesh=stretch(positions))

    def worst_stretch(self):
        return max((r.stretch for r in self.frames.values()), default=0.0)

    def series(self, frame, count=PLOT_FRAMES):
        """(frames, errors) of the last ``count`` reported frames up to ``frame``, in order."""
        fs = sorted(f for f in self.frames if f <= frame)[-count:]
        return np.array(fs, dtype=np.int64), np.array([self.frames[f].error for f in fs])


BACKGROUND = (0.12, 0.12, 0.12, 1.0)
GRID = (0.25, 0.25, 0.25, 1.0)
LINE = (0.35, 0.75, 1.0, 1.0)
OVER = (1.0, 0.45, 0.3, 1.0)
TOLERANCE = (0.9, 0.8, 0.3, 1.0)


def plot(errors, tolerance, width=240, height=80):
    """The per-frame error on a log scale (one decade per grid line; the tolerance as a yellow line, frames
    above it in red), as float32 RGBA (height, width, 4), row 0 at the bottom as Blender's images are."""
    img = np.empty((height, width, 4), dtype=np.float32)
    img[:] = BACKGROUND
    e = np.asarray(errors, dtype=np.float64)
    e = e[e > 0.0]
    if len(e) == 0:
        return img
    ref = tolerance if tolerance > 0.0 else float(np.median(e))
    lo, hi = np.log10(ref) - 2.0, np.log10(ref) + 2.0  # two decades either side of the tolerance

    def row(v):
        return np.clip(((np.log10(v) - lo) / (hi - lo) * (height - 1)).astype(int), 0, height - 1)

    for decade in range(int(np.ceil(lo)), int(np.floor(hi)) + 1):
        img[row(np.array([10.0 ** decade]))[0], :] = GRID
    if tolerance > 0.0:
        img[row(np.array([tolerance]))[0], :] = TOLERANCE
    x = np.linspace(0, width - 1, len(e)).astype(int) if len(e) > 1 else np.array([width - 1])
    y = row(e)
    for xi, yi, over in zip(x, y, e > tolerance if tolerance > 0.0 else np.zeros(len(e), bool)):
        img[max(0, yi - 1):yi + 2, max(0, xi - 1):xi + 1] = OVER if over else LINE
    return img
