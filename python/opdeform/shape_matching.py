"""Gauss-Seidel shape matching with oriented particles (Müller and Chentanez 2011): the baseline the ARAP
solver is compared against, on the same graphs. See docs/shape_matching.md and
csrc/include/opdeform/shape_matching.h.

Its stiffness is a fraction of the way to the goals per sweep, so how stiff a body looks depends on the
iteration count and the step size; ``opdeform.Simulation``'s does not. The core objects share the
Simulation's state protocol, so both take their state accessors from ``simulation.CoreObject``.
"""

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

import numpy as np

from . import _core
from ._arguments import Vector, vector
from .graph import Graph
from .scenes import bar_graph, end_face_points
from .simulation import CoreObject, Simulation, core_params

__all__ = ["ShapeMatching", "fig1_bar", "settle"]


class ShapeMatching(CoreObject):
    """Shape matching of an oriented-particle graph: one group per particle (itself and its neighbours),
    visited Gauss-Seidel, ``iterations`` sweeps per step. stiffness in (0, 1] is the fraction of the way
    each group moves its particles to their goals per sweep; damping the per-step velocity damping;
    skin_neighbors the m of the Sumner weights that place the position constraints (hard, projected every
    sweep). The density only sets masses, whose ratios alone enter."""

    def __init__(self, graph: Graph, stiffness: float = 1.0, density: float = 1000.0, dt: float = 1 / 60,
                 iterations: int = 10, gravity: Vector = (0.0, 0.0, -9.81), damping: float = 0.0,
                 skin_neighbors: int = 4) -> None:
        if not isinstance(graph, Graph):
            raise TypeError("graph must be an opdeform.Graph")
        self.graph = graph
        self._core = _core.ShapeMatching(graph._core, *core_params(stiffness, density, dt, iterations, gravity,
                                                                   damping, skin_neighbors))

    def add_position_constraint(self, point: Vector, target: Vector | None = None) -> int:
        """Holds the rest-space point at target (None: where it is now). Returns the constraint id."""
        target = None if target is None else vector("target", target)
        return self._core.add_position_constraint(vector("point", point), target)

    def __repr__(self) -> str:
        p = self.params
        return (f"opdeform.ShapeMatching(n_particles={self.graph.n_particles}, stiffness={p['stiffness']}, "
                f"iterations={p['iterations']}, dt={p['dt']:.6g})")

    # no colliders: none arrives at the end of a step
    _colliders: Mapping[int, dict[str, Any]] = MappingProxyType({})


def fig1_bar(**args: Any) -> ShapeMatching:
    """The set-up of ``scenes.fig1_bar`` for shape matching: the bar held at its x = 0 end face by 25 position
    constraints. ``args`` go to ShapeMatching; the tip is ``scenes.BAR_TIP``."""
    sm = ShapeMatching(bar_graph(), **args)
    for p in end_face_points(0.0):
        sm.add_position_constraint(p)
    return sm


def settle(sim: Simulation | ShapeMatching, tol: float = 1e-7, chunk: int = 500, max_steps: int = 100_000) -> int:
    """Steps a Simulation or ShapeMatching in chunks until no particle moves faster than ``tol`` (m/s).
    Returns the steps taken; raises RuntimeError when ``max_steps`` were not enough."""
    steps = 0
    while steps < max_steps:
        sim.step(chunk)
        steps += chunk
        if np.abs(sim.velocities).max() < tol:
            return steps
    raise RuntimeError(f"not settled after {steps} steps (max speed {np.abs(sim.velocities).max():.3g} m/s)")
