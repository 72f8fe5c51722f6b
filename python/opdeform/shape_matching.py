"""Gauss-Seidel shape matching with oriented particles (Müller and Chentanez 2011): the baseline the ARAP
solver is compared against, on the same graphs. See docs/shape_matching.md and
csrc/include/opdeform/shape_matching.h.

Its stiffness is a fraction of the way to the goals per sweep, so how stiff a body looks depends on the
iteration count and the step size; ``opdeform.Simulation``'s does not. The core objects share the
Simulation's state protocol, so the state accessors below are the Simulation's own.
"""

from types import MappingProxyType

import numpy as np

from . import _core
from ._arguments import vector
from .graph import Graph
from .scenes import bar_graph, end_face_points
from .simulation import Simulation, core_params

__all__ = ["ShapeMatching", "fig1_bar", "settle"]


class ShapeMatching:
    """Shape matching of an oriented-particle graph: one group per particle (itself and its neighbours),
    visited Gauss-Seidel, ``iterations`` sweeps per step. stiffness in (0, 1] is the fraction of the way
    each group moves its particles to their goals per sweep; damping the per-step velocity damping;
    skin_neighbors the m of the Sumner weights that place the position constraints (hard, projected every
    sweep). The density only sets masses, whose ratios alone enter."""

    def __init__(self, graph, stiffness=1.0, density=1000.0, dt=1 / 60, iterations=10, gravity=(0.0, 0.0, -9.81),
                 damping=0.0, skin_neighbors=4):
        if not isinstance(graph, Graph):
            raise TypeError("graph must be an opdeform.Graph")
        self.graph = graph
        self._core = _core.ShapeMatching(graph._core, *core_params(stiffness, density, dt, iterations, gravity,
                                                                   damping, skin_neighbors))

    def add_position_constraint(self, point, target=None):
        """Holds the rest-space point at target (None: where it is now). Returns the constraint id."""
        target = None if target is None else vector("target", target)
        return self._core.add_position_constraint(vector("point", point), target)

    def __repr__(self):
        p = self.params
        return (f"opdeform.ShapeMatching(n_particles={self.graph.n_particles}, stiffness={p['stiffness']}, "
                f"iterations={p['iterations']}, dt={p['dt']:.6g})")

    # The same protocol as the Simulation's core object: share its methods instead of repeating them.
    set_constraint_target = Simulation.set_constraint_target
    n_constraints = Simulation.n_constraints
    set_floor = Simulation.set_floor
    clear_floor = Simulation.clear_floor
    step = Simulation.step
    _colliders = MappingProxyType({})  # no colliders: none arrives at the end of a step
    _colliders_arrived = Simulation._colliders_arrived
    set_state = Simulation.set_state
    _read = Simulation._read
    positions = Simulation.positions
    rotations = Simulation.rotations
    velocities = Simulation.velocities
    angular_velocities = Simulation.angular_velocities
    skin_points = Simulation.skin_points
    params = Simulation.params
    set_params = Simulation.set_params
    counters = Simulation.counters


def fig1_bar(**args):
    """The set-up of ``scenes.fig1_bar`` for shape matching: the bar held at its x = 0 end face by 25 position
    constraints. ``args`` go to ShapeMatching; the tip is ``scenes.BAR_TIP``."""
    sm = ShapeMatching(bar_graph(), **args)
    for p in end_face_points(0.0):
        sm.add_position_constraint(p)
    return sm


def settle(sim, tol=1e-7, chunk=500, max_steps=100_000):
    """Steps a Simulation or ShapeMatching in chunks until no particle moves faster than ``tol`` (m/s).
    Returns the steps taken; raises RuntimeError when ``max_steps`` were not enough."""
    steps = 0
    while steps < max_steps:
        sim.step(chunk)
        steps += chunk
        if np.abs(sim.velocities).max() < tol:
            return steps
    raise RuntimeError(f"not settled after {steps} steps (max speed {np.abs(sim.velocities).max():.3g} m/s)")
