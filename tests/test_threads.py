"""Thread safety (docs/hardening.md): the GIL is released inside the heavy calls, so separate objects step in
parallel with results identical to running them one after the other, and one object used from a second
thread while it is inside such a call refuses with RuntimeError instead of corrupting its state."""

import threading

import numpy as np
import pytest

import opdeform
from opdeform import mpm, scenes


def _bar():
    sim = scenes.fig1_bar()
    tip = sim.add_position_constraint((2.0, 0.0, 0.0), weight=1e5)
    sim.set_constraint_target(tip, (1.8, 0.2, 0.3))
    return sim


def _body():
    return scenes.falling_body(damping=0.01)


def _twist():
    tb = scenes.TwistedBar()
    tb.animate(0.5)
    return tb.sim


def _world():
    w = mpm.World((0, 0, 0), (1, 1, 1), 1 / 32, threads=1)
    w.add_particles(mpm.fill_box((0.35, 0.35, 0.3), (0.65, 0.65, 0.5), 1 / 64), mpm.snow())
    w.add_floor(0.1)
    return w


def _state(obj):
    if isinstance(obj, mpm.World):
        return [obj.read(name) for name in ("positions", "velocities", "orientations", "deformation")]
    return [obj.positions, obj.rotations, obj.velocities, obj.angular_velocities]


def _advance(obj, count):
    if isinstance(obj, mpm.World):
        for _ in range(count):
            obj.step(1 / 120)
    else:
        obj.step(count)


def _run_concurrently(fns):
    """Runs each fn in its own thread, all released at once; re-raises the first exception."""
    barrier = threading.Barrier(len(fns))
    errors = []

    def wrap(fn):
        try:
            barrier.wait()
            fn()
        except BaseException as exc:  # noqa: BLE001 - reported to the main thread
            errors.append(exc)

    threads = [threading.Thread(target=wrap, args=(fn,)) for fn in fns]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert not any(t.is_alive() for t in threads), "a thread did not finish"
    if errors:
        raise errors[0]


@pytest.mark.parametrize("makers", [(_bar, _body), (_body, _body), (_twist, _world), (_world, _world)],
                         ids=["bar+body", "body+body", "twist+mpm", "mpm+mpm"])
