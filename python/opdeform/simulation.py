"""ARAP dynamics of an oriented-particle graph (``opdeform.Simulation``); see METHOD.md."""

from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core
from ._arguments import ArrayLike, Floats, Ints, Vector, as_array, choice, integer, number, vector
from ._saved import check_simulation
from .fields import ForceFields
from .goals import goal_frequency
from .graph import Graph

__all__ = ["Simulation"]

# With goals carrying the rest, the least skin weight with which a particle carries a vertex as its contact shape
# (set_contact_skin). A copy carried with a smaller weight moves the skinned vertex little, but a far one swings
# far as its particle turns: the outside pig's belly and leg particles carried its hooves' vertices 21-28 cm below
# their centres, whose copies met a floor the skin stayed 0.8 mm above, so the floor moved a belly it never touched
# and kept it bouncing after the stop (docs/contact.md, "A floor out of reach (stop 48)"). Free bodies keep every
# copy: a vertex then never dips into a plane (without them Suzanne's skin went 0.12 mm into the floor).
CONTACT_WEIGHT = 0.05
MAX_WEIGHT_RATIO = 1e12  # a constraint's weight is at most this many default weights (Simulation._weight)


class CoreObject:
    """What a Simulation and a ShapeMatching share: the core objects of both take the same calls for
    constraint targets, the floor, stepping, the state and the parameters."""

    graph: Graph
    _core: Any  # _core.Simulation or _core.ShapeMatching
    _floor: tuple[float, float] | None
    _colliders: Mapping[int, dict[str, Any]]  # moved colliders arrive at the end of a step call

    def set_constraint_target(self, id: int, target: Vector) -> None:
        """Moves a constraint's target (a point, or a direction); unknown ids raise IndexError."""
        self._core.set_constraint_target(integer("id", id), vector("target", target))

    @property
    def n_constraints(self) -> int:
        """The number of position and direction constraints."""
        return self._core.constraint_count()

    def set_floor(self, height: float = 0.0, friction: float = 0.0) -> None:
        """A floor plane z = height (normal +z) with Coulomb friction coefficient ``friction``."""
        floor = (number("height", height), number("friction", friction))
        self._core.set_floor(*floor)
        self._floor = floor

    def clear_floor(self) -> None:
        """Removes the floor."""
        self._core.clear_floor()
        self._floor = None

    def step(self, steps: int = 1) -> None:
        """Advances ``steps`` time steps. On a non-finite result raises SolverError and keeps the state."""
        self._core.step(integer("steps", steps))
        self._colliders_arrived()

    def _colliders_arrived(self) -> None:
        """After a step call: each moved collider is at its target."""
        for c in self._colliders.values():
            if c["target"] is not None:
                c["frame"], c["target"] = c["target"], None

    def set_state(self, positions: ArrayLike, rotations: ArrayLike, velocities: ArrayLike | None = None,
                  angular_velocities: ArrayLike | None = None) -> None:
        """Sets positions (n, 3), rotations (n, 3, 3) and optionally (angular) velocities (n, 3)."""
        n = self.graph.n_particles
        pos = as_array("positions", positions, (n, 3))
        rot = as_array("rotations", rotations, (n, 3, 3))
        vel = None if velocities is None else as_array("velocities", velocities, (n, 3))
        ang = None if angular_velocities is None else as_array("angular_velocities", angular_velocities, (n, 3))
        self._core.set_state(pos, rot, vel, ang)

    def _read(self, name: str, shape: tuple[int, ...]) -> Floats:
        out = np.empty(shape)
        self._core.read(name, out)
        return out

    @property
    def positions(self) -> Floats:
        """(n, 3) particle positions, a copy."""
        return self._read("positions", (self.graph.n_particles, 3))

    @property
    def rotations(self) -> Floats:
        """(n, 3, 3) particle rotations, a copy."""
        return self._read("rotations", (self.graph.n_particles, 3, 3))

    @property
    def velocities(self) -> Floats:
        """(n, 3) particle velocities, a copy."""
        return self._read("velocities", (self.graph.n_particles, 3))

    @property
    def angular_velocities(self) -> Floats:
        """(n, 3) particle angular velocities, a copy."""
        return self._read("angular_velocities", (self.graph.n_particles, 3))

    def skin_points(self, points: ArrayLike, m: int | None = None) -> Floats:
        """Positions of rest-space points under the current state (linear-blend skinning, eq. 1)."""
        pts = as_array("points", points, (None, 3))
        m = self.params["skin_neighbors"] if m is None else m
        x, rot, rest = self.positions, self.rotations, self.graph.centers
        out = np.zeros_like(pts)
        for k, p in enumerate(pts):
            idx, w = self.graph.skin_weights(p, m)
            out[k] = np.einsum("j,jab,jb->a", w, rot[idx], p - rest[idx]) + w @ x[idx]
        return out

    @property
    def params(self) -> dict[str, Any]:
        """The parameters as a dict (stiffness, density, dt, iterations, gravity, damping, ...)."""
        return self._core.params()

    def set_params(self, **changes: Any) -> None:
        """Changes parameters (same names as the constructor); the state is kept."""
        self._core.set_params(*core_params(**self._changed_params(changes)))

    def _changed_params(self, changes: dict[str, Any]) -> dict[str, Any]:
        """The parameters with ``changes`` made; ValueError naming the unknown ones."""
        p = self.params
        unknown = set(changes) - set(p)
        if unknown:
            raise ValueError(f"unknown parameters: {sorted(unknown)}")
        p.update(changes)
        return p

    @property
    def counters(self) -> dict[str, float]:
        """Factorizations, analyses, solves, steps, polar fallbacks, accelerated / rejected iterations, and wall
        seconds: local_seconds, global_seconds, and of the global ones analyze_seconds (the ordering) and
        factor_seconds (the numeric factorization)."""
        return self._core.counters()


