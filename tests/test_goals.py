"""Goals: secondary motion on an animated shape. A 2 m tail swung 60 degrees about its root in 0.5 s, then
held (the swinging-armature shot): full strength is the animation, partial strength lags, overshoots and
settles back with no drift, zero strength is free dynamics, and new goals never refactor."""
import numpy as np
import pytest

import opdeform
from opdeform import meshes

FPS = 24
SWING = np.radians(60.0)


@pytest.fixture(scope="module")
def tail():
    v, t = meshes.bar(length=2.0, width=0.2, segments=20, cross=2)
    g = opdeform.Graph.from_mesh(v, t, particles=40)
    return v, g, opdeform.GoalFit(g, v), opdeform.Skin(g, v)


def swung(v, seconds, scale=1.0):
    a = SWING * min(seconds / 0.5, 1.0)
    c, s = np.cos(a), np.sin(a)
    return scale * v @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T


def play(tail, strength, frames=4 * FPS, scale=1.0, density=1000.0, stiffness=1e6):
    """Per frame: the largest distance of the output from the animation, and the tip's signed angle ahead
    of the animated tip (radians); and the simulation."""
    v, g, fit, skin = tail
    if scale != 1.0:
        g = opdeform.Graph(g.centers * scale, g.radii * scale, g.edges, g.axes)
        fit, skin = opdeform.GoalFit(g, v * scale), opdeform.Skin(g, v * scale)
    sim = opdeform.Simulation(g, stiffness, density=density, dt=1 / FPS, gravity=(0, 0, 0))
    sim.set_goal_strength(strength)
    tip = np.argmax(v[:, 0])
    deviation, ahead = [], []
    for f in range(1, frames + 1):
        animated = swung(v, f / FPS, scale)
        goals = fit.fit(animated)
        sim.set_goals(*goals)
        sim.step()
        out = opdeform.relative_deform(skin, animated, sim, goals)
        deviation.append(np.linalg.norm(out - animated, axis=1).max())
        ahead.append(np.arctan2(out[tip, 1], out[tip, 0]) - np.arctan2(animated[tip, 1], animated[tip, 0]))
    return np.array(deviation), np.array(ahead), sim


def test_full_strength_is_the_animation(tail):
    deviation, _, sim = play(tail, 1.0)
    assert deviation.max() < 1e-3 * 2.0  # 1e-3 of the tail's length, on every frame
    assert sim.counters["factorizations"] == 1  # 96 new goals, one factorization


def test_partial_strength_lags_overshoots_and_settles(tail):
    deviation, ahead, _ = play(tail, 0.5, frames=6 * FPS)
    assert ahead[:4].max() < -np.radians(3)  # behind as the swing starts
    after = ahead[int(0.5 * FPS):]
    assert after.max() > np.radians(1) and after.min() < -np.radians(0.5)  # swings past the animation and back
    assert deviation[-FPS:].max() < 1e-4 * 2.0  # settled onto the animation, no drift over the last second


def test_weaker_is_softer(tail):
    lags = [play(tail, s, frames=FPS)[0].max() for s in (0.2, 0.5, 0.8, 1.0)]
    assert all(a > 2 * b for a, b in zip(lags, lags[1:]))


def test_zero_strength_is_free_dynamics(tail):
    _, _, with_goals = play(tail, 0.0, frames=10)
    v, g, _, _ = tail
    free = opdeform.Simulation(g, 1e6, dt=1 / FPS, gravity=(0, 0, 0))
    free.step(10)
    np.testing.assert_array_equal(with_goals.positions, free.positions)
    np.testing.assert_array_equal(with_goals.rotations, free.rotations)


@pytest.mark.parametrize("scale, density", [(0.1, 1000.0), (10.0, 1000.0), (1.0, 50.0)])
def test_strength_means_the_same_at_any_size_and_mass(tail, scale, density):
    """The goal is a frequency: with the body's own frequencies kept (k in proportion to the density; the
    elastic and inertial energies both grow as size⁵), the lag relative to size is the same."""
    reference, _, _ = play(tail, 0.5, frames=FPS)
    k = 1e6 * density / 1000.0
    scaled, _, _ = play(tail, 0.5, frames=FPS, scale=scale, density=density, stiffness=k)
    np.testing.assert_allclose(scaled / scale, reference, rtol=1e-6, atol=1e-9)


def test_goals_and_pins_compose(tail):
    """A tail hanging from an animated body: the body half follows its goals, the tail half is free under
    gravity and stays attached (no edge of the graph stretched past 1.5x)."""
    v, g, fit, skin = tail
    sim = opdeform.Simulation(g, 1e6, dt=1 / FPS)
    body = g.centers[:, 0] < 1.0
    sim.set_goal_strength(np.where(body, 1.0, 0.0))
    rest = np.linalg.norm(g.centers[g.edges[:, 0]] - g.centers[g.edges[:, 1]], axis=1)
    for f in range(1, 2 * FPS):
        sim.set_goals(*fit.fit(swung(v, f / FPS)))
        sim.step()
        x = sim.positions
        stretch = np.linalg.norm(x[g.edges[:, 0]] - x[g.edges[:, 1]], axis=1) / rest
        assert stretch.max() < 1.5
    assert sim.positions[~body, 2].min() < -0.05  # the free half hangs