def test_two_objects_stepping_at_once_match_one_after_the_other(makers):
    counts = [400 if m is not _world else 6 for m in makers]
    sequential = []
    for make, count in zip(makers, counts):
        obj = make()
        _advance(obj, count)
        sequential.append(_state(obj))

    objs = [make() for make in makers]
    # Several rounds, so that the two really overlap (each round starts both at once).
    rounds = 4
    for r in range(rounds):
        _run_concurrently([lambda o=o, c=c: _advance(o, c // rounds + (c % rounds if r == rounds - 1 else 0))
                           for o, c in zip(objs, counts)])
    for obj, expected in zip(objs, sequential):
        for got, want in zip(_state(obj), expected):
            assert np.array_equal(got, want), "a simulation stepped beside another gave different bits"


def _refused(outcome):
    return isinstance(outcome, RuntimeError) and "another thread" in str(outcome)


def _probe_during(call, ready, probes, timeout=120.0, limit=None):
    """Runs `call` on a second thread. Once `ready()` (a call that changes nothing) is refused here - so `call`
    is running - runs `probes` in turn until one is not refused (then `call` has ended), `call` ends, or
    `limit` probes ran (stopping well before the end of `call` keeps the race at its end out of the test).
    Returns (outcomes of the probes, the error `call` raised or None, whether a probe got through)."""
    done = threading.Event()
    failure = []

    def worker():
        try:
            call()
        except BaseException as exc:  # noqa: BLE001 - reported to the caller
            failure.append(exc)
        finally:
            done.set()

    t = threading.Thread(target=worker)
    t.start()
    inside = False
    while not done.is_set() and not inside:
        try:
            ready()
        except RuntimeError as exc:
            inside = _refused(exc)
    outcomes, through = [], False
    k = 0
    while inside and not done.is_set() and not through and (limit is None or k < limit):
        try:
            outcomes.append(probes[k % len(probes)]())
            through = True
        except Exception as exc:  # noqa: BLE001 - the outcome is what is checked
            outcomes.append(exc)
            through = not _refused(exc)
        k += 1
    t.join(timeout)
    assert not t.is_alive()
    return outcomes, (failure[0] if failure else None), through


def test_one_simulation_from_two_threads_raises_and_loses_nothing():
    """While step() runs (GIL released), every call on the same simulation from another thread raises
    RuntimeError and changes nothing: the result is bit for bit that of the undisturbed steps."""
    steps = 1000
    reference = _body()
    reference.step(steps)
    for attempt in range(3):
        sim = _body()
        n = sim.graph.n_particles
        probes = [lambda: sim.step(1), lambda: sim.solve_static(1), lambda: sim.positions,
                  lambda: sim.set_state(sim.graph.centers, np.tile(np.eye(3), (n, 1, 1))),
                  lambda: sim.add_position_constraint((0.0, 0.0, 1.0)), lambda: sim.set_params(damping=0.5),
                  lambda: sim.energy(), lambda: sim.set_floor(0.5), lambda: sim.clear_floor(),
                  lambda: sim.set_constraint_target(0, (0.0, 0.0, 0.0)), lambda: sim.remove_constraint(0),
                  lambda: setattr(sim, "trace_energy", True)]
        outcomes, failure, through = _probe_during(lambda: sim.step(steps), lambda: sim.velocities, probes,
                                                   limit=2 * len(probes))
        assert failure is None, failure
        if not through:
            break  # every probe landed inside the step (one got through only if the step ended meanwhile)
    assert len(outcomes) >= len(probes), f"only {len(outcomes)} calls landed inside a step of {steps}"
    assert all(_refused(o) for o in outcomes), outcomes
    for got, want in zip(_state(sim), _state(reference)):
        assert np.array_equal(got, want)
    assert sim.n_constraints == reference.n_constraints
    assert sim.params == reference.params


def test_gil_is_released_inside_a_step():
    """Python code keeps running on another thread during a long step: many calls land inside it."""
    sim = _body()
    outcomes, failure, through = _probe_during(lambda: sim.step(1000), lambda: sim.positions,
                                               [lambda: sim.positions])
    assert failure is None
    assert sum(_refused(o) for o in outcomes) > 10, "the other thread hardly ran during the step"


def test_one_mpm_world_from_two_threads_raises():
    reference = _world()
    reference.step(8 / 120)
    for attempt in range(3):
        world = _world()
        probes = [lambda: world.step(1 / 120), lambda: world.positions, lambda: world.add_floor(0.05),
                  lambda: world.move_collider(0, (0, 0, 0.1)), lambda: world.update_orientations(),
                  lambda: world.add_particles([(0.5, 0.5, 0.9)], mpm.snow())]
        outcomes, failure, through = _probe_during(lambda: world.step(8 / 120), lambda: world.velocities, probes,
                                                   limit=2 * len(probes))
        assert failure is None, failure
        if not through:
            break
    assert outcomes and all(_refused(o) for o in outcomes), outcomes
    for got, want in zip(_state(world), _state(reference)):
        assert np.array_equal(got, want)


def test_adding_a_mesh_collider_refuses_a_step_meanwhile():
    """add_collider of a mesh computes distance samples with the GIL released: a step of the same world from
    another thread must be refused meanwhile (it would walk the collider array being reallocated)."""
    from opdeform import meshes

    vertices, triangles = meshes.capsule(radius=0.4, length=0.6, segments=128, rings=32, body=32)
    vertices, triangles = vertices.astype(np.float64), triangles.astype(np.int32)
    for attempt in range(4):
        window, calls = _steps_during_add_collider(vertices, triangles)
        t0, t1 = window
        assert t1 - t0 > 0.05, f"add_collider took only {t1 - t0:.3f} s: make the mesh finer"
        # Calls well inside the window (after the switch interval, so the adding thread was surely in C).
        inside = [o for a, b, o in calls if a > t0 + 0.02 and b < t1]
        if inside:
            break  # on a loaded machine the stepping thread may not be scheduled inside the window: try again
    assert inside, "no step call landed while the collider was added"
    assert all(_refused(o) for o in inside), f"{sum(o is None for o in inside)} steps ran during add_collider"


def _steps_during_add_collider(vertices, triangles):
    """Adds a mesh collider on one thread while this one steps the world; returns the adding call's time
    window and (start, end, outcome) of every step call."""
    import time

    world = mpm.World((-1, -1, -1), (1, 1, 1), 1 / 128, threads=1)
    world.add_particles(mpm.fill_box((-0.05, -0.05, 0.8), (0.05, 0.05, 0.9), 1 / 128), mpm.snow())
    core = world._core
    window = []

    def add():
        t0 = time.perf_counter()
        core.add_collider(3, 1, 0.0, (0.5, 0.5, 0.5), vertices, triangles, np.eye(3).ravel(), (0.0, 0.0, 0.0))
        window.extend([t0, time.perf_counter()])

    done = threading.Event()
    t = threading.Thread(target=lambda: (add(), done.set()))
    t.start()
    calls = []
    while not done.is_set():
        start = time.perf_counter()
        try:
            core.step(1e-4)
            outcome = None
        except RuntimeError as exc:
            outcome = exc
        calls.append((start, time.perf_counter(), outcome))
    t.join(60)
    return window, calls


def test_one_skin_from_two_threads():
    """Two threads deforming one skin: each call either finishes with the right result or is refused."""
    from opdeform import mesh as opmesh
    from opdeform import meshes

    vertices, triangles = meshes.capsule(radius=0.1, length=0.6, segments=128, rings=64, body=64)
    graph = opmesh.graph_from_mesh(vertices, triangles, particles=60)
    skin = opmesh.Skin(graph, vertices, triangles=triangles, threads=2)
    rng = np.random.default_rng(3)
    x = graph.centers + 0.01 * rng.standard_normal((graph.n_particles, 3))
    r = np.tile(np.eye(3), (graph.n_particles, 1, 1))
    expected = skin.deform(x, r)
    results = [[], []]

    def work(slot):
        for _ in range(30):
            try:
                results[slot].append(skin.deform(x, r))
            except RuntimeError as exc:
                assert "another thread" in str(exc)

    _run_concurrently([lambda: work(0), lambda: work(1)])
    got = results[0] + results[1]
    assert got, "every deform was refused"
    for out in got:
        assert np.array_equal(out, expected)


def test_graphs_built_at_once_match():
    from opdeform import mesh as opmesh
    from opdeform import meshes

    vertices, triangles = meshes.capsule(radius=0.1, length=0.6)
    expected = opmesh.graph_from_mesh(vertices, triangles, particles=40).centers
    out = [None, None]

    def build(slot):
        out[slot] = opmesh.graph_from_mesh(vertices, triangles, particles=40).centers

    _run_concurrently([lambda: build(0), lambda: build(1)])
    assert np.array_equal(out[0], expected) and np.array_equal(out[1], expected)


def test_simulations_are_independent_objects():
    """Graphs are shared read-only: many simulations of one graph stepping at once stay bit-identical."""
    graph = scenes.body_graph()
    sims = [opdeform.Simulation(graph, 2e5) for _ in range(4)]
    for s in sims:
        s.set_floor(0.0, 0.5)
    _run_concurrently([lambda s=s: s.step(150) for s in sims])
    first = sims[0].positions
    for s in sims[1:]:
        assert np.array_equal(s.positions, first)


@pytest.mark.parametrize("threads", [3, 24])
def test_parallel_sweep_stays_deterministic_and_within_the_iteration_error(threads):
    """The local step's border sweeps in phases (local_step.c): 3 blocks of the 720-particle beam sweep block 0's
    and block 2's borders at once; 24 blocks of 30 particles are thinner than an edge's reach (up to 42 indices):
    492 particles reach past the blocks beside theirs and sweep last on one thread. Runs repeat bit for bit, and
    after 80 steps they differ from one thread's by under 1 % of what 10 pairs a step leave of 40 pairs'."""
    from test_acceleration import pinned_beam

    def run(threads, iterations=10):
        sim = pinned_beam()
        sim.set_params(iterations=iterations)
        sim.set_solver(threads=threads)
        sim.step(80)
        return sim.positions

    serial = run(1)
    iteration_error = np.abs(serial - run(1, iterations=40)).max()
    first = run(threads)
    assert np.array_equal(first, run(threads))
    assert np.abs(first - serial).max() < 0.01 * iteration_error


def test_thread_bound_reads_the_plan():
    """The plan's bound (od_Sim_GetThreadBound): 0 before a step has made the partition and the factor, 1 on one
    thread; on 8 threads above 1 and at most 8 for both stages of a 6,000-particle beam, and 1 for the 720-particle
    beam's substitution (too little work for a second thread: the plan stays serial)."""
    from test_acceleration import pinned_beam

    one, eight, small = pinned_beam(60, 10, 10), pinned_beam(60, 10, 10), pinned_beam()
    eight.set_solver(threads=8)
    small.set_solver(threads=8)
    assert eight._core.thread_bound() == {"threads": 8, "local": 0.0, "global": 0.0}
    for sim in (one, eight, small):
        sim.step(1)
    assert one._core.thread_bound() == {"threads": 1, "local": 1.0, "global": 1.0}
    bound = eight._core.thread_bound()
    assert 1.5 < bound["local"] <= 8 and 1.5 < bound["global"] <= 8, bound
    assert small._core.thread_bound()["global"] < 1.1


@pytest.mark.parametrize("make", [scenes.fig1_bar, scenes.falling_body], ids=["fig1_bar", "fig4_body"])
def test_small_graphs_step_alike_on_any_thread_count(make):
    """Under 512 particles the sweep is serial, and a factor too small to split keeps AMD's ordering on any thread
    count (global_solve.c, od_Analyze): 1, 2 and 16 threads give the same bits."""
    states = []
    for threads in (1, 2, 16):
        sim = make()
        sim.set_solver(threads=threads)
        sim.step(30)
        states.append(sim.positions)
    assert all(np.array_equal(states[0], s) for s in states[1:])
