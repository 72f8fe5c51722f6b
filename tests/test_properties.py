"""Property-based tests (docs/hardening.md): random sequences of API calls, driven by hypothesis, with the
invariants checked after every call:
- the state is finite and the rotations orthonormal, or the call raised a clean exception (ValueError,
  IndexError, opdeform.SolverError, never anything else and never a crash);
- a call that raised changed nothing: positions, rotations, velocities, the constraint count, parameters;
- ids behave: a live id can be moved, reweighted and removed; an unknown or removed id raises IndexError;
- a warmed-up step allocates nothing in the C core; repeating a whole program leaks nothing.
Deterministic (derandomize=True) and bounded, so that scripts/test stays fast; set OPDEFORM_HYPOTHESIS_EXAMPLES
for a longer hunt."""

import ctypes
import gc
import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import Bundle, RuleBasedStateMachine, consumes, initialize, invariant, multiple, rule

import opdeform
from opdeform import _core, mpm
from opdeform.simulation import MAX_WEIGHT_RATIO

SANITIZED = bool(os.environ.get("OPDEFORM_SANITIZED"))
EXAMPLES = int(os.environ.get("OPDEFORM_HYPOTHESIS_EXAMPLES", 12 if SANITIZED else 40))
CLEAN = (ValueError, IndexError, opdeform.SolverError)

SETTINGS = settings(max_examples=EXAMPLES, stateful_step_count=30, deadline=None, derandomize=True,
                    suppress_health_check=list(HealthCheck), print_blob=True)

# -- strategies ---------------------------------------------------------------------------------------------

SPECIAL = [math.nan, math.inf, -math.inf, 1e300, -1e300, 0.0, -0.0, 5e-324]
modest = st.floats(-1.0, 1.0, allow_nan=False, width=64)
anyfloat = st.one_of(modest, modest, modest, st.sampled_from(SPECIAL))
vec3 = st.tuples(anyfloat, anyfloat, anyfloat)
good_vec3 = st.tuples(modest, modest, modest)
weight = st.one_of(st.floats(1e2, 1e7), st.floats(1e2, 1e7), st.sampled_from([0.0, -1.0, math.nan, math.inf, 1e300]))


def _lattice(nx, ny, nz, spacing, two_pieces):
    idx = np.arange(nx * ny * nz).reshape(nx, ny, nz)
    centers = np.stack(np.meshgrid(*(np.arange(k) * spacing for k in (nx, ny, nz)), indexing="ij"), -1).reshape(-1, 3)
    edges = []
    for d in [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0)]:
        a = idx[: nx - d[0], : ny - d[1], : nz - d[2]]
        b = idx[d[0]:, d[1]:, d[2]:]
        edges += list(zip(a.ravel(), b.ravel()))
    edges = np.array(edges, np.int32).reshape(-1, 2)
    if two_pieces:
        n = len(centers)
        centers = np.vstack([centers, centers + [0.0, 0.0, 3 * spacing * nz]])
        edges = np.vstack([edges, edges + n])
    radii = np.full((len(centers), 3), 0.4 * spacing)
    return centers, radii, edges


graphs = st.builds(_lattice, st.integers(1, 4), st.integers(1, 3), st.integers(1, 2), st.sampled_from([0.05, 0.1]),
                   st.booleans())


def _near(graph, point):
    """The core's rule for a constraint's rest-space point: within 100 sizes of the box of the ellipsoids."""
    reach = graph.radii.max(axis=1)[:, None]
    lower, upper = (graph.centers - reach).min(axis=0), (graph.centers + reach).max(axis=0)
    outside = np.maximum(lower - point, np.asarray(point) - upper).max()
    return outside <= 100.0 * np.linalg.norm(upper - lower)


def _state(sim):
    return [sim.positions, sim.rotations, sim.velocities, sim.angular_velocities]


def _rotation(q):
    w, x, y, z = np.asarray(q, float) / (np.linalg.norm(q) or 1.0)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


# -- the simulation state machine ------------------------------------------------------------------------------

