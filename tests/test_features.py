"""Issue 5, section 4: the step does only the work the scene asks for. Each switch checked where it can be
(what it costs and saves is measured by `scripts/bench features`)."""

import math

import numpy as np

import opdeform
from opdeform import meshes, scenes


def pinned_body(**kw):
    sim = opdeform.Simulation(scenes.body_graph(), 2e5, **kw)
    for p in sim.graph.centers[:10]:
        sim.add_position_constraint(p)
    return sim


def state(sim):
    return sim.positions, sim.rotations, sim.velocities, sim.angular_velocities


def test_moving_targets_never_refactor():
    sim = pinned_body()
    handle = sim.add_position_constraint(sim.graph.centers[-1])
    sim.step()
    before = sim.counters
    for f in range(60):
        sim.set_constraint_target(handle, sim.graph.centers[-1] + (0.0, 0.0, 0.1 * math.sin(f / 5)))
        sim.step()
    after = sim.counters
    assert after["factorizations"] == before["factorizations"] == 1 and after["analyses"] == 1
    assert after["solves"] - before["solves"] == 60 * (sim.params["iterations"] + 1)  # back-substitutions only
    sim.set_constraint_weight(handle, 2 * sim.default_weight())  # a weight is in the matrix: one refactor
    sim.step(5)
    assert sim.counters["factorizations"] == 2


def test_static_pose_has_no_inertia():
    """A static pose depends on neither h nor the damping (they enter only the inertia), and changing h or
    the density does not refactor the static matrix, which has no mass term."""
    a, b = pinned_body(), pinned_body(dt=1 / 5, damping=0.5)
    a.solve_static(50)
    b.solve_static(50)
    for x, y in zip(state(a), state(b)):
        assert np.array_equal(x, y)
    factored = a.counters["factorizations"]
    a.set_params(dt=1 / 30, density=500.0)
    a.solve_static(5)
    assert a.counters["factorizations"] == factored
    a.step()  # the dynamic matrix has them
    assert a.counters["factorizations"] == factored + 1


def test_floor_far_below_changes_nothing():
    free, floored = scenes.falling_body(), scenes.falling_body()
    free.clear_floor()
    floored.set_floor(-1000.0, 0.5)
    free.step(60)
    floored.step(60)
    for x, y in zip(state(free), state(floored)):
        assert np.array_equal(x, y)


def test_removed_direction_constraints_leave_no_work_behind():
    """The twisted bar with its direction constraints removed steps like a bar that never had them."""
    tb = scenes.TwistedBar()
    for cid in tb.direction_ids:
        tb.sim.remove_constraint(cid)
    plain = scenes.fig1_bar()
    tip = plain.add_position_constraint(scenes.BAR_TIP)
    for f in range(30):
        target = (scenes.BAR_LENGTH - 0.01 * f, 0.0, 0.02 * f)
        tb.sim.set_constraint_target(tb.position_id, target)
        plain.set_constraint_target(tip, target)
        tb.sim.step()
        plain.step()
    for x, y in zip(state(tb.sim), state(plain)):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)


def test_energy_is_traced_only_when_asked():
    sim = scenes.fig1_bar()
    sim.step()
    assert len(sim.energy_trace) == 0
    sim.trace_energy = True
    sim.step()
    assert len(sim.energy_trace) == 2 * sim.params["iterations"] + 1


def test_normals_only_when_asked():
    v, t = meshes.creature()
    graph = opdeform.Graph.from_mesh(v, t, particles=40)
    skin = opdeform.Skin(graph, v, triangles=t, threads=1)
    rng = np.random.default_rng(1)
    pos = graph.centers + rng.normal(scale=0.01, size=graph.centers.shape)
    rot = np.tile(np.eye(3), (graph.n_particles, 1, 1))
    alone = skin.deform(pos, rot)
    normals = np.full((len(v), 3), np.nan)
    both = skin.deform(pos, rot, normals_out=normals)
    assert np.array_equal(alone, both)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)


def test_direction_constraints_never_refactor():
    """Direction terms never enter the global matrix: adding, reweighting, retargeting and removing one
    leaves the factorization alone, and the motion still follows the new weight."""
    sim, twin = pinned_body(), pinned_body()
    for s in (sim, twin):
        s.step()
    point = sim.graph.centers[-1]
    ids = [s.add_direction_constraint(point, (1, 0, 0), (0, 0, 1), weight=1.0) for s in (sim, twin)]
    for s in (sim, twin):
        s.step(3)
    before = sim.counters
    sim.set_constraint_weight(ids[0], 1e6)
    sim.set_constraint_target(ids[0], (0, 1, 0))
    twin.set_constraint_target(ids[1], (0, 1, 0))
    for s in (sim, twin):
        s.step(3)
    sim.remove_constraint(ids[0])
    sim.step(2)
    after = sim.counters
    assert after["factorizations"] == before["factorizations"] == 1
    assert after["analyses"] == before["analyses"] == 1
    assert np.abs(twin.positions - sim.positions).max() > 1e-6  # the new weight acted


def test_parameters_refactor_only_the_matrices_they_enter():
    sim = pinned_body()
    sim.step()
    sim.solve_static(2)
    assert sim.counters["factorizations"] == 2  # one dynamic, one static matrix
    sim.set_params(damping=0.1, iterations=3, gravity=(0, 0, -1))
    sim.step()
    sim.solve_static(2)
    assert sim.counters["factorizations"] == 2
    sim.set_params(dt=1 / 30)  # h enters the dynamic matrix only
    sim.step()
    sim.solve_static(2)
    assert sim.counters["factorizations"] == 3
    sim.set_params(stiffness=4e5)  # k enters both
    sim.step()
    sim.solve_static(2)
    assert sim.counters["factorizations"] == 5
