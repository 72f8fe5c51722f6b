"""ARAP dynamics of an oriented-particle graph (``opdeform.Simulation``); see METHOD.md."""

import numpy as np

from . import _core
from ._arguments import as_array, choice, integer, number, vector
from .goals import goal_frequency
from .graph import Graph

__all__ = ["Simulation"]


class Simulation:
    """ARAP dynamics of an oriented-particle graph (METHOD.md): k = stiffness, rho = density, h = dt,
    c = damping, iterations = local/global pairs after each step's first global solve, skin_neighbors = m."""

    def __init__(self, graph, stiffness, density=1000.0, dt=1 / 60, iterations=10, gravity=(0.0, 0.0, -9.81),
                 damping=0.0, skin_neighbors=4):
        if not isinstance(graph, Graph):
            raise TypeError("graph must be an opdeform.Graph")
        self.graph = graph
        self._core = _core.Simulation(graph._core, *core_params(stiffness, density, dt, iterations, gravity, damping,
                                                            skin_neighbors))
        v = graph.volumes
        r2 = (graph.radii ** 2).sum(axis=1)
        self._mean_volume = float(v.mean())
        self._mean_moment = float((0.2 * v * r2).mean())

    # -- constraints ----------------------------------------------------------------------------------
    def default_weight(self, kind="position"):
        """1000 times the elastic stiffness of a typical particle: holds a point firmly, keeps the matrix
        well conditioned. Position weights are in N/m, direction weights in J."""
        k = self.params["stiffness"]
        if kind == "position":
            return 1e3 * k * self._mean_volume
        if kind == "direction":
            return 1e3 * k * self._mean_moment
        raise ValueError(f"kind must be 'position' or 'direction', got {kind!r}")

    def add_position_constraint(self, point, target=None, weight=None):
        """Pins the rest-space point to target (None: where it is now). Returns the constraint id."""
        weight = self.default_weight("position") if weight is None else number("weight", weight)
        target = None if target is None else vector("target", target)
        return self._core.add_position_constraint(vector("point", point), target, weight)

    def add_direction_constraint(self, point, direction, target=None, weight=None):
        """Turns the rest direction at the rest-space point towards target (None: where it points now)."""
        weight = self.default_weight("direction") if weight is None else number("weight", weight)
        target = None if target is None else vector("target", target)
        return self._core.add_direction_constraint(vector("point", point), vector("direction", direction), target,
                                                   weight)

    def set_constraint_target(self, id, target):
        self._core.set_constraint_target(integer("id", id), vector("target", target))

    def set_constraint_weight(self, id, weight):
        self._core.set_constraint_weight(integer("id", id), number("weight", weight))

    def remove_constraint(self, id):
        self._core.remove_constraint(integer("id", id))

    @property
    def n_constraints(self):
        return self._core.constraint_count()

    # -- floor -----------------------------------------------------------------------------------------
    # -- goals ----------------------------------------------------------------------------------------
    def set_goal_strength(self, strength):
        """Pull toward the goal frames (``set_goals``), a number or one per particle in [0, 1] (opdeform.goals):
        0 free, 1 follows the goals. None removes the goals. A change refactors the global matrix once."""
        if strength is None:
            self._core.set_goal_frequencies(None)
            return
        s = as_array("strength", np.broadcast_to(np.asarray(strength, dtype=np.float64), (self.graph.n_particles,)),
                     (self.graph.n_particles,))
        self.set_goal_frequencies(goal_frequency(s))

    def set_goal_frequencies(self, frequencies):
        """The goal springs as frequencies in Hz, one per particle (>= 0), or None to remove the goals."""
        hz = None if frequencies is None else as_array("frequencies", frequencies, (self.graph.n_particles,))
        self._core.set_goal_frequencies(hz)

    def set_goals(self, positions, rotations=None):
        """Goal centres (n,3) and rotations (n,3,3; None: the rest frames), e.g. from ``GoalFit.fit``. Only the
        right side changes: no refactoring. Needs goal strengths first."""
        n = self.graph.n_particles
        rot = None if rotations is None else as_array("rotations", rotations, (n, 3, 3))
        self._core.set_goals(as_array("positions", positions, (n, 3)), rot)

    def set_floor(self, height=0.0, friction=0.0):
        """A floor plane z = height (normal +z) with Coulomb friction coefficient ``friction``."""
        self._core.set_floor(number("height", height), number("friction", friction))

    def clear_floor(self):
        self._core.clear_floor()

    # -- solving ---------------------------------------------------------------------------------------
    def step(self, steps=1):
        """Advances ``steps`` time steps. On a non-finite result raises SolverError and keeps the state."""
        self._core.step(integer("steps", steps))

    def solve_static(self, iterations):
        """The static pose (no inertia, gravity included) from the current state; needs a position
        constraint on every connected piece."""
        self._core.solve_static(integer("iterations", iterations))

    def energy(self):
        """The objective of the last step (or static solve) at the current iterate."""
        return self._core.energy()

    # -- state -----------------------------------------------------------------------------------------
    def set_state(self, positions, rotations, velocities=None, angular_velocities=None):
        n = self.graph.n_particles
        pos = as_array("positions", positions, (n, 3))
        rot = as_array("rotations", rotations, (n, 3, 3))
        vel = None if velocities is None else as_array("velocities", velocities, (n, 3))
        ang = None if angular_velocities is None else as_array("angular_velocities", angular_velocities, (n, 3))
        self._core.set_state(pos, rot, vel, ang)

    def _read(self, name, shape):
        out = np.empty(shape)
        self._core.read(name, out)
        return out

    @property
    def positions(self):
        return self._read("positions", (self.graph.n_particles, 3))

    @property
    def rotations(self):
        return self._read("rotations", (self.graph.n_particles, 3, 3))

    @property
    def velocities(self):
        return self._read("velocities", (self.graph.n_particles, 3))

    @property
    def angular_velocities(self):
        return self._read("angular_velocities", (self.graph.n_particles, 3))

    def skin_points(self, points, m=None):
        """Positions of rest-space points under the current state (linear-blend skinning, eq. 1)."""
        pts = as_array("points", points, (None, 3))
        m = self.params["skin_neighbors"] if m is None else m
        x, rot, rest = self.positions, self.rotations, self.graph.centers
        out = np.zeros_like(pts)
        for k, p in enumerate(pts):
            idx, w = self.graph.skin_weights(p, m)
            out[k] = np.einsum("j,jab,jb->a", w, rot[idx], p - rest[idx]) + w @ x[idx]
        return out

    # -- parameters and diagnostics --------------------------------------------------------------------
    @property
    def params(self):
        return self._core.params()

    def set_params(self, **changes):
        """Changes parameters (same names as the constructor); the state is kept."""
        p = self.params
        unknown = set(changes) - set(p)
        if unknown:
            raise ValueError(f"unknown parameters: {sorted(unknown)}")
        p.update(changes)
        self._core.set_params(*core_params(**p))

    ACCELERATORS = ("none", "anderson", "chebyshev")

    FACTORIZATIONS = ("auto", "simplicial", "supernodal")

    def set_solver(self, accelerator="none", window=5, rho=0.999, threads=1, factorization="auto"):
        """How the local/global iteration runs: ``accelerator`` "none" (plain), "anderson" (history
        ``window``) or "chebyshev" (spectral radius estimate ``rho``), both safeguarded by the energy;
        ``threads`` (0..64; 0: the CPUs this process may use) for the local step (a block of particles per thread, then the border),
        the right side and the substitution (subtrees of a METIS-ordered factor); results are the same bits
        run to run for a given thread count; CHOLMOD's ``factorization`` path ("auto": simplicial below 400
        flops per factor entry, else supernodal; "simplicial"; "supernodal")."""
        self._core.set_solver(choice("accelerator", accelerator, self.ACCELERATORS), integer("window", window),
                              number("rho", rho), integer("threads", threads),
                              choice("factorization", factorization, self.FACTORIZATIONS))

    @property
    def solver(self):
        s = self._core.solver()
        s["accelerator"] = self.ACCELERATORS[s["accelerator"]]
        s["factorization"] = self.FACTORIZATIONS[s["factorization"]]
        return s

    @property
    def counters(self):
        """Factorizations, analyses, solves, steps, polar fallbacks, and accelerated / rejected iterations."""
        return self._core.counters()

    @property
    def trace_energy(self):
        """Whether each call records the objective after every local and global step (``energy_trace``)."""
        return self._core.trace_energy

    @trace_energy.setter
    def trace_energy(self, enabled):
        self._core.trace_energy = bool(enabled)

    @property
    def energy_trace(self):
        """Objective after the first global solve and after each local and global step of the last call."""
        out = np.empty(self._core.trace_length())
        self._core.read("energy_trace", out)
        return out


def core_params(stiffness, density, dt, iterations, gravity, damping, skin_neighbors):
    """The core's positional parameters (a Simulation's and a ShapeMatching's), each converted by name."""
    return (number("stiffness", stiffness), number("density", density), number("dt", dt),
            integer("iterations", iterations), vector("gravity", gravity), number("damping", damping),
            integer("skin_neighbors", skin_neighbors))
