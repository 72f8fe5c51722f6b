"""Goals: secondary motion on an animated shape (Soft Body's Goal, nCloth's Input Mesh Attract, ARAP form).

Each frame, ``GoalFit.fit`` turns the animated mesh (the rest mesh deformed by the rig, same vertex order)
into a goal frame per particle, ``Simulation.set_goals`` takes them, and ``Simulation.set_goal_strength``
says how hard each particle is pulled: a spring given as a frequency, so that it means the same at any
size, mass and frame rate. Strength 0 is free dynamics, 1 follows the animation (1000 Hz), and in between
log f grows with s² (0.3 Hz at 0.2, 1.7 Hz at 0.5, 13 Hz at 0.7, 200 Hz at 0.9), which spreads the visible
range of lag and overshoot over the slider instead of crowding it below 0.5. ``relative_deform`` puts the simulated motion on top of the
animated mesh, so that at full strength the output is the animation itself, vertex for vertex.
"""

from typing import Any, Literal, Protocol

import numpy as np
import numpy.typing as npt

from . import _core
from ._arguments import ArrayLike, Floats, Ints, as_array, integer
from ._rebuild import FromArguments
from .graph import Graph

Floats32 = npt.NDArray[np.float32]

__all__ = ["GoalFit", "goal_frequency", "relative_deform", "GOAL_MIN_HZ", "GOAL_MAX_HZ"]

GOAL_MIN_HZ = 0.2     # strength just above 0
GOAL_MAX_HZ = 1000.0  # strength 1: (2π f h)² is 6.9e4 at 24 fps, the goal is followed to ~1e-5 of a step's motion


def goal_frequency(strength: ArrayLike) -> Floats:
    """Strength in [0, 1] (a number or an array) -> spring frequency in Hz: 0 -> 0, s > 0 -> f_min (f_max /
    f_min)^(s²)."""
    s = np.asarray(strength, dtype=np.float64)
    if not np.all(np.isfinite(s)) or np.any(s < 0.0) or np.any(s > 1.0):
        raise ValueError("goal strength must be finite and in [0, 1]")
    return np.where(s > 0.0, GOAL_MIN_HZ * (GOAL_MAX_HZ / GOAL_MIN_HZ) ** (s * s), 0.0)


class GoalFit(FromArguments):
    """Goal frames of a graph's particles fitted to an animated mesh: per particle, the rigid motion that best
    carries its ``neighbors`` nearest rest vertices (Sumner-weighted) onto their animated positions; for a graph
    built from a mesh, the nearest of those it skins (its own mesh piece's and those of the pieces it carries)."""

    def __init__(self, graph: Graph, rest_vertices: ArrayLike, neighbors: int = 16) -> None:
        if not isinstance(graph, Graph):
            raise TypeError("graph must be an opdeform.Graph")
        self.graph = graph
        vertices = as_array("rest_vertices", rest_vertices, (None, 3))
        self._core = _core.GoalFit(graph._core, vertices, integer("neighbors", neighbors))
        self._args = (graph, vertices.copy(), neighbors)  # a pickle fits again
        self._spare: tuple[Floats, Floats] | None = None  # follow's outputs while no fit has taken them

    @property
    def n_vertices(self) -> int:
        """The number of rest vertices."""
        return self._core.n_vertices

    @property
    def neighbors(self) -> int:
        """The rest vertices fitted per particle."""
        return self._core.neighbors

    def _read(self, name: Literal["indices", "weights"], dtype: npt.DTypeLike) -> npt.NDArray[Any]:
        out = np.empty((self.graph.n_particles, self.neighbors), dtype)
        self._core.read(name, out)
        return out

    @property
    def indices(self) -> Ints:
        """(n, k) int32: each particle's rest vertices, nearest first."""
        return self._read("indices", np.int32)

    @property
    def weights(self) -> Floats:
        """(n, k): their weights, summing to 1 per particle."""
        return self._read("weights", np.float64)

    def particle_values(self, vertex_values: ArrayLike) -> Floats:
        """Per-vertex values (V,), e.g. a painted goal weight, as per-particle values: each particle's weighted
        mean over its vertices."""
        values = as_array("vertex_values", vertex_values, (self.n_vertices,))
        return (values[self.indices] * self.weights).sum(axis=1)

    def fit(self, animated: ArrayLike, shift: ArrayLike | None = None) -> tuple[Floats, Floats]:
        """(positions (n,3), rotations (n,3,3)) of the goal frames for the animated vertices (V,3). With ``shift``
        (3,), the vertices are float32 (V,3), each moved by the shift in float64 (Blender's object-space input
        placed by an unturned object's translation; the same bits as fitting their float64 copy plus the shift,
        with no (V,3) float64 array made)."""
        n = self.graph.n_particles
        positions, rotations = np.empty((n, 3)), np.empty((n, 3, 3))
        if shift is None:
            self._core.fit(as_array("animated", animated, (self.n_vertices, 3)), positions, rotations)
        elif np.asarray(animated).dtype != np.float32:  # rounding float64 vertices would lose their bits unseen
            raise ValueError(f"animated must be float32 with a shift, got {np.asarray(animated).dtype}")
        else:
            self._core.fit(as_array("animated", animated, (self.n_vertices, 3), np.float32), positions, rotations,
                           as_array("shift", shift, (3,)))
        return positions, rotations

    def follow(self, animated: Floats32, shift: ArrayLike, kept: Floats32, kept_shift: Floats,
               valid: bool) -> tuple[Floats, Floats] | None:
        """A frame's goal frames in one C call: ``fit(animated, shift)`` of the float32 vertices (V,3), every one
        checked finite first (ValueError naming the first that is not), unless they and the shift equal ``kept``
        (float32 (V,3), not sharing memory with ``animated``) and ``kept_shift`` (float64 (3,)), the last fit's
        input when ``valid``: None then (a held pose; nothing written). A fit writes its input into kept and
        kept_shift. An array of another shape or type is refused (ValueError naming it). The arrays it returns
        are new ones each fit; a held pose allocates nothing."""
        n = self.graph.n_particles
        out = self._spare if self._spare is not None else (np.empty((n, 3)), np.empty((n, 3, 3)))
        self._spare = out
        if not self._core.follow(animated, as_array("shift", shift, (3,)), kept, kept_shift, valid, *out):
            return None
        self._spare = None
        return out


class Skinning(Protocol):
    """What relative_deform needs of a Skin (mesh.py, a layer above this one)."""
    @property
    def n_vertices(self) -> int: ...

    def deform(self, positions: ArrayLike, rotations: ArrayLike) -> Floats: ...


class Posed(Protocol):
    """What relative_deform needs of a Simulation (simulation.py, a layer above this one)."""
    @property
    def positions(self) -> Floats: ...

    @property
    def rotations(self) -> Floats: ...


def relative_deform(skin: Skinning, animated: ArrayLike, sim: Posed, goals: tuple[ArrayLike, ArrayLike],
                    out: Floats | None = None) -> Floats:
    """The animated vertices moved by what the simulation adds to the goals: animated + skin(sim) - skin(goals),
    the layering of secondary motion on an animation (exactly the animation where the particles sit on their
    goals). goals is the (positions, rotations) pair of ``GoalFit.fit``."""
    simulated = skin.deform(sim.positions, sim.rotations)
    followed = skin.deform(*goals)
    return np.add(as_array("animated", animated, (skin.n_vertices, 3)), simulated - followed, out=out)
