"""opdeform: physics-based deformation with oriented particles.

The C core (``opdeform._core``) does the work; this layer turns any array-like into the contiguous
float64/int32 buffers the core reads, and the core's arrays back into numpy arrays. See README.md.
"""

import numpy as np

from . import _core
from ._core import SolverError

__all__ = ["Graph", "Simulation", "Skin", "SolverError", "add_vertex_direction", "as_array", "io", "meshes",
           "pin_vertices"]
__version__ = _core.__version__


def as_array(name, value, shape, dtype=np.float64):
    """``value`` as a C-contiguous array of ``shape`` (None = any length); ValueError naming ``name``."""
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{name}: not an array of numbers ({exc})") from None
    if arr.size == 0 and len(shape) > 1 and shape[0] is None:
        arr = arr.reshape((0,) + tuple(shape[1:]))
    if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if np.issubdtype(dtype, np.integer):
        if arr.size and not np.issubdtype(arr.dtype, np.integer):
            if not np.issubdtype(arr.dtype, np.number) or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
                raise ValueError(f"{name} must hold integers")
        if arr.size and (arr.min() < np.iinfo(dtype).min or arr.max() > np.iinfo(dtype).max):
            raise ValueError(f"{name} holds values outside the {np.dtype(dtype).name} range")
    elif arr.size and not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_):
        raise ValueError(f"{name} must hold numbers, got dtype {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=dtype)


def _vec3(name, value):
    """Three floats for the core (which checks finiteness); fast for tuples, lists and 1-D arrays."""
    if isinstance(value, np.ndarray) and value.shape == (3,) and np.issubdtype(value.dtype, np.number):
        value = value.tolist()
    if isinstance(value, (tuple, list)) and len(value) == 3:
        try:
            return (float(value[0]), float(value[1]), float(value[2]))
        except (TypeError, ValueError):
            pass
    return tuple(float(x) for x in as_array(name, value, (3,)))


class Graph:
    """Rest graph of ellipsoid particles.

    centers (n,3); radii (n,3) > 0; edges (m,2) undirected particle pairs; axes (n,3,3) rest frames whose
    columns are the ellipsoid axes (proper rotations; default identity).
    """

    def __init__(self, centers, radii, edges, axes=None):
        centers = as_array("centers", centers, (None, 3))
        n = centers.shape[0]
        radii = as_array("radii", radii, (n, 3))
        edges = as_array("edges", edges, (None, 2), np.int32)
        axes = None if axes is None else as_array("axes", axes, (n, 3, 3))
        self._core = _core.Graph(centers, radii, edges, axes)

    @classmethod
    def from_mesh(cls, vertices, triangles, particles=100, mode="auto", join_pieces=False, voxels_per_particle=100,
                  small_pieces="attach"):
        """A graph of ``particles`` ellipsoids covering a triangle mesh (vertices (V,3), triangles (T,3)):
        through the volume of closed pieces, along the surface of open or thin ones (``mode="auto"``), or
        forced: "volume", "surface", or "chain" (a 1-D chain along each piece's principal axis). Frames and
        radii are the principal axes of the part of the body each particle stands for. Each connected piece
        gets its own connected graph unless ``join_pieces``; a small piece (an eye, a button) is carried by
        the nearest large one (``small_pieces="attach"``) or gets particles of its own joined to it ("own").
        Deterministic. See opdeform.mesh."""
        from .mesh import graph_from_mesh

        return graph_from_mesh(vertices, triangles, particles, mode, join_pieces, voxels_per_particle, small_pieces)

    @property
    def n_particles(self):
        return self._core.n_particles

    @property
    def n_edges(self):
        return self._core.n_edges

    def _read(self, name, shape, dtype=np.float64):
        out = np.empty(shape, dtype)
        self._core.read(name, out)
        return out

    @property
    def centers(self):
        return self._read("centers", (self.n_particles, 3))

    @property
    def radii(self):
        return self._read("radii", (self.n_particles, 3))

    @property
    def axes(self):
        return self._read("axes", (self.n_particles, 3, 3))

    @property
    def edges(self):
        return self._read("edges", (self.n_edges, 2), np.int32)

    @property
    def volumes(self):
        r = self.radii
        return 4.0 / 3.0 * np.pi * r[:, 0] * r[:, 1] * r[:, 2]

    def pieces(self):
        """(count, label of each particle) of the connected pieces."""
        return self._core.piece_count(), self._read("pieces", (self.n_particles,), np.int32)

    def skin_weights(self, point, m=4):
        """Indices and Sumner weights of the m nearest particles of a rest-space point."""
        idx = np.empty(m, np.int32)
        w = np.empty(m)
        count = self._core.skin_weights(_vec3("point", point), int(m), idx, w)
        return idx[:count], w[:count]

    def __repr__(self):
        return f"opdeform.Graph(n_particles={self.n_particles}, n_edges={self.n_edges})"


class Simulation:
    """ARAP dynamics of an oriented-particle graph (METHOD.md): k = stiffness, rho = density, h = dt,
    c = damping, iterations = local/global pairs after each step's first global solve, skin_neighbors = m."""

    def __init__(self, graph, stiffness, density=1000.0, dt=1 / 60, iterations=10, gravity=(0.0, 0.0, -9.81),
                 damping=0.0, skin_neighbors=4):
        if not isinstance(graph, Graph):
            raise TypeError("graph must be an opdeform.Graph")
        self.graph = graph
        self._core = _core.Simulation(graph._core, float(stiffness), float(density), float(dt), _int(
            "iterations", iterations), _vec3("gravity", gravity), float(damping), _int("skin_neighbors",
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
        weight = self.default_weight("position") if weight is None else float(weight)
        target = None if target is None else _vec3("target", target)
        return self._core.add_position_constraint(_vec3("point", point), target, weight)

    def add_direction_constraint(self, point, direction, target=None, weight=None):
        """Turns the rest direction at the rest-space point towards target (None: where it points now)."""
        weight = self.default_weight("direction") if weight is None else float(weight)
        target = None if target is None else _vec3("target", target)
        return self._core.add_direction_constraint(_vec3("point", point), _vec3("direction", direction), target,
                                                   weight)

    def set_constraint_target(self, id, target):
        self._core.set_constraint_target(_int("id", id), _vec3("target", target))

    def set_constraint_weight(self, id, weight):
        self._core.set_constraint_weight(_int("id", id), float(weight))

    def remove_constraint(self, id):
        self._core.remove_constraint(_int("id", id))

    @property
    def n_constraints(self):
        return self._core.constraint_count()

    # -- floor -----------------------------------------------------------------------------------------
    def set_floor(self, height=0.0, friction=0.0):
        """A floor plane z = height (normal +z) with Coulomb friction coefficient ``friction``."""
        self._core.set_floor(float(height), float(friction))

    def clear_floor(self):
        self._core.clear_floor()

    # -- solving ---------------------------------------------------------------------------------------
    def step(self, steps=1):
        """Advances ``steps`` time steps. On a non-finite result raises SolverError and keeps the state."""
        self._core.step(_int("steps", steps))

    def solve_static(self, iterations):
        """The static pose (no inertia, gravity included) from the current state; needs a position
        constraint on every connected piece."""
        self._core.solve_static(_int("iterations", iterations))

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
        self._core.set_params(float(p["stiffness"]), float(p["density"]), float(p["dt"]),
                              _int("iterations", p["iterations"]), _vec3("gravity", p["gravity"]),
                              float(p["damping"]), _int("skin_neighbors", p["skin_neighbors"]))

    ACCELERATORS = ("none", "anderson", "chebyshev")

    FACTORIZATIONS = ("auto", "simplicial", "supernodal")

    def set_solver(self, accelerator="none", window=5, rho=0.999, threads=1, factorization="auto"):
        """How the local/global iteration runs: ``accelerator`` "none" (plain), "anderson" (history
        ``window``) or "chebyshev" (spectral radius estimate ``rho``), both safeguarded by the energy;
        ``threads`` (0: one per core) for the local step (a block of particles per thread, then the border),
        the right side and the substitution (subtrees of a METIS-ordered factor); results are the same bits
        run to run for a given thread count; CHOLMOD's ``factorization`` path ("auto": simplicial below 400
        flops per factor entry, else supernodal; "simplicial"; "supernodal")."""
        if accelerator not in self.ACCELERATORS:
            raise ValueError(f"accelerator must be one of {self.ACCELERATORS}, got {accelerator!r}")
        if factorization not in self.FACTORIZATIONS:
            raise ValueError(f"factorization must be one of {self.FACTORIZATIONS}, got {factorization!r}")
        self._core.set_solver(self.ACCELERATORS.index(accelerator), _int("window", window), float(rho),
                              _int("threads", threads), self.FACTORIZATIONS.index(factorization))

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
        return self._trace

    @trace_energy.setter
    def trace_energy(self, enabled):
        self._trace = bool(enabled)
        self._core.set_energy_trace(self._trace)

    _trace = False

    @property
    def energy_trace(self):
        """Objective after the first global solve and after each local and global step of the last call."""
        out = np.empty(self._core.trace_length())
        self._core.read("energy_trace", out)
        return out


def _int(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    return int(value)

# The mesh layer builds on Graph and Simulation above.
from . import io, meshes  # noqa: E402
from .mesh import Skin, add_vertex_direction, pin_vertices  # noqa: E402

if hasattr(_core, "ShapeMatching"):  # the baseline of issue 5, left out of the Blender packages (-Dbaselines=false)
    from .shape_matching import ShapeMatching  # noqa: E402  (needs the names above)