class Simulation(CoreObject, ForceFields):
    """ARAP dynamics of an oriented-particle graph (METHOD.md): k = stiffness, rho = density, h = dt,
    c = damping, iterations = local/global pairs after each step's first global solve, skin_neighbors = m.
    ``stiffness`` is a number or one per particle (as ``materials.stiffness_for`` gives it): then k is their
    mean and ``stiffness_scale`` their ratios to it (``set_stiffness_scale``)."""

    def __init__(self, graph: Graph, stiffness: float | ArrayLike, density: float = 1000.0, dt: float = 1 / 60,
                 iterations: int = 10, gravity: Vector = (0.0, 0.0, -9.81), damping: float = 0.0,
                 skin_neighbors: int = 4) -> None:
        if not isinstance(graph, Graph):
            raise TypeError("graph must be an opdeform.Graph")
        k, scale = split_stiffness(stiffness, graph.n_particles)
        self._start(graph, core_params(k, density, dt, iterations, gravity, damping, skin_neighbors))
        if scale is not None:
            self.set_stiffness_scale(scale)

    def _start(self, graph: Graph, params: tuple[Any, ...]) -> None:
        self.graph = graph
        self._core = _core.Simulation(graph._core, *params)
        v = graph.volumes
        r2 = (graph.radii ** 2).sum(axis=1)
        self._mean_volume = float(v.mean())
        self._mean_moment = float((0.2 * v * r2).mean())
        # What the core cannot give back, for pickling: the constraints as added (kind, point, direction,
        # weight) by id, the adds and removals since the set was last empty (they decide the slot order, and
        # so the bits), the ids issued before that, the floor and the goals.
        self._constraints: dict[int, list[Any]] = {}
        self._history: list[int] = []
        self._ids_before = 0
        self._stretch_bound: tuple[float, Floats | None] = (0.0, None)  # set_stretch_limit's arguments
        self._floor: tuple[float, float] | None = None
        self._goal_hz: Floats | None = None
        self._goal_frames: tuple[Floats, Floats | None] | None = None
        # The scene, for pickling too: the force-field calls as made (ForceFields records them in _calls),
        # each live collider's arguments with its frame now and the frame the next step call takes it to.
        self._calls: list[tuple[str, tuple[Any, ...]]] = []
        self._colliders: dict[int, dict[str, Any]] = {}
        self._collider_ids = 0
        self._contact_points: tuple[Floats, npt.NDArray[np.int32], bool] | None = None
        # set_contact_skin's rest vertices, indices, weights and bodies: carried again when the goals' rest changes
        self._contact_skin: tuple[Floats, npt.NDArray[np.int32], Floats, bool] | None = None

    # -- constraints ----------------------------------------------------------------------------------
    def default_weight(self, kind: str = "position") -> float:
        """1000 times the elastic stiffness of a typical particle: holds a point firmly, keeps the matrix
        well conditioned. Position weights are in N/m, direction weights in J."""
        k = self.params["stiffness"]
        if kind == "position":
            return 1e3 * k * self._mean_volume
        if kind == "direction":
            return 1e3 * k * self._mean_moment
        raise ValueError(f"kind must be 'position' or 'direction', got {kind!r}")

    def add_position_constraint(self, point: Vector, target: Vector | None = None, weight: float | None = None) -> int:
        """Pins the rest-space point to target (None: where it is now). Returns the constraint id."""
        weight = self.default_weight("position") if weight is None else self._weight("position", weight)
        target = None if target is None else vector("target", target)
        point = vector("point", point)
        return self._added(self._core.add_position_constraint(point, target, weight), [0, point, None, weight])

    def add_direction_constraint(self, point: Vector, direction: Vector, target: Vector | None = None,
                                 weight: float | None = None) -> int:
        """Turns the rest direction at the rest-space point towards target (None: where it points now)."""
        weight = self.default_weight("direction") if weight is None else self._weight("direction", weight)
        target = None if target is None else vector("target", target)
        point, direction = vector("point", point), vector("direction", direction)
        return self._added(self._core.add_direction_constraint(point, direction, target, weight),
                           [1, point, direction, weight])

    def _weight(self, kind: str, weight: float) -> float:
        """A weight of at most MAX_WEIGHT_RATIO default weights: above it the constraint's rank-deficient term
        swamps the particle's own in the factorization (1e30 N/m on the Fig. 1 bar, ~1e21 defaults: the matrix
        "not positive definite" on every step, issue 28); the bar steps at 1e12 defaults for stiffness 1e3-1e20
        and dt 1e-9-1 s (the stability suite's stiffest pins are 1e9 defaults)."""
        weight = number("weight", weight)
        limit = MAX_WEIGHT_RATIO * self.default_weight(kind)
        if not weight <= limit:
            raise ValueError(f"weight = {weight:g} must be at most {limit:g} ({MAX_WEIGHT_RATIO:g} times the default "
                             f"{kind} weight for this stiffness)")
        return weight

    def _added(self, id: int, record: list[Any]) -> int:
        self._constraints[id] = record
        self._history.append(id)
        return id

    def set_constraint_weight(self, id: int, weight: float) -> None:
        """Changes a constraint's weight (a position weight refactors once, on the next step; a direction weight
        refactors nothing); unknown ids raise IndexError."""
        kind = ("position", "direction")[self._constraints[id][0]] if id in self._constraints else "position"
        weight = self._weight(kind, weight)
        self._core.set_constraint_weight(integer("id", id), weight)
        self._constraints[id][3] = weight

    def remove_constraint(self, id: int) -> None:
        """Removes a constraint; unknown ids raise IndexError."""
        self._core.remove_constraint(integer("id", id))
        del self._constraints[id]
        self._history.append(~id)  # ~id < 0: a removal
        if not self._constraints:
            self._ids_before += sum(1 for op in self._history if op >= 0)
            self._history = []

    # -- stiffness per particle ---------------------------------------------------------------------------
    def set_stiffness_scale(self, scale: ArrayLike | None) -> None:
        """A stiffness per particle: particle i's ellipsoid stores scale[i] times the stiffness (every elastic
        term integrated over it, METHOD.md eq. 3), one value > 0 per particle, or None for all 1 (the same
        bits as never set). A change refactors the global matrix once, on the next step."""
        n = self.graph.n_particles
        self._core.set_stiffness_scale(None if scale is None else as_array("scale", scale, (n,)))

    @property
    def stiffness_scale(self) -> Floats | None:
        """The stiffness per particle (set_stiffness_scale), a copy; None when all 1."""
        out = np.empty(self.graph.n_particles)
        return out if self._core.read("stiffness_scale", out) else None

    def set_link_softness(self, softness: ArrayLike | None) -> None:
        """A softness per link: one value r_i in (0, 1] per particle, and each link (i, j) weighted min(r_i, r_j)
        on both of its halves (its terms over ellipsoid i and over ellipsoid j, each also times that particle's
        ``stiffness_scale``), so that a soft particle among stiff ones has soft links, where a scale softens
        only its own half of each. None: all 1, the same bits as never set. A change refactors the global
        matrix once, on the next step."""
        n = self.graph.n_particles
        self._core.set_link_softness(None if softness is None else as_array("softness", softness, (n,)))

    @property
    def link_softness(self) -> Floats | None:
        """The softness per particle whose minimum weights each link (set_link_softness), a copy; None when all
        1."""
        out = np.empty(self.graph.n_particles)
        return out if self._core.read("link_softness", out) else None

    def set_stretch_limit(self, limit: float, gradient: ArrayLike | None = None) -> None:
        """A stretch bound on the softened links (flesh stiffens as it stretches): at each step call's start a
        link that would stretch the skin past ``limit`` at the call's end (its ends' velocities carrying them
        there) by t (reaching 1 at 0.2 further) raises its ends' link softness r to r^(1 - t); the raise is a
        function of the call's start (and duration), so a frame simulated again from a restored state gets the same. A
        link's stretch of the skin: the gap at its middle between the skin its ends carry, times its skin
        ``gradient`` (one value >= 0 per link of ``graph.edges``: the most half the difference of its ends' skin
        weights changes per metre along a mesh edge), or over the link's length (None). Its length and its ends'
        frames are the goals' while they carry the rest. A raise refactors the global matrix. 0: off (the
        default); else > 1. With no link past the limit: the same bits as off. The raise depends on the call's
        duration too (a frame stepped in several calls looks ahead less far); solve_static uses the softness as
        set. The limit and gradient already set again change nothing (nothing refactored)."""
        links = len(self.graph.edges)
        gradient = None if gradient is None else as_array("gradient", gradient, (links,))
        try:
            self._core.set_stretch_limit(float(limit), gradient)
        except BaseException:  # refused (bad values) the core keeps its bound; failing after (memory) it is off
            if self._core.stretch_limit() == 0.0:
                self._stretch_bound = (0.0, None)
            raise
        self._stretch_bound = (float(limit), None if gradient is None else gradient.copy())

    @property
    def stretch_limit(self) -> float:
        """The stretch bound's limit (set_stretch_limit; 0: off)."""
        return self._core.stretch_limit()

    # -- goals ----------------------------------------------------------------------------------------
    def set_goal_strength(self, strength: float | ArrayLike | None) -> None:
        """Pull toward the goal frames (``set_goals``), a number or one per particle in [0, 1] (opdeform.goals):
        0 free, 1 follows the goals. None removes the goals. A change refactors the global matrix once."""
        if strength is None:
            self.set_goal_frequencies(None)
            return
        s = as_array("strength", np.broadcast_to(np.asarray(strength, dtype=np.float64), (self.graph.n_particles,)),
                     (self.graph.n_particles,))
        self.set_goal_frequencies(goal_frequency(s))

    def set_goal_frequencies(self, frequencies: float | ArrayLike | None) -> None:
        """The goal springs as frequencies in Hz, one per particle (>= 0), or None to remove the goals."""
        hz = None if frequencies is None else as_array("frequencies", frequencies, (self.graph.n_particles,)).copy()
        self._core.set_goal_frequencies(hz)
        if hz is None or self._goal_hz is None:  # goal frames start again at the rest frames
            self._goal_frames = None
        self._goal_hz = hz

    def set_goals(self, positions: ArrayLike, rotations: ArrayLike | None = None) -> None:
        """Goal centres (n,3) and rotations (n,3,3; None: the rest frames), e.g. from ``GoalFit.fit``. Only the
        right side changes: no refactoring. Needs goal strengths first."""
        n = self.graph.n_particles
        rot = None if rotations is None else as_array("rotations", rotations, (n, 3, 3)).copy()
        pos = as_array("positions", positions, (n, 3)).copy()
        self._core.set_goals(pos, rot)
        self._goal_frames = (pos, rot)

    def set_goals_carry_rest(self, enabled: bool = True) -> None:
        """Secondary motion that rides the animation (docs/goals.md): with ``enabled`` the elastic energy is
        measured against the goal shape (the particles where ``set_goals`` puts them) instead of the rest shape,
        so the animated shape is the body's equilibrium. A region left alone settles back onto the animation;
        what moves it off is the animation's acceleration (through the inertia) and gravity, which stays a
        separate setting: zero or small gravity for jiggle (a goal spring of f Hz sags g / (2π f)²). Damping
        then acts only on the motion relative to the goals (``set_particle_damping``, the ``damping``
        parameter): it never drags a moving body behind its animation. The goal velocities are measured between
        successive ``set_goals`` over the steps taken between them (0 until the second frame after enabling).
        Each ``set_goals`` remakes the edges' rest terms, without refactoring. Acts while goals exist; off (the
        default) gives the same bits as never set. A skin set as the contact shape is then carried from
        ``CONTACT_WEIGHT`` on (``set_contact_skin``)."""
        changed = bool(enabled) != self.goals_carry_rest
        self._core.set_goal_rest(bool(enabled))
        if changed and self._contact_skin is not None:
            self._carry_skin(*self._contact_skin)

    @property
    def goals_carry_rest(self) -> bool:
        """Whether the goals carry the rest shape (``set_goals_carry_rest``)."""
        return self._core.goal_rest()

    @property
    def goal_motion(self) -> tuple[Floats, Floats, int] | None:
        """(velocities, angular_velocities, steps since the last set_goals or -1) of goals carrying the rest, or
        None: what a step's damping reads besides the state, so a saved state continues to the same bits only
        with it (``set_goal_motion``; the add-on's frame cache keeps it per frame, pickles carry it)."""
        if not self.goals_carry_rest or self._goal_hz is None:
            return None
        n = self.graph.n_particles
        velocities, angular = np.empty((n, 3)), np.empty((n, 3))
        steps = self._core.goal_motion(velocities, angular)
        return velocities, angular, steps

    def set_goal_motion(self, motion: tuple[Floats, Floats, int] | None) -> None:
        """Puts back a ``goal_motion`` (None: nothing to put back)."""
        if motion is not None:
            self._core.restore_goal_motion(*motion)

    @property
    def surface_forces(self) -> tuple[Floats, Ints] | None:
        """(forces (n, 3), surfaces (n,) int32) or None: the normal force each particle pressed the floor or a
        collider with at the last step's end, which the next step starts from (docs/contact.md, warm start), and
        that surface (-1 the floor, k the k-th collider present, -2 none); kept under fixed iteration counts only
        (none under a tolerance). A step reads them besides the state: ``set_state`` drops them, so a saved state
        continues to the same bits only with them put back after it (``set_surface_forces``; pickles and the
        add-on's frame cache carry them). None when none is carried."""
        n = self.graph.n_particles
        forces, surfaces = np.empty((n, 3)), np.empty(n, np.int32)
        self._core.surface_forces(forces, surfaces)
        return None if np.all(surfaces == -2) else (forces, surfaces)

    def set_surface_forces(self, carried: tuple[ArrayLike, ArrayLike] | None) -> None:
        """Puts back ``surface_forces`` (None: nothing to put back), after the floor, colliders and state."""
        if carried is not None:
            n = self.graph.n_particles
            self._core.restore_surface_forces(as_array("surface forces", carried[0], (n, 3)),
                                              as_array("surfaces", carried[1], (n,), np.int32))

    # -- damping per particle ---------------------------------------------------------------------------
    def set_particle_damping(self, damping: float | ArrayLike | None) -> None:
        """Velocity damping per step per particle, a number or one value per particle in [0, 1], in place of the
        ``damping`` parameter (relative to the goals when they carry the rest: ``set_goals_carry_rest``); None:
        the ``damping`` parameter for all, the same bits as never set."""
        n = self.graph.n_particles
        if damping is not None:
            damping = np.full(n, number("damping", damping)) if np.ndim(damping) == 0 else as_array("damping", damping,
                                                                                                  (n,))
        self._core.set_particle_damping(damping)

    @property
    def particle_damping(self) -> Floats | None:
        """The damping per particle (``set_particle_damping``), a copy; None when the ``damping`` parameter
        applies to all."""
        out = np.empty(self.graph.n_particles)
        return out if self._core.read("particle_damping", out) else None

    # -- colliders (docs/contact.md) --------------------------------------------------------------------
    COLLIDER_SHAPES = ("plane", "box", "sphere", "capsule", "mesh")

    def add_collider(self, shape: str, half_extents: Vector = (0.5, 0.5, 0.5), radius: float = 0.5,
                     half_length: float = 0.5, vertices: ArrayLike | None = None, triangles: ArrayLike | None = None,
                     rotation: ArrayLike | None = None, translation: Vector = (0.0, 0.0, 0.0),
                     normal: Vector | None = None, friction: float = 0.5, thickness: float = 0.005,
                     resolution: int = 64) -> int:
        """A scene collider; returns its id. ``shape``: "plane" (z < 0 of its frame; or give ``normal``: the
        plane through ``translation`` facing it), "box" (``half_extents``), "sphere" (``radius``), "capsule"
        (``radius`` about the segment |z| <= ``half_length``) or "mesh" (``vertices`` (V,3), ``triangles``
        (T,3) in its frame; closed, or open with its faces wound counter-clockwise seen from outside, inside
        behind them, not beyond its rim; sampled at ``resolution`` samples along its longest side). Particles keep
        ``thickness`` (> 0) from the surface, with Coulomb ``friction``."""
        index = choice("shape", shape, self.COLLIDER_SHAPES)
        verts = tris = None
        if index == 4:
            verts = as_array("vertices", vertices, (None, 3)).copy()
            tris = as_array("triangles", triangles, (None, 3), np.int32).copy()
        if normal is not None:
            rotation = frame_from_normal(vector("normal", normal))
        frame = (_rotation(rotation).copy(), vector("translation", translation))
        args = {"shape": shape, "half_extents": vector("half_extents", half_extents),
                "radius": number("radius", radius), "half_length": number("half_length", half_length),
                "vertices": verts, "triangles": tris, "friction": number("friction", friction),
                "thickness": number("thickness", thickness), "resolution": integer("resolution", resolution)}
        id = self._core.add_collider(index, args["half_extents"], args["radius"], args["half_length"], verts, tris,
                                     args["resolution"], args["friction"], args["thickness"], *frame)
        self._colliders[id] = {"args": args, "frame": frame, "target": None}
        self._collider_ids = id + 1
        return id

    def move_collider(self, id: int, translation: Vector, rotation: ArrayLike | None = None) -> None:
        """The collider's frame at the end of the next ``step`` call (reached at constant velocity over its
        steps; contact follows the swept motion)."""
        target = (_rotation(rotation).copy(), vector("translation", translation))
        self._core.move_collider(integer("id", id), *target)
        self._colliders[id]["target"] = target

    def update_collider_vertices(self, id: int, vertices: ArrayLike) -> None:
        """New vertices (V,3) of a mesh collider, in its frame (a deforming collider): re-sampled now."""
        verts = as_array("vertices", vertices, (None, 3))
        self._core.update_collider_vertices(integer("id", id), verts)
        self._colliders[id]["args"]["vertices"] = verts.copy()

    def set_collider_contact(self, id: int, friction: float = 0.5, thickness: float = 0.005) -> None:
        """A collider's Coulomb friction and thickness (m, > 0); unknown ids raise IndexError."""
        contact = {"friction": number("friction", friction), "thickness": number("thickness", thickness)}
        self._core.set_collider_contact(integer("id", id), *contact.values())
        self._colliders[id]["args"].update(contact)

    def remove_collider(self, id: int) -> None:
        """Removes a collider; unknown ids raise IndexError."""
        self._core.remove_collider(integer("id", id))
        del self._colliders[id]

    @property
    def n_colliders(self) -> int:
        """How many colliders the simulation has."""
        return self._core.collider_count()

    def push_out(self, points: ArrayLike, out: Floats | None = None) -> Floats:
        """``points`` (n,3) with those inside a collider or below the floor moved to the surface, written into
        ``out`` (float64 (n,3), C-contiguous, writable; ``points`` itself to push in place) and returned, or into
        a new array: what a skinned mesh shows (``Skin.deform_sim`` does it)."""
        pts = as_array("points", points, (None, 3))
        if out is None:
            out = pts.copy()
        else:
            if not (isinstance(out, np.ndarray) and out.dtype == np.float64 and out.shape == pts.shape
                    and out.flags.c_contiguous and out.flags.writeable):
                raise ValueError(f"out must be a C-contiguous, writable float64 array of shape {pts.shape}")
            np.copyto(out, pts)
        self._core.push_out(out)
        return out

    def collider_distances(self, points: ArrayLike) -> Floats:
        """The signed distance of each point (n,3) to the nearest collider or the floor (negative inside)."""
        pts = as_array("points", points, (None, 3))
        out = np.empty(len(pts))
        self._core.collider_distances(pts, out)
        return out

    def set_contact_skin(self, skin: Any, bodies: bool = True) -> None:
        """The skinned surface as the contact shape of the floor and the colliders (docs/contact.md, "Contact on
        the skin"): each rest vertex of ``skin`` (an ``opdeform.Skin`` of this graph) is carried rigidly by each
        particle that skins it (weight > 0), and these points meet them instead of the particles' ellipsoids:
        the skinned vertex, a blend of its carried copies, stays out of a plane that each copy stays out of, so
        the skin, not the ellipsoids, rests on them. While the goals carry the rest (``set_goals_carry_rest``) a
        particle carries only the vertices it skins with a weight of at least ``CONTACT_WEIGHT`` (or its vertex's
        largest): a far copy of small weight met a floor the skin never came near. None: the ellipsoids again
        (the default). In a ContactGroup these points also meet the other members (their skin points, or their
        ellipsoids where they have none); ``bodies=False``: the other members meet this body's ellipsoids (the
        add-on's groups). Self-contact keeps the ellipsoids."""
        if skin is None:
            self.set_contact_points(None)
            return
        if getattr(skin, "graph", None) is not self.graph:
            raise ValueError("skin: an opdeform.Skin bound to this simulation's graph expected")
        rest = skin.deform(self.graph.centers, np.tile(np.eye(3), (self.graph.n_particles, 1, 1)))
        self._carry_skin(rest, skin.indices, skin.weights, bodies)

    def _carry_skin(self, rest: ArrayLike, indices: ArrayLike, weights: ArrayLike, bodies: bool) -> None:
        """set_contact_skin's points from the skin's rest vertices (V,3), indices and weights (V,m): those the
        goals' rest setting carries. Kept (and pickled), so that a change of that setting carries them again."""
        rest = as_array("contact_skin rest", rest, (None, 3))
        indices = as_array("contact_skin indices", indices, (len(rest), None), np.int32)
        weights = as_array("contact_skin weights", weights, indices.shape)
        least = np.minimum(CONTACT_WEIGHT if self.goals_carry_rest else 0.0, weights.max(axis=1, keepdims=True))
        carried = (weights > 0.0) & (weights >= least)
        vertex = np.broadcast_to(np.arange(len(rest))[:, None], carried.shape)[carried]
        self.set_contact_points(rest[vertex], indices[carried], bodies)
        self._contact_skin = (rest, indices, weights, bool(bodies))

    def set_contact_points(self, points: ArrayLike | None, particles: ArrayLike | None = None,
                           bodies: bool = True) -> None:
        """``set_contact_skin`` with any rest-space points (m,3) (a sampling of the skin), each carried by the
        particle of ``particles`` (m,) int; a particle given none keeps its centre. None: the ellipsoids."""
        self._contact_skin = None
        if points is None:
            self._core.set_contact_skin(np.empty((0, 3)), np.empty(0, np.int32), False)
            self._contact_points = None
            return
        pts = as_array("points", points, (None, 3))
        owner = as_array("particles", particles, (len(pts),), np.int32)
        self._core.set_contact_skin(pts, owner, bool(bodies))
        self._contact_points = (pts.copy(), owner.copy(), bool(bodies))

    @property
    def n_contact_points(self) -> int:
        """How many skin points meet the floor and the colliders (0: the particles' ellipsoids do)."""
        return self._core.contact_skin_count()

    # -- contact between particles (docs/contact.md) -----------------------------------------------------
    def set_self_contact(self, enabled: bool = True, thickness: float = 0.005, friction: float = 0.5,
                         exclusion_ring: int = 2, exclusion_scale: float = 1.5) -> None:
        """Contact of distant parts of this body with each other (a tail against its own body). Pairs of
        particles at most ``exclusion_ring`` edges apart, or closer at rest than ``exclusion_scale`` times the
        sum of their largest radii, never collide; the others keep ``thickness`` (m) apart along the line
        between their centres, with Coulomb ``friction``. ``enabled=False`` turns it off."""
        self._core.set_self_contact(bool(enabled), number("thickness", thickness), number("friction", friction),
                                    integer("exclusion_ring", exclusion_ring),
                                    number("exclusion_scale", exclusion_scale))

    @property
    def self_contact(self) -> dict[str, Any] | None:
        """The self-contact settings of ``set_self_contact`` as a dict, or None when off."""
        return self._core.self_contact()

    # -- solving ---------------------------------------------------------------------------------------
    def solve_static(self, iterations: int) -> None:
        """The static pose (no inertia, gravity included) from the current state; needs a position
        constraint on every connected piece."""
        self._core.solve_static(integer("iterations", iterations))

    def energy(self) -> float:
        """The objective of the last step (or static solve) at the current iterate."""
        return self._core.energy()

    # -- pickling ---------------------------------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        """Everything a step reads: graph, parameters, stiffness scale, link softness, damping per particle, solver
        settings, floor, goals (with their rest setting and motion), constraints (ids, slot order, targets as
        stored), force fields, colliders (ids, frames, targets, deformed vertices), self-contact, the contact points
        (a skin's carried again when the goals' rest changes) and the state with velocities. The factorization is
        rebuilt; counters restart."""
        solver = dict(self.solver, tolerance=self.tolerance, max_iterations=self.max_iterations)
        return {"graph": self.graph, "params": self.params, "stiffness_scale": self.stiffness_scale,
                "link_softness": self.link_softness, "stretch_bound": self._stretch_bound, "solver": solver,
                "trace_energy": self.trace_energy, "floor": self._floor, "goal_hz": self._goal_hz,
                "goal_frames": self._goal_frames, "goal_rest": self.goals_carry_rest, "goal_motion": self.goal_motion,
                "surface_forces": self.surface_forces,
                "particle_damping": self.particle_damping,
                "constraints": self._constraints, "history": self._history, "ids_before": self._ids_before,
                "targets": {id: self._core.constraint_target(id) for id in self._constraints},
                "state": (self.positions, self.rotations, self.velocities, self.angular_velocities),
                "fields": self._calls, "colliders": self._colliders, "collider_ids": self._collider_ids,
                "self_contact": self.self_contact, "contact_points": self._contact_points,
                "contact_skin": self._contact_skin}

    def __setstate__(self, saved: dict[str, Any]) -> None:
        """Unpickling: the saved calls replayed after ``check_simulation`` bounds them. ``pickle.loads`` runs
        whatever a crafted pickle names before this is reached, and nothing here can stop that: unpickle only
        what you or a trusted process wrote. For state kept where others can write (shared farm storage), store
        data instead: ``positions``, ``rotations``, ``velocities`` and ``angular_velocities`` as arrays
        (``numpy.savez``, read with ``numpy.load(..., allow_pickle=False)``) and ``set_state`` them on a
        Simulation your own code builds, as the bake's checkpoints do (docs/pipeline.md)."""
        check_simulation(saved)
        self._start(saved["graph"], core_params(**saved["params"]))
        self.set_solver(**saved["solver"])
        self.trace_energy = saved["trace_energy"]
        if saved["floor"] is not None:
            self.set_floor(*saved["floor"])
        if saved["stiffness_scale"] is not None:
            self.set_stiffness_scale(saved["stiffness_scale"])
        self.set_link_softness(saved.get("link_softness"))
        self.set_stretch_limit(*saved.get("stretch_bound", (0.0, None)))
        if saved["goal_hz"] is not None:
            self.set_goal_frequencies(saved["goal_hz"])
        self.set_goals_carry_rest(saved.get("goal_rest", False))
        if saved["goal_frames"] is not None:
            self.set_goals(*saved["goal_frames"])
        self.set_goal_motion(saved.get("goal_motion"))
        self.set_particle_damping(saved.get("particle_damping"))
        self._replay(saved["ids_before"], saved["history"], saved["constraints"], saved["targets"])
        for name, args in saved["fields"]:
            getattr(self, name)(*args)
        self._replay_colliders(saved["collider_ids"], saved["colliders"])
        if saved["self_contact"] is not None:
            self.set_self_contact(True, **saved["self_contact"])
        if saved.get("contact_skin") is not None:  # carried again when the goals' rest changes, as set
            self._carry_skin(*saved["contact_skin"])
        elif saved.get("contact_points") is not None:
            self.set_contact_points(*saved["contact_points"])
        self._core.restore_state(*saved["state"])
        self.set_surface_forces(saved.get("surface_forces"))

    def _replay(self, ids_before: int, history: list[int], constraints: dict[int, list[Any]],
                targets: dict[int, Any]) -> None:
        """The same adds and removals, so that ids and slots match; removed constraints come back as
        placeholders, live ones as added, with their targets as stored (no renormalisation)."""
        placeholder = [0, tuple(self.graph.centers[0]), None, 1.0]
        for op in [op for id in range(ids_before) for op in (id, ~id)] + history:
            if op < 0:
                self.remove_constraint(~op)
                continue
            kind, point, direction, weight = constraints.get(op, placeholder)
            target = targets.get(op, point)
            if kind == 0:
                self.add_position_constraint(point, target, weight)
            else:
                self.add_direction_constraint(point, direction, target, weight)
        for id, target in targets.items():
            self._core.restore_constraint_target(id, target)

    def _replay_colliders(self, ids: int, colliders: dict[int, dict[str, Any]]) -> None:
        """Each live collider added again at its frame now (ids in order, removed ones as placeholders, so that
        ids and the order contact takes them in match), then sent on to its target."""
        for id in range(ids):
            c = colliders.get(id)
            if c is None:
                self.remove_collider(self.add_collider("plane"))
                continue
            self.add_collider(**c["args"], rotation=c["frame"][0], translation=c["frame"][1])
            if c["target"] is not None:
                self.move_collider(id, c["target"][1], c["target"][0])

    # -- parameters and diagnostics --------------------------------------------------------------------
    def set_params(self, **changes: Any) -> None:
        """Changes parameters (same names as the constructor); the state is kept. A stiffness replaces the
        stiffness scale too: one per particle sets it, a number makes it uniform; the link softness stays."""
        p = self._changed_params(changes)
        p["stiffness"], scale = split_stiffness(p["stiffness"], self.graph.n_particles)
        self._core.set_params(*core_params(**p))
        if "stiffness" in changes:
            self.set_stiffness_scale(scale)

    ACCELERATORS = ("none", "anderson", "chebyshev", "auto")

    FACTORIZATIONS = ("auto", "simplicial", "supernodal")

    def set_solver(self, accelerator: str = "none", window: int = 5, rho: float = 0.999, threads: int = 1,
                   factorization: str = "auto", tolerance: float | None = None,
                   max_iterations: int | None = None) -> None:
        """How the local/global iteration runs: ``accelerator`` "none" (plain), "anderson" (history
        ``window``) or "chebyshev" (spectral radius estimate ``rho``), both safeguarded by the energy, or
        "auto": under a tolerance each step makes two plain pairs and goes on plain (to half the tolerance)
        when they contracted fast, else turns Chebyshev on (the variant that meets the error and cost goals
        on both of docs/settings.md's bars); without a tolerance "auto" is Chebyshev;
        ``threads`` (0..64; 0: the CPUs this process may use) for the local step (a block of particles per
        thread, the borders in phases), the right side and the substitution (levels of subtrees of a
        METIS-ordered factor); results are the same bits run to run for a given thread count; CHOLMOD's
        ``factorization`` path ("auto": simplicial below 400 flops per factor entry, else supernodal;
        "simplicial"; "supernodal"). ``tolerance`` > 0: each step
        iterates until its residual (the largest displacement of a particle's material in the last pair, as
        a fraction of the body's size) is at most this, at most ``max_iterations`` pairs, and
        ``step_report`` says what it reached; 0: ``iterations`` pairs a step. None keeps the current value of
        either (defaults: 0 and 100)."""
        current = self._core.solver()
        tolerance = current["tolerance"] if tolerance is None else number("tolerance", tolerance)
        cap = current["max_iterations"] if max_iterations is None else integer("max_iterations", max_iterations)
        self._core.set_solver(choice("accelerator", accelerator, self.ACCELERATORS), integer("window", window),
                              number("rho", rho), integer("threads", threads),
                              choice("factorization", factorization, self.FACTORIZATIONS), tolerance, cap)

    @property
    def solver(self) -> dict[str, Any]:
        """The solver settings of set_solver() as a dict: the accelerator, window, rho, threads and
        factorization (``tolerance`` and ``max_iterations`` apart)."""
        s = self._core.solver()
        del s["tolerance"], s["max_iterations"]
        s["accelerator"] = self.ACCELERATORS[s["accelerator"]]
        s["factorization"] = self.FACTORIZATIONS[s["factorization"]]
        return s

    @property
    def tolerance(self) -> float | None:
        """The residual tolerance of a step (0: ``iterations`` pairs a step), set by ``set_solver``."""
        return self._core.solver()["tolerance"]

    @property
    def max_iterations(self) -> int | None:
        """The cap of a step under a tolerance, set by ``set_solver``."""
        return self._core.solver()["max_iterations"]

    @property
    def step_report(self) -> dict[str, float]:
        """What the last ``step`` call did: steps, iterations (all steps), most_iterations (in one step), error
        (the largest error estimate at the end of a step: the residual, a fraction of the body's size, doubled
        for "auto"'s plain pairs; -1 without a tolerance) and unconverged (steps that stopped at
        max_iterations above the tolerance)."""
        return self._core.step_report()

    @property
    def trace_energy(self) -> bool:
        """Whether each call records the objective after every local and global step (``energy_trace``)."""
        return self._core.trace_energy

    @trace_energy.setter
    def trace_energy(self, enabled: bool) -> None:
        self._core.trace_energy = bool(enabled)

    @property
    def energy_trace(self) -> Floats:
        """Objective after the first global solve and after each local and global step of the last call."""
        out = np.empty(self._core.trace_length())
        self._core.read("energy_trace", out)
        return out