class SimulationMachine(RuleBasedStateMachine):
    ids = Bundle("ids")

    @initialize(graph=graphs, stiffness=st.sampled_from([1e3, 1e5, 1e7]), iterations=st.integers(1, 6))
    def create(self, graph, stiffness, iterations):
        self.graph = opdeform.Graph(*graph)
        self.n = self.graph.n_particles
        self.sim = opdeform.Simulation(self.graph, stiffness, iterations=iterations)
        self.live = set()
        self.kinds = {}
        self.seen = 0  # ids handed out so far

    def call(self, fn, *, must=None, changes_state=False):
        """Calls fn(); a clean exception must leave everything as it was. `must`: the exception type the
        call has to raise (None: it may succeed or raise a clean one). Returns (ok, result)."""
        before = _state(self.sim)
        count, params = self.sim.n_constraints, self.sim.params
        try:
            result = fn()
        except CLEAN as exc:
            if must is not None:
                assert isinstance(exc, must), f"expected {must.__name__}, got {exc!r}"
            for got, want in zip(_state(self.sim), before):
                assert np.array_equal(got, want, equal_nan=True), f"{exc!r} changed the state"
            assert self.sim.n_constraints == count, f"{exc!r} changed the constraint count"
            assert self.sim.params == params, f"{exc!r} changed the parameters"
            return False, exc
        assert must is None, f"expected {must.__name__}, the call succeeded"
        if not changes_state:
            for got, want in zip(_state(self.sim), before):
                assert np.array_equal(got, want), "a call that does not move the body changed the state"
        return True, result

    @rule(target=ids, point=vec3, target_point=st.one_of(st.none(), vec3), w=weight)
    def add_position(self, point, target_point, w):
        ok, cid = self.call(lambda: self.sim.add_position_constraint(point, target_point, w))
        valid = all(map(math.isfinite, point)) and (target_point is None or all(map(math.isfinite, target_point))) \
            and self._weight_ok("position", w) and _near(self.graph, point)
        assert ok == valid, (point, target_point, w, cid)
        if not ok:
            return multiple()
        assert cid == self.seen
        self.seen += 1
        self.live.add(cid)
        self.kinds[cid] = "position"
        return cid

    @rule(target=ids, point=good_vec3, direction=vec3, target_dir=st.one_of(st.none(), vec3), w=weight)
    def add_direction(self, point, direction, target_dir, w):
        ok, cid = self.call(lambda: self.sim.add_direction_constraint(point, direction, target_dir, w))
        if not ok:
            return multiple()
        self.seen += 1
        self.live.add(cid)
        self.kinds[cid] = "direction"
        return cid

    @rule(cid=st.one_of(ids, st.integers(-3, 60)), target_point=vec3)
    def set_target(self, cid, target_point):
        finite = all(map(math.isfinite, target_point))
        nonzero = any(x != 0.0 for x in target_point)  # 3.5e-292 and 5e-324 are directions too
        if cid not in self.live:
            self.call(lambda: self.sim.set_constraint_target(cid, target_point), must=CLEAN)
        else:
            ok, _ = self.call(lambda: self.sim.set_constraint_target(cid, target_point))
            # a direction constraint also refuses the zero vector
            assert ok or not finite or not nonzero, target_point

    @rule(cid=st.one_of(ids, st.integers(-3, 60)), w=weight)
    def set_weight(self, cid, w):
        ok, _ = self.call(lambda: self.sim.set_constraint_weight(cid, w),
                          must=None if cid in self.live else CLEAN)
        if cid in self.live:
            assert ok == self._weight_ok(self.kinds[cid], w)

    def _weight_ok(self, kind, w):
        """Positive, finite and at most MAX_WEIGHT_RATIO default weights (issue 28)."""
        return 0 < w <= MAX_WEIGHT_RATIO * self.sim.default_weight(kind)

    @rule(cid=st.one_of(consumes(ids), st.integers(-3, 60)))
    def remove(self, cid):
        if cid in self.live:
            ok, _ = self.call(lambda: self.sim.remove_constraint(cid))
            assert ok
            self.live.discard(cid)
        else:
            self.call(lambda: self.sim.remove_constraint(cid), must=IndexError)

    @rule(steps=st.integers(-1, 3))
    def step(self, steps):
        self.call(lambda: self.sim.step(steps), must=ValueError if steps < 1 else None, changes_state=True)

    @rule(iterations=st.integers(-1, 12))
    def solve_static(self, iterations):
        self.call(lambda: self.sim.solve_static(iterations), must=ValueError if iterations < 0 else None,
                  changes_state=True)

    @rule(data=st.data())
    def set_state(self, data):
        noise = data.draw(st.floats(0.0, 0.05))
        rng = np.random.default_rng(data.draw(st.integers(0, 2**16)))
        x = self.sim.positions + noise * rng.standard_normal((self.n, 3))
        r = np.array([_rotation(rng.standard_normal(4)) for _ in range(self.n)])
        v = data.draw(st.one_of(st.none(), st.just(rng.standard_normal((self.n, 3)))))
        w = data.draw(st.one_of(st.none(), st.just(rng.standard_normal((self.n, 3)))))
        spoil = data.draw(st.sampled_from(["none", "none", "nan", "improper", "scaled", "shape"]))
        if spoil == "nan":
            x[rng.integers(self.n), rng.integers(3)] = math.nan
        elif spoil == "improper":
            r[rng.integers(self.n)] *= -1.0
        elif spoil == "scaled":
            r[rng.integers(self.n)] *= 1.01
        elif spoil == "shape":
            x = x[:-1]
        ok, _ = self.call(lambda: self.sim.set_state(x, r, v, w), changes_state=True)
        assert ok == (spoil == "none")
        if ok:
            assert np.array_equal(self.sim.positions, x)
            assert np.abs(self.sim.rotations - r).max() < 1e-9

    @rule(stiffness=st.one_of(st.sampled_from([1e3, 1e6]), st.sampled_from([0.0, -1.0, math.nan])),
          dt=st.one_of(st.sampled_from([1 / 60, 1 / 240]), st.sampled_from([0.0, math.inf])),
          iterations=st.integers(0, 6), damping=st.sampled_from([0.0, 0.1, 1.0, 1.5, math.nan]),
          skin=st.integers(0, 17), gravity=st.one_of(good_vec3, vec3))
    def set_params(self, stiffness, dt, iterations, damping, skin, gravity):
        self.call(lambda: self.sim.set_params(stiffness=stiffness, dt=dt, iterations=iterations, damping=damping,
                                              skin_neighbors=skin, gravity=gravity))

    @rule(height=anyfloat, friction=anyfloat)
    def set_floor(self, height, friction):
        ok, _ = self.call(lambda: self.sim.set_floor(height, friction))
        assert ok == (math.isfinite(height) and math.isfinite(friction) and friction >= 0)

    @rule()
    def clear_floor(self):
        self.call(self.sim.clear_floor)

    @rule()
    def energy(self):
        ok, e = self.call(self.sim.energy)
        assert ok and isinstance(e, float)

    @rule(enabled=st.booleans())
    def trace(self, enabled):
        self.sim.trace_energy = enabled
        trace = self.sim.energy_trace
        assert trace.ndim == 1 and len(trace) == 0  # setting it clears the record of the last call

    @rule()
    def recreate(self):
        """Deletes the simulation (its C object is freed) and starts a new one on the same graph."""
        params = self.sim.params
        del self.sim
        gc.collect()
        self.sim = opdeform.Simulation(self.graph, params["stiffness"], params["density"], params["dt"],
                                       params["iterations"], params["gravity"], params["damping"],
                                       params["skin_neighbors"])
        self.live.clear()
        self.seen = 0

    @invariant()
    def finite_and_proper(self):
        if not hasattr(self, "sim"):
            return
        for a in _state(self.sim):
            assert np.isfinite(a).all()
        r = self.sim.rotations
        assert np.abs(np.einsum("nji,njk->nik", r, r) - np.eye(3)).max() < 1e-6
        assert self.sim.n_constraints == len(self.live)


