"""Pickling (issue 17): every object round-trips, and a restored simulation or MPM world continues to the same
bits as the original over 50 steps, constraints removed in the middle (ids with gaps) included."""

import pickle

import numpy as np
import pytest

import opdeform
from opdeform import meshes, mpm

STATE = ("positions", "rotations", "velocities", "angular_velocities")


def copy(obj):
    return pickle.loads(pickle.dumps(obj))


@pytest.fixture(scope="module")
def tail():
    v, t = meshes.bar(length=2.0)
    return v, t, opdeform.Graph.from_mesh(v, t, particles=30)


def assert_same_state(a, b):
    for name in STATE:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def rigged(v, graph):
    """A simulation with pins, a handle, a direction constraint, a floor and a few steps taken."""
    sim = opdeform.Simulation(graph, 1e6, dt=1 / 48, damping=0.01)
    sim.set_floor(-0.4, 0.5)
    pins = opdeform.pin_vertices(sim, v, np.flatnonzero(v[:, 0] < 1e-9))
    direction = opdeform.add_vertex_direction(sim, v, int(np.argmax(v[:, 0])), (0, 0, 1))
    handle = sim.add_position_constraint((2.0, 0.0, 0.0), (1.7, 0.6, 0.0), weight=1e4)
    sim.step(10)
    return sim, pins, direction, handle


def test_graphs_round_trip(tail):
    v, t, graph = tail
    plain = opdeform.Graph(graph.centers, graph.radii, graph.edges, graph.axes)
    for g in (graph, plain):
        back = copy(g)
        for name in ("centers", "radii", "axes", "edges"):
            np.testing.assert_array_equal(getattr(back, name), getattr(g, name))
    assert opdeform.mesh.mesh_pieces(copy(graph))[0] == 1 and opdeform.mesh.mesh_pieces(copy(plain))[0] == 0


def test_simulation_continues_to_the_same_bits_with_id_gaps(tail):
    v, _, graph = tail
    sim, pins, direction, handle = rigged(v, graph)
    for cid in (pins[3], pins[0], pins[7]):  # the last slot moves into each hole: slots differ from ids
        sim.remove_constraint(cid)
    sim.set_constraint_target(direction, (0.3, 0.0, 1.0))
    sim.set_constraint_weight(handle, 2e4)
    sim.step(5)
    back = copy(sim)
    assert_same_state(back, sim)
    assert back.n_constraints == sim.n_constraints
    for k in range(50):
        sim.set_constraint_target(handle, (1.7, 0.6 * np.cos(k / 8), 0.0))
        back.set_constraint_target(handle, (1.7, 0.6 * np.cos(k / 8), 0.0))
        sim.step()
        back.step()
    assert_same_state(back, sim)
    assert np.abs(sim.velocities).max() > 0.01  # it moved
    assert back.add_position_constraint((1.0, 0, 0)) == sim.add_position_constraint((1.0, 0, 0))


def test_simulation_with_goals_and_solver_settings(tail):
    v, _, graph = tail
    sim = opdeform.Simulation(graph, 1e6, dt=1 / 24, gravity=(0, 0, 0))
    sim.set_solver("anderson", window=3, tolerance=3e-5, max_iterations=37)
    fit = opdeform.GoalFit(graph, v)
    sim.set_goal_strength(0.5)
    swing = [v @ np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]).T
             for a in np.linspace(0, 1, 60)]
    for frame in swing[:10]:
        sim.set_goals(*fit.fit(frame))
        sim.step()
    back, fit_back = copy(sim), copy(fit)
    assert (back.solver, back.tolerance, back.max_iterations) == (sim.solver, 3e-5, 37)
    for frame in swing[10:]:
        sim.set_goals(*fit.fit(frame))
        back.set_goals(*fit_back.fit(frame))
        sim.step()
        back.step()
    assert_same_state(back, sim)


def test_simulation_with_a_stiffness_per_particle(tail):
    v, _, graph = tail
    k = 1e6 * np.random.default_rng(3).uniform(0.5, 2.0, graph.n_particles)
    sim = opdeform.Simulation(graph, k, dt=1 / 48)
    opdeform.pin_vertices(sim, v, np.flatnonzero(v[:, 0] < 1e-9))
    sim.step(10)
    back = copy(sim)
    np.testing.assert_array_equal(back.stiffness_scale, sim.stiffness_scale)
    assert back.params == sim.params
    sim.step(20)
    back.step(20)
    assert_same_state(back, sim)


def test_a_removed_set_and_static_solve(tail):
    v, _, graph = tail
    sim, pins, direction, handle = rigged(v, graph)
    for cid in pins + [direction, handle]:
        sim.remove_constraint(cid)
    pin = sim.add_position_constraint((0.0, 0.0, 0.0))
    back = copy(sim)
    assert back.add_direction_constraint((1, 0, 0), (0, 0, 1)) == sim.add_direction_constraint((1, 0, 0), (0, 0, 1))
    assert pin == len(pins) + 2
    sim.solve_static(50)
    back.solve_static(50)
    assert_same_state(back, sim)