def frame_from_normal(normal: Vector) -> Floats:
    """A rotation whose z axis is ``normal`` (the frame of a plane collider facing it)."""
    n = np.asarray(normal, dtype=np.float64)
    length = np.linalg.norm(n)
    if not length > 0:
        raise ValueError(f"normal must not be zero, got {tuple(normal)}")
    z = n / length
    x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _rotation(rotation: ArrayLike | None) -> Floats:
    return np.eye(3) if rotation is None else as_array("rotation", rotation, (3, 3))


def split_stiffness(stiffness: float | ArrayLike, n: int) -> tuple[Any, Floats | None]:
    """(k, scale) of a stiffness: a number as given (scale None; core_params checks it), or one per particle (k
    their mean, scale k_i / k)."""
    if np.ndim(stiffness) == 0:
        return stiffness, None
    per_particle = as_array("stiffness", stiffness, (n,))
    bad = np.flatnonzero(~(np.isfinite(per_particle) & (per_particle > 0.0)))
    if len(bad):  # named here: the mean (nan, 0) and the scale it divides would hide which one
        raise ValueError(f"stiffness[{bad[0]}] = {per_particle[bad[0]]} must be finite and > 0")
    k = float(per_particle.mean())
    return k, per_particle / k


def core_params(stiffness: float, density: float, dt: float, iterations: int, gravity: Vector, damping: float,
                skin_neighbors: int) -> tuple[Any, ...]:
    """The core's positional parameters (a Simulation's and a ShapeMatching's), each converted by name."""
    return (number("stiffness", stiffness), number("density", density), number("dt", dt),
            integer("iterations", iterations), vector("gravity", gravity), number("damping", damping),
            integer("skin_neighbors", skin_neighbors))
