"""The simulation behind one Blender object, free of bpy: rest mesh -> graph -> simulation -> skinned vertices.

The Blender layer reads the object's settings, mesh, vertex group and handle transforms, passes them here as
numbers, and writes ``Engine.out`` (float32, object space, the layout ``foreach_set("co", ...)`` copies) back
into the mesh. Bakes and live playback both go through ``goto``, so a bake equals playback bit for bit.
"""

import time

import numpy as np

from . import frames as frame_logic
from . import handles as handle_math
from .cache import StateCache

GRAPH_MODES = ("auto", "volume", "surface", "chain")


class EngineError(ValueError):
    """Bad input from the scene (a mesh without faces, an empty pin group, ...): a message for the user."""


class Engine:
    def __init__(self, od, rest_local, triangles, matrix_world=None, particles=100, mode="auto",
                 neighbors=4):
        self.od = od
        rest_local = np.asarray(rest_local, dtype=np.float32).reshape(-1, 3)
        triangles = np.asarray(triangles, dtype=np.int32).reshape(-1, 3)
        if len(rest_local) == 0:
            raise EngineError("the mesh has no vertices")
        if len(triangles) == 0:
            raise EngineError("the mesh has no faces: oriented particles need a surface or a volume")
        if not np.all(np.isfinite(rest_local)):
            raise EngineError("the mesh has non-finite vertex coordinates")
        if mode not in GRAPH_MODES:
            raise EngineError(f"graph mode must be one of {', '.join(GRAPH_MODES)}, got {mode!r}")
        m = np.eye(4) if matrix_world is None else np.asarray(matrix_world, dtype=np.float64).reshape(4, 4)
        if not np.all(np.isfinite(m)) or abs(np.linalg.det(m[:3, :3])) < 1e-12:
            raise EngineError("the object's transform is degenerate or not finite")
        self.rest_local = np.ascontiguousarray(rest_local)
        self.identity = bool(np.array_equal(m, np.eye(4)))
        if self.identity:
            self.rest = self.rest_local.astype(np.float64)
            self._to_local = None
        else:
            self.rest = self.rest_local.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
            inv = np.linalg.inv(m)
            self._to_local = (np.ascontiguousarray(inv[:3, :3].T), inv[:3, 3].copy())
            self._world = np.empty((len(self.rest), 3))
        self.matrix_world = m
        self.triangles = triangles
        # a low-poly mesh (the default cube) cannot hold more particles than it has distinct vertices
        distinct = len(np.unique(self.rest_local, axis=0))
        self.particles_clamped = int(particles) > distinct
        particles = min(int(particles), distinct)
        try:
            self.graph = od.Graph.from_mesh(self.rest, triangles, particles=int(particles), mode=mode)
            self.skin = od.Skin(self.graph, self.rest, neighbors=int(neighbors))
        except ValueError as exc:
            raise EngineError(f"building the particle graph failed: {exc}") from None
        self.neighbors = int(neighbors)
        n = self.graph.n_particles
        self._rest_state = (self.graph.centers, np.tile(np.eye(3), (n, 1, 1)), np.zeros((n, 3)), np.zeros((n, 3)))
        self.out = np.empty((len(self.rest), 3), dtype=np.float32)
        self.sim = None
        self._params = None
        self._substeps = 1
        self._floor = None
        self._constraint_key = None
        self._handle_ids = []
        self._pin_ids = []
        self.cache = StateCache()
        self.solver_frame = None
        self.start, self.end = 1, 250
        self.timing = {"solver": 0.0, "skin": 0.0}
        self.shown_state = self._rest_state[:2]

    # -- configuration ---------------------------------------------------------------------------------
    @property
    def n_vertices(self):
        return len(self.rest)

    def configure(self, params, substeps=1, floor=None, start=1, end=250):
        """params: stiffness, density, dt (per substep), iterations, gravity, damping. floor: (height, friction)
        or None. A change clears the in-memory cache (it is outdated). Returns True when something changed."""
        params = dict(params, skin_neighbors=self.neighbors)
        changed = False
        if self.sim is None:
            self.sim = self.od.Simulation(self.graph, **params)
            changed = True
        elif params != self._params:
            self.sim.set_params(**params)
            changed = True
        self._params = params
        if floor != self._floor:
            if floor is None:
                self.sim.clear_floor()
            else:
                self.sim.set_floor(*floor)
            self._floor = floor
            changed = True
        if int(substeps) != self._substeps or (int(start), int(end)) != (self.start, self.end):
            self._substeps = max(1, int(substeps))
            self.start, self.end = int(start), max(int(end), int(start))
            changed = True
        if changed:
            self.invalidate()
        return changed

    def invalidate(self, keep_until=None):
        """Marks the cache outdated: all of it, or the frames after keep_until."""
        if keep_until is None:
            self.cache.clear()
            self.solver_frame = None
        else:
            self.cache.truncate(keep_until)
            if self.solver_frame is not None and self.solver_frame > keep_until:
                self.solver_frame = None

    def set_constraints(self, pin_indices=(), pin_weights=None, pin_strength=1.0, handles=()):
        """Pins (vertex indices and weights, as a vertex group gives them; strength scales the solver's default
        weight) and handles (sequence of (vertex index, use_rotation, strength)). Re-adds the constraints only
        when they changed; then the cache is outdated."""
        pin_indices = np.asarray(pin_indices, dtype=np.int64).ravel()
        pin_weights = (np.ones(len(pin_indices)) if pin_weights is None
                       else np.asarray(pin_weights, dtype=np.float64).ravel())
        handles = tuple((int(v), bool(r), float(s)) for v, r, s in handles)
        key = (pin_indices.tobytes(), pin_weights.tobytes(), float(pin_strength), handles)
        if key == self._constraint_key:
            return False
        for h in self._handle_ids:
            for cid in h:
                self.sim.remove_constraint(cid)
        for cid in self._pin_ids:
            self.sim.remove_constraint(cid)
        self._pin_ids, self._handle_ids = [], []
        self._constraint_key = None
        if len(pin_indices):
            if pin_indices.min() < 0 or pin_indices.max() >= self.n_vertices:
                raise EngineError("pin vertex index out of range")
            base = float(pin_strength) * self.sim.default_weight("position")
            self._pin_ids = list(self.od.pin_vertices(self.sim, self.rest, pin_indices, weights=pin_weights,
                                                      weight=base))
        for vertex, use_rotation, strength in handles:
            if not 0 <= vertex < self.n_vertices:
                raise EngineError(f"handle vertex {vertex} out of range")
            ids = list(self.od.pin_vertices(self.sim, self.rest, [vertex],
                                            weight=strength * self.sim.default_weight("position")))
            if use_rotation:
                wd = strength * self.sim.default_weight("direction")
                ids += [self.od.add_vertex_direction(self.sim, self.rest, vertex, axis, weight=wd)
                        for axis in np.eye(3)]
            self._handle_ids.append(ids)
        self._constraint_key = key
        self.invalidate()
        return True

    @property
    def n_constraints(self):
        return len(self._pin_ids) + sum(len(h) for h in self._handle_ids)

    def _apply_targets(self, targets):
        if targets is None:
            return
        for ids, t in zip(self._handle_ids, targets):
            self.sim.set_constraint_target(ids[0], t[0])
            for cid, direction in zip(ids[1:], t[1:]):
                self.sim.set_constraint_target(cid, direction)

    # -- state ----------------------------------------------------------------------------------------
    def _state(self):
        s = self.sim
        return (s.positions, s.rotations, s.velocities, s.angular_velocities)

    def reset(self, targets=None):
        """The rest state at the start frame; the cache's start entry is (re)written."""
        self.sim.set_state(*self._rest_state)
        self._apply_targets(targets)
        self.solver_frame = self.start
        self.cache.store(self.start, self._rest_state, targets)

    def _restore(self, frame):
        self.sim.set_state(*self.cache.state(frame))
        self.solver_frame = frame

    # -- output ---------------------------------------------------------------------------------------
    def _emit(self, positions, rotations):
        t = time.perf_counter()
        if self._to_local is None:
            self.skin.deform(positions, rotations, out=self.out)
        else:
            self.skin.deform(positions, rotations, out=self._world)
            a, b = self._to_local
            np.matmul(self._world, a, out=self._world)
            self._world += b
            self.out[:] = self._world
        self.timing["skin"] += time.perf_counter() - t
        self.shown_state = (positions, rotations)
        return self.out

    def rest_output(self):
        self.shown_state = self._rest_state[:2]
        self.out[:] = self.rest_local
        return self.out

    # -- frames ---------------------------------------------------------------------------------------
    def goto(self, frame, targets=None):
        """The object-space vertices (float32 (V, 3), ``self.out``) of ``frame`` with handle targets (H, 4, 3)
        taken at that frame. Simulates what the cache lacks (see core/frames.py)."""
        self.timing = {"solver": 0.0, "skin": 0.0}
        plan = frame_logic.plan(frame, self.start, self.end, self.cache.last, self.solver_frame)
        if plan.kind == "rest":
            return self.rest_output()
        if plan.kind == "reset":
            self.reset(targets)
            return self.rest_output()
        if plan.kind == "show":
            pos, rot = self.cache.state(plan.frame)[:2]
            return self._emit(pos, rot)
        if plan.restore == "reset":
            self.reset(targets)
        elif plan.restore is not None:
            self._restore(plan.restore)
        last = self.solver_frame
        before = self.cache.targets(last)
        t0 = time.perf_counter()
        for k in plan.steps:
            if targets is None or before is None:
                tk = targets
            elif k == plan.frame:
                tk = targets
            else:
                tk = handle_math.blend(before, targets, (k - last) / (plan.frame - last))
            self._apply_targets(tk)
            self.sim.step(self._substeps)
            self.solver_frame = k
            self.cache.store(k, self._state(), tk)
        self.timing["solver"] += time.perf_counter() - t0
        pos, rot = self.cache.state(plan.frame)[:2]
        return self._emit(pos, rot)

    def pose(self, targets, iterations):
        """Posing mode: the static ARAP pose for the targets, warm-started from the current state."""
        self.timing = {"solver": 0.0, "skin": 0.0}
        if self.n_constraints == 0:
            raise EngineError("posing needs a pin group or a handle: a static pose without constraints is not "
                              "defined")
        self._apply_targets(targets)
        t0 = time.perf_counter()
        self.sim.solve_static(int(iterations))
        self.timing["solver"] += time.perf_counter() - t0
        self.cache.clear()
        self.solver_frame = None
        return self._emit(self.sim.positions, self.sim.rotations)