def test_simulation_with_colliders_fields_and_self_contact(tail):
    """The scene travels with a simulation: colliders (a removed one leaving an id gap, a mesh deformed, one
    moving when pickled, with its target pending), force fields (one moved, one removed) and self-contact."""
    v, t, graph = tail
    sim = opdeform.Simulation(graph, 1e6, dt=1 / 48, damping=0.01)
    opdeform.pin_vertices(sim, v, np.flatnonzero(v[:, 0] < 1e-9))
    gone = sim.add_collider("sphere", radius=0.2, translation=(5.0, 0.0, 0.0))
    ball = sim.add_collider("sphere", radius=0.25, translation=(1.5, 0.0, -0.6), friction=0.3)
    cube_v, cube_t = meshes.bar(length=0.6, width=0.3)
    slab = sim.add_collider("mesh", vertices=cube_v, triangles=cube_t, translation=(1.0, 0.0, -0.9),
                            resolution=24)
    sim.remove_collider(gone)
    sim.update_collider_vertices(slab, cube_v * (1.2, 1.0, 1.0))
    sim.set_collider_contact(ball, friction=0.8, thickness=0.01)
    wind = sim.add_force_field("wind", strength=4.0, direction=(0, 1, 0), turbulence=0.5, size=0.4)
    sim.remove_force_field(sim.add_force_field("vortex", strength=2.0))
    sim.add_force_field("force", strength=-3.0, position=(2.0, 0.0, 0.0), falloff=1.0)
    sim.move_force_field(wind, (0.0, 0.0, 0.0), (0.0, 1.0, 0.2))
    sim.set_self_contact(thickness=0.002, friction=0.2)
    sim.step(10)
    sim.move_collider(ball, (1.6, 0.1, -0.5))  # pending: the next step call takes it there
    back = copy(sim)
    assert (back.n_colliders, back.n_force_fields, back.self_contact) == (2, 2, sim.self_contact)
    for k in range(40):
        for s in (sim, back):
            s.step()
            s.move_collider(ball, (1.6 - 0.01 * k, 0.1, -0.5 + 0.005 * k))
    assert_same_state(back, sim)
    np.testing.assert_array_equal(back.collider_distances(v), sim.collider_distances(v))
    assert back.add_collider("box") == sim.add_collider("box") == 3
    assert np.abs(sim.velocities).max() > 0.01


def test_skin_and_goal_fit_round_trip(tail):
    v, t, graph = tail
    sim, *_ = rigged(v, graph)
    skin = opdeform.Skin(graph, v, triangles=t)
    back = copy(skin)
    normals = [np.empty((len(v), 3)) for _ in range(2)]
    np.testing.assert_array_equal(back.deform(sim.positions, sim.rotations, normals_out=normals[0]),
                                  skin.deform(sim.positions, sim.rotations, normals_out=normals[1]))
    np.testing.assert_array_equal(*normals)
    fit = opdeform.GoalFit(graph, v, neighbors=8)
    np.testing.assert_array_equal(copy(fit).fit(v + 0.1)[1], fit.fit(v + 0.1)[1])


def test_mpm_world_continues_to_the_same_bits():
    world = mpm.World((0, 0, 0), (1, 1, 1), 0.05, threads=1)
    world.add_particles(mpm.fill_box((0.3, 0.3, 0.3), (0.6, 0.6, 0.6), 0.025), orientations=mpm.random_orientations(1728))
    world.add_particles(mpm.fill_box((0.3, 0.3, 0.65), (0.5, 0.5, 0.75), 0.025), mpm.jelly(), velocities=None)
    ball = world.add_collider("sphere", radius=0.08, translation=(0.45, 0.45, 0.15))
    world.set_wind("noise", amplitude=2.0)
    for k in range(5):
        world.move_collider(ball, (0.45, 0.45, 0.15 + 0.01 * k))
        world.step(1 / 240)
    back = copy(world)
    for k in range(50):
        for w in (world, back):
            w.move_collider(ball, (0.45 + 0.002 * k, 0.45, 0.2))
            w.step(1 / 240)
    for name in ("positions", "velocities", "orientations", "deformation", "affine", "plastic_j"):
        np.testing.assert_array_equal(back.read(name), world.read(name), err_msg=name)
    assert back.stats == world.stats and world.stats["substeps"] > 50


def test_mpm_state_from_another_world_is_refused():
    a = mpm.World((0, 0, 0), (1, 1, 1), 0.1)
    a.add_particles([[0.5, 0.5, 0.5]])
    b = mpm.World((0, 0, 0), (1, 1, 1), 0.1)
    b.add_floor(0.2)
    with pytest.raises(ValueError, match="colliders"):
        b._core.load_state(a._core.save_state())
    with pytest.raises(ValueError, match="not an MPM state"):
        a._core.load_state(b"nonsense")
    with pytest.raises(ValueError, match="bytes"):
        a._core.load_state(a._core.save_state()[:-8])
