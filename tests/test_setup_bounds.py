"""Values a step cannot represent are refused where they are given (issue 28, round three): the argument is
named, and the object is unchanged and still steps. A failed step leaves the counters and the energy as they
were (docs/hardening.md)."""

import os
import signal
import threading

import numpy as np
import pytest

from opdeform import Graph, Simulation, SolverError, meshes, mpm, scenes


def _bar():
    return scenes.fig1_bar()


@pytest.mark.parametrize("kwargs, name", [({"stiffness": 1e300}, "stiffness"), ({"stiffness": 1e21}, "stiffness"),
                                          ({"density": 1e308}, "density"), ({"density": 1e9}, "density"),
                                          ({"dt": 1e-300}, "dt"), ({"dt": 1e-10}, "dt")])
def test_parameters_no_step_can_take_are_refused_at_set_up(kwargs, name):
    graph = _bar().graph
    args = {"stiffness": 1e9, **kwargs}
    with pytest.raises(ValueError, match=name):
        Simulation(graph, **args)
    sim = _bar()
    before = sim.params
    with pytest.raises(ValueError, match=name):
        sim.set_params(**kwargs)
    assert sim.params == before
    sim.step(1)
    assert np.isfinite(sim.energy())


def test_the_bounds_themselves_step():
    graph = _bar().graph
    for kwargs in ({"stiffness": 1e20}, {"density": 1e8}, {"dt": 1e-9}):
        sim = Simulation(graph, **{"stiffness": 1e9, **kwargs})
        sim.add_position_constraint(graph.centers[0])
        sim.step(2)
        assert np.all(np.isfinite(sim.positions)), kwargs


@pytest.mark.parametrize("scale", [1e-200, 1e-13, 1e14, 1e200])
def test_radii_whose_volume_a_step_cannot_represent_are_refused(scale):
    graph = _bar().graph
    radii = graph.radii.copy()
    radii[3] *= scale
    with pytest.raises(ValueError, match=r"radii\[3\]"):
        Graph(graph.centers, radii, graph.edges)


def test_a_constraint_weight_far_above_the_default_is_refused():
    sim = _bar()
    p = sim.graph.centers[0]
    for weight in (1e308, 1e30, 2e12 * sim.default_weight("position")):
        with pytest.raises(ValueError, match="weight"):
            sim.add_position_constraint(p, weight=weight)
    with pytest.raises(ValueError, match="weight"):
        sim.add_direction_constraint(p, (1, 0, 0), weight=1e308)
    n = sim.n_constraints
    cid = sim.add_position_constraint(p, weight=1e12 * sim.default_weight("position"))
    with pytest.raises(ValueError, match="weight"):
        sim.set_constraint_weight(cid, 1e308)
    assert sim.n_constraints == n + 1
    sim.step(2)
    assert np.all(np.isfinite(sim.positions))


def test_a_failed_step_counts_nothing_and_keeps_the_energy():
    sim = _bar()
    sim.step(1)
    energy, steps = sim.energy(), sim.counters["steps"]
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))  # fails the call many steps in
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            sim.step(10 ** 7)
    finally:
        timer.cancel()
    assert sim.counters["steps"] == steps
    assert sim.energy() == energy
    sim.set_state(sim.positions, sim.rotations, velocities=np.full((sim.graph.n_particles, 3), 1e306))
    with pytest.raises(SolverError):
        sim.step(1)
    assert sim.counters["steps"] == steps


def test_complex_arguments_are_refused_not_truncated():
    graph = _bar().graph
    with pytest.raises(ValueError, match="centers"):
        Graph(graph.centers + 1j, graph.radii, graph.edges)
    with pytest.raises(ValueError, match="point"):
        graph.skin_weights(np.array([1 + 1j, 0, 0]))
    with pytest.raises(ValueError, match="point"):
        graph.skin_weights([np.complex128(1 + 1j), 0.0, 0.0])
    sim = _bar()
    with pytest.raises(ValueError, match="points"):
        sim.skin_points(graph.centers[:2] + 1j)
    with pytest.raises(ValueError, match="dt"):
        sim.set_params(dt=np.complex128(0.01 + 1j))
    with pytest.raises(ValueError, match="stiffness"):
        Simulation(graph, np.full(graph.n_particles, 1e9 + 1j))


def test_skinning_a_nan_point_is_refused():
    sim = _bar()
    with pytest.raises(ValueError, match="point"):
        sim.graph.skin_weights((np.nan, 0.0, 0.0))
    with pytest.raises(ValueError, match="point"):
        sim.skin_points([[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]])


def test_moving_an_mpm_collider_far_out_of_the_world_is_refused():
    world = mpm.World((0, 0, 0), (1, 1, 1), 1 / 16)
    world.add_particles(mpm.fill_box((0.4, 0.4, 0.2), (0.6, 0.6, 0.4), 1 / 24), mpm.snow())
    box = world.add_collider("box", "slip", half_extents=(0.1, 0.1, 0.1), translation=(0.5, 0.5, 0.7))
    for far in ((1e300, 0, 0), (0.5, 0.5, -1e5), (np.nan, 0, 0)):
        with pytest.raises(ValueError, match="translation"):
            world.move_collider(box, far)
    with pytest.raises(ValueError, match="translation"):
        world.add_collider("box", "slip", half_extents=(0.1, 0.1, 0.1), translation=(0, 1e300, 0))
    world.step(1 / 60)
    assert np.all(np.isfinite(world.positions))


def test_a_stray_vertex_outside_the_triangles_is_not_welded_in_and_one_inside_is_named():
    vertices, triangles = meshes.bar()
    stray = np.vstack([vertices, [[1e8, 0.0, 0.0]]])
    expected = Graph.from_mesh(vertices, triangles, 50)
    graph = Graph.from_mesh(stray, triangles, 50)  # a vertex of no triangle: was welded into 6 points
    assert np.array_equal(graph.centers, expected.centers)
    with pytest.raises(ValueError, match=r"only \d+ distinct vertices: it spans 1e\+08 m .* welded"):
        Graph.from_mesh(stray, np.vstack([triangles, [[0, 1, len(vertices)]]]), 50)


@pytest.mark.parametrize("scale", [1e300, 1e150, 1e13, 1e-300, 1e-11])
def test_a_mesh_whose_span_no_particle_can_take_is_refused_naming_the_span(scale):
    vertices, triangles = meshes.bar()
    with pytest.raises(ValueError, match=r"^vertices: the mesh spans .* m .*must span \[1e-09, 1e\+12\] m"):
        Graph.from_mesh(vertices * scale, triangles, 50)
