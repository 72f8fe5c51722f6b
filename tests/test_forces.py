"""Force fields (docs/forces.md, issue 13): wind pushes a body in its direction in proportion to its strength,
drag limits the speed to strength / drag, a vortex turns a body about its axis, the same wind pushes MPM
flakes, and a field with a NaN or out-of-range value raises ValueError naming it with nothing added."""

import numpy as np
import pytest

import opdeform
from opdeform import meshes, mpm


@pytest.fixture(scope="module")
def graph():
    v, t = meshes.capsule(radius=0.2, length=0.2)
    return opdeform.Graph.from_mesh(v, t, particles=60)


def _free(graph, **kw):
    return opdeform.Simulation(graph, 1e5, dt=1 / 60, gravity=(0.0, 0.0, 0.0), **kw)


def _pushed(graph, strength, steps=30, **field):
    sim = _free(graph)
    sim.add_force_field("wind", strength=strength, direction=(1.0, 1.0, 0.0), **field)
    start = sim.positions.mean(axis=0)
    sim.step(steps)
    return sim.positions.mean(axis=0) - start, sim


def test_wind_pushes_the_body_in_its_direction_scaling_with_strength(graph):
    weak, _ = _pushed(graph, 1.0)
    strong, _ = _pushed(graph, 2.0)
    along = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    t = 0.5
    assert weak @ along == pytest.approx(0.5 * t ** 2, rel=0.05)  # implicit Euler: a t^2 / 2 (1 + 1/30)
    assert np.linalg.norm(weak - (weak @ along) * along) < 1e-9   # in the wind's direction only
    assert strong @ along == pytest.approx(2.0 * (weak @ along), rel=1e-9)


def test_turbulent_wind_varies_but_keeps_its_mean_direction(graph):
    moved, sim = _pushed(graph, 2.0, turbulence=1.0, size=0.2)
    assert moved @ np.array([1.0, 1.0, 0.0]) > 0.0
    spread = np.linalg.norm(sim.velocities - sim.velocities.mean(axis=0), axis=1).max()
    assert spread > 1e-3  # the noise differs across the body


def test_drag_limits_the_speed_to_strength_over_drag(graph):
    _, sim = _pushed(graph, 3.0, steps=300, drag=2.0)
    speed = np.linalg.norm(sim.velocities.mean(axis=0))
    assert speed == pytest.approx(3.0 / 2.0, rel=0.01)


def test_a_vortex_turns_the_body_about_its_axis(graph):
    sim = _free(graph)
    offset = np.array([0.5, 0.0, 0.0])
    sim.set_state(graph.centers + offset, sim.rotations)
    sim.add_force_field("vortex", strength=2.0, direction=(0.0, 0.0, 1.0))
    sim.step(20)
    v = sim.velocities.mean(axis=0)
    assert v[1] > 0.5 and abs(v[0]) < 0.3 * v[1]  # counter-clockwise about +z at +x: along +y


def test_a_force_field_repels_and_attracts_with_falloff(graph):
    def moved(strength, **kw):
        sim = _free(graph)
        sim.add_force_field("force", strength=strength, position=(-1.0, 0.0, 0.0), **kw)
        x0 = sim.positions.mean(axis=0)
        sim.step(10)
        return (sim.positions.mean(axis=0) - x0)[0]

    assert moved(1.0) > 0.0 > moved(-1.0)
    assert 0.0 < moved(1.0, falloff=2.0) < 0.5 * moved(1.0)     # (1 + r)^-2 at r = 1: a quarter
    assert abs(moved(1.0, max_distance=0.5)) < 1e-12           # beyond its reach


def test_fields_move_and_remove(graph):
    sim = _free(graph)
    fid = sim.add_force_field("wind", strength=1.0, direction=(1, 0, 0))
    sim.move_force_field(fid, (0, 0, 0), direction=(0, 1, 0))
    sim.step(5)
    v = sim.velocities.mean(axis=0)
    assert v[1] > 0.0 and abs(v[0]) < 1e-12
    sim.remove_force_field(fid)
    assert sim.n_force_fields == 0
    with pytest.raises(IndexError):
        sim.remove_force_field(fid)


@pytest.mark.parametrize("bad, name", [({"strength": float("nan")}, "strength"), ({"size": 0.0}, "size"),
                                       ({"drag": -1.0}, "drag"), ({"direction": (0, 0, 0)}, "direction"),
                                       ({"kind": "gust"}, "kind"), ({"falloff": float("inf")}, "falloff"),
                                       ({"min_distance": 2.0, "max_distance": 1.0}, "max_distance")])
def test_bad_fields_raise_naming_the_value_and_change_nothing(graph, bad, name):
    for owner in (_free(graph), mpm.World((0, 0, 0), (1, 1, 1), 1 / 16)):
        with pytest.raises(ValueError, match=name):
            owner.add_force_field(**{"kind": "wind", **bad})
        assert owner.n_force_fields == 0


def test_without_fields_a_step_is_unchanged_to_the_bit(graph):
    a, b = _free(graph), _free(graph)
    b.remove_force_field(b.add_force_field("wind", strength=5.0))
    a.step(10)
    b.step(10)
    assert np.array_equal(a.positions, b.positions)


def _flakes(strength):
    world = mpm.World((0, 0, 0), (2, 2, 1), 1 / 32, gravity=(0, 0, 0), max_dt=2e-3)
    pts = mpm.flake_layer((1.0, 1.0, 0.5), (0.8, 0.8), 0.2, 30, seed=2)
    world.add_particles(pts, mpm.flakes(), particle_volume=2e-6)
    if strength:
        world.add_force_field("wind", strength=strength, direction=(1.0, 0.0, 0.0), drag=1.0)
    for _ in range(6):
        world.step(1 / 30)
    return world.positions.mean(axis=0) - pts.mean(axis=0)


def test_mpm_flakes_are_pushed_by_a_wind_field():
    still, pushed = _flakes(0.0), _flakes(2.0)
    assert np.abs(still).max() < 1e-9
    t = 0.2
    assert pushed[0] == pytest.approx(2.0 * (t - (1 - np.exp(-t))), rel=0.1)  # v = 2 (1 - e^-t) under drag 1
    assert abs(pushed[1]) < 0.1 * pushed[0]