TestSimulationSequences = SimulationMachine.TestCase
TestSimulationSequences.settings = SETTINGS


# -- the MPM world state machine -------------------------------------------------------------------------------

class WorldMachine(RuleBasedStateMachine):
    """Random MPM programs: batches, wind, colliders, moves, steps; finite and inside the box, or a clean error."""

    @initialize(dx=st.sampled_from([1 / 16, 1 / 24]), spin=st.sampled_from([0.0, 1.0, 2.5]))
    def create(self, dx, spin):
        self.world = mpm.World((0, 0, 0), (1, 1, 1), dx, spin=spin, threads=1)
        self.count = 0
        self.colliders = 0
        self.dead = False

    def call(self, fn):
        n = self.world.n_particles
        try:
            fn()
            return True
        except CLEAN as exc:
            assert self.world.n_particles == n
            if isinstance(exc, opdeform.SolverError):
                self.dead = True  # documented: a non-finite step ends the world
            return False

    @rule(lo=st.tuples(*[st.floats(0.0, 1.0)] * 3), size=st.floats(0.0, 0.3),
          kind=st.sampled_from(["snow", "jelly", "flakes"]), speed=st.floats(-3.0, 3.0),
          stiffness=st.sampled_from([1e3, 5e3, 1e5, 0.0, -1.0, math.nan]))
    def add(self, lo, size, kind, speed, stiffness):
        if self.dead:
            return
        pos = mpm.fill_box(lo, np.add(lo, size), 0.08) if size > 0.08 else np.array([lo])
        material = mpm.Material(kind=kind, young_modulus=stiffness)
        v = np.full(np.shape(pos), speed) if len(pos) else None
        if self.call(lambda: self.world.add_particles(pos, material, velocities=v)):
            self.count += len(pos)

    @rule(kind=st.sampled_from(["off", "noise", "potential"]), amplitude=st.floats(0.0, 3.0),
          wavelength=st.one_of(st.floats(0.1, 4.0), st.sampled_from([0.0, 1e-300, math.inf])))
    def wind(self, kind, amplitude, wavelength):
        if not self.dead:
            self.call(lambda: self.world.set_wind(kind, amplitude=amplitude, wavelength=wavelength))

    @rule(shape=st.sampled_from(["plane", "box", "sphere"]), center=good_vec3, r=st.floats(0.0, 0.3))
    def collider(self, shape, center, r):
        if not self.dead and self.call(lambda: self.world.add_collider(shape, radius=r, translation=np.abs(center))):
            self.colliders += 1

    @rule(which=st.integers(-1, 4), to=vec3)
    def move(self, which, to):
        if not self.dead:
            self.call(lambda: self.world.move_collider(which, to))

    @rule(duration=st.one_of(st.floats(1e-4, 1 / 120), st.sampled_from([0.0, -1.0, math.nan, math.inf])))
    def step(self, duration):
        if not self.dead:
            self.call(lambda: self.world.step(duration))

    @invariant()
    def finite_inside(self):
        if not hasattr(self, "world") or self.dead:
            return
        assert self.world.n_particles == self.count
        if self.count:
            x = self.world.positions
            assert np.isfinite(x).all() and (x >= 0).all() and (x <= 1).all()
            for name in ("velocities", "orientations", "deformation"):
                assert np.isfinite(self.world.read(name)).all()