def test_bad_goals_raise_and_change_nothing(tail):
    v, g, fit, _ = tail
    sim = opdeform.Simulation(g, 1e6)
    with pytest.raises(ValueError, match="set the goal frequencies first"):
        sim.set_goals(g.centers)
    sim.set_goal_strength(0.5)
    sim.step(2)
    before = sim.positions, sim.counters["factorizations"]
    bad = g.centers.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match=r"goal positions\[3\]\[1\] is not finite"):
        sim.set_goals(bad)
    with pytest.raises(ValueError, match="goal rotations"):
        sim.set_goals(g.centers, np.zeros((g.n_particles, 3, 3)))
    with pytest.raises(ValueError, match="strength"):
        sim.set_goal_strength(1.5)
    with pytest.raises(ValueError, match="animated"):
        fit.fit(v[:-1])
    sim.step(1)
    twin = opdeform.Simulation(g, 1e6)
    twin.set_goal_strength(0.5)
    twin.step(3)
    np.testing.assert_array_equal(sim.positions, twin.positions)
    assert sim.counters["factorizations"] == before[1]


def test_energy_decreases_with_goals(tail):
    v, g, fit, _ = tail
    sim = opdeform.Simulation(g, 1e6, dt=1 / FPS)
    sim.set_goal_strength(np.linspace(0, 1, g.n_particles))
    sim.set_goals(*fit.fit(swung(v, 0.3)))
    sim.trace_energy = True
    sim.step()
    e = sim.energy_trace
    assert len(e) > 3 and np.all(np.diff(e) <= 1e-12 * abs(e[0]))


def test_painted_weights_become_particle_strengths(tail):
    v, g, fit, _ = tail
    np.testing.assert_allclose(fit.particle_values(np.full(len(v), 0.3)), 0.3, rtol=1e-12)
    ramp = fit.particle_values(v[:, 0] / 2.0)  # a weight painted along the tail
    assert np.all(np.abs(ramp - g.centers[:, 0] / 2.0) < 0.1)
    assert fit.indices.shape == (g.n_particles, fit.neighbors) and np.allclose(fit.weights.sum(axis=1), 1.0)


def test_a_float32_input_with_a_shift_fits_as_its_float64_copy_plus_the_shift(tail):
    """``GoalFit.fit(animated, shift)`` (Blender's float32 object-space input and an unturned object's
    translation) gives the bits of fitting the float64 copy plus the shift, added only where the shift is nonzero
    (the add-on's ``to_world``: adding zeros would turn -0.0 into 0.0); a vertex it reads not finite is named."""
    v, g, fit, _ = tail
    animated = swung(v, 0.3).astype(np.float32)
    animated[0] = -0.0
    for shift in ((0.0, 0.0, 0.0), (1.5, -0.25, 0.0), (-0.0, 0.0, 3.0)):
        world = animated.astype(np.float64)
        if any(shift):
            world += shift
        for got, want in zip(fit.fit(animated, shift), fit.fit(world)):
            assert got.tobytes() == want.tobytes(), shift
    with pytest.raises(ValueError, match="animated"):  # float64 where a shift says float32
        fit.fit(animated.astype(np.float64), (0.0, 0.0, 0.0))
    order = fit.indices.reshape(-1)
    animated[order[-1]] = np.nan
    with pytest.raises(ValueError, match=rf"animated vertices\[{order[-1]}\] is not finite"):
        fit.fit(animated, (1.0, 0.0, 0.0))


def test_follow_fits_a_new_input_once_and_names_any_vertex_not_finite(tail):
    """``GoalFit.follow`` (the add-on's frame in one C call): a new input gives ``fit(animated, shift)``'s bits
    in new arrays and is kept with its shift; the same values again (-0.0 for 0.0 too) give None and write
    nothing; another shift fits again; any vertex not finite, read by the fit or not, is named and keeps the kept
    input."""
    v, g, fit, _ = tail
    animated = swung(v, 0.3).astype(np.float32)
    animated[0] = 0.0
    kept, kept_shift = np.full_like(animated, 7.0), np.zeros(3)
    first = fit.follow(animated, (1.5, -0.25, 0.0), kept, kept_shift, False)
    for got, want in zip(first, fit.fit(animated, (1.5, -0.25, 0.0))):
        assert got.tobytes() == want.tobytes()
    assert kept.tobytes() == animated.tobytes() and list(kept_shift) == [1.5, -0.25, 0.0]
    animated[0] = -0.0
    assert fit.follow(animated, (1.5, -0.25, 0.0), kept, kept_shift, True) is None
    assert kept[0].tobytes() == np.zeros(3, np.float32).tobytes()  # nothing written: still +0.0
    assert fit.follow(animated, (1.5, -0.25, 0.0), kept, kept_shift, False) is not None  # not valid: fitted
    second = fit.follow(animated, (1.5, 0.0, 0.0), kept, kept_shift, True)
    assert second is not None and second[0] is not first[0] and kept_shift[1] == 0.0
    unread = np.setdiff1d(np.arange(len(v)), fit.indices.reshape(-1))
    bad = int(unread[0]) if len(unread) else len(v) - 1
    animated[bad, 2] = np.inf
    with pytest.raises(ValueError, match=rf"animated vertices\[{bad}\] is not finite"):
        fit.follow(animated, (0.0, 0.0, 0.0), kept, kept_shift, True)
    assert kept_shift[1] == 0.0 and np.isfinite(kept).all()
    with pytest.raises(ValueError, match="kept"):  # float64 where the kept input is float32
        fit.follow(animated, (0.0, 0.0, 0.0), kept.astype(np.float64), kept_shift, True)
    animated[bad, 2] = 0.0
    with pytest.raises(ValueError, match="share memory"):  # would compare the input with itself: never fitted
        fit.follow(animated, (0.0, 0.0, 0.0), animated, kept_shift, True)