TestWorldSequences = WorldMachine.TestCase
TestWorldSequences.settings = settings(SETTINGS, max_examples=max(3, EXAMPLES // 5), stateful_step_count=12)


# -- memory ---------------------------------------------------------------------------------------------------

def _malloc_in_use():
    """Bytes the C allocator has handed out and not taken back (glibc mallinfo2), or None."""
    class MallInfo2(ctypes.Structure):
        _fields_ = [(name, ctypes.c_size_t) for name in
                    ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks",
                     "keepcost")]
    try:
        libc = ctypes.CDLL(None)
        libc.mallinfo2.restype = MallInfo2
    except (OSError, AttributeError, TypeError):  # TypeError: Windows has no CDLL(None)
        return None
    info = libc.mallinfo2()
    return info.uordblks + info.hblkhd


def _program(seed):
    """A fixed program touching every part: graph, constraints, a failing step, bad calls, state, deletion."""
    centers, radii, edges = _lattice(3, 2, 2, 0.1, seed % 2 == 1)
    g = opdeform.Graph(centers, radii, edges)
    sim = opdeform.Simulation(g, 1e5, iterations=3)
    ids = [sim.add_position_constraint(p) for p in centers[:3]]
    sim.add_direction_constraint(centers[-1], (0, 0, 1), (0, 1, 0))
    sim.set_floor(-0.5, 0.3)
    sim.step(3)
    sim.set_constraint_target(ids[0], (0.0, 0.1, 0.0))
    sim.remove_constraint(ids[1])
    for bad in (lambda: sim.remove_constraint(ids[1]), lambda: sim.set_params(dt=-1.0),
                lambda: sim.add_position_constraint((math.nan, 0, 0)), lambda: sim.solve_static(5) if seed % 2 else
                sim.set_state(centers[:-1], np.eye(3)[None].repeat(len(centers), 0))):
        with pytest.raises(CLEAN):
            bad()
    x, r = sim.positions, sim.rotations
    sim.set_state(1e307 * (x + 1.0), r)
    with pytest.raises(opdeform.SolverError):
        sim.step()  # overflows: the previous state is kept
    sim.set_state(x, r)
    sim.set_params(gravity=(0.0, 0.0, -9.81))
    sim.trace_energy = True
    sim.solve_static(4) if seed % 2 == 0 else sim.step(2)
    _ = sim.energy_trace, sim.counters, sim.energy()
    w = mpm.World((0, 0, 0), (1, 1, 1), 1 / 16, threads=1)
    w.add_particles(mpm.fill_box((0.4, 0.4, 0.4), (0.6, 0.6, 0.6), 0.05), mpm.jelly())
    w.add_collider("sphere", radius=0.1, translation=(0.5, 0.5, 0.2))
    w.set_wind("noise", amplitude=1.0)
    w.step(1 / 240)
    del sim, g, w


@pytest.mark.skipif(SANITIZED, reason="LeakSanitizer checks leaks in the sanitizer run")
def test_repeated_programs_leak_nothing():
    """Runs the same program many times: after a warm-up, the bytes held by malloc do not grow."""
    if _malloc_in_use() is None:
        pytest.skip("glibc mallinfo2 is not available (Windows, macOS)")
    for seed in range(20):
        _program(seed)
    gc.collect()
    before = _malloc_in_use()
    rounds = 200
    for seed in range(rounds):
        _program(seed)
    gc.collect()
    grown = _malloc_in_use() - before
    # A leak of even one small block per program would add >= 200 * 32 bytes.
    assert grown < 4096, f"malloc holds {grown} more bytes after {rounds} programs"


def test_warmed_up_steps_allocate_nothing():
    """The core's allocation counter does not move over warmed-up steps, target moves and static solves."""
    centers, radii, edges = _lattice(4, 3, 2, 0.1, True)
    sim = opdeform.Simulation(opdeform.Graph(centers, radii, edges), 1e5)
    ids = [sim.add_position_constraint(p) for p in (centers[0], centers[len(centers) // 2])]
    sim.add_direction_constraint(centers[-1], (1, 0, 0))
    sim.set_floor(-0.2, 0.5)
    sim.step(5)
    sim.solve_static(3)
    sim.step(1)
    start = _core.allocation_count()
    for k in range(50):
        sim.set_constraint_target(ids[0], (0.01 * k, 0.0, 0.0))
        sim.step()
    sim.solve_static(3)
    sim.step()
    assert _core.allocation_count() == start
