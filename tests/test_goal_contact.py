"""Contact with goals carrying the rest (docs/goals.md, "Contact with goals"): the floor and the scene colliders
act on the deviation from the animation, not on the animation itself. A particle is pushed only by what its
ellipsoid is deeper than at its goal frame, so a bar lying on the floor whose particles' ellipsoids reach 3 cm
below its skin stays on its strength-1 goals; a free tip that the animation's stop swings below the floor is
stopped at the surface (or at its goal's depth); with the goals not carrying the rest contact is what it was,
and a simulation whose goals carried the rest and no longer do gives the same bits as one that never had it."""
import numpy as np
import pytest

import opdeform
from opdeform import meshes

LENGTH = 2.0
FPS = 60
THICKNESS = 0.005  # the colliders' default
SURFACE = {"floor": 0.0, "plane": THICKNESS, "box": THICKNESS}  # where a particle's lowest point stops


@pytest.fixture(scope="module")
def bar():
    v, t = meshes.bar(length=LENGTH, width=0.2, segments=20, cross=2)  # x in [0, 2], skin 0.1 m about the axis
    g = opdeform.Graph.from_mesh(v, t, particles=40)
    return v, g, opdeform.GoalFit(g, v)


def add_contact(sim, kind, friction=0.5):
    """The surface z = 0 as the floor, a plane collider or the top of a box collider."""
    if kind == "floor":
        sim.set_floor(0.0, friction)
    elif kind == "plane":
        sim.add_collider("plane", friction=friction)
    else:
        sim.add_collider("box", half_extents=(5.0, 5.0, 0.5), translation=(1.0, 0.0, -0.5), friction=friction)


def lowest(g, x, rot):
    """Each particle's lowest point: its centre less its ellipsoid's reach down, sqrt(Σ (r_a (R Ē)_za)²)."""
    frames = rot @ g.axes
    return x[:, 2] - np.sqrt(np.sum((g.radii * frames[:, 2, :]) ** 2, axis=1))


def turn(axis, angle):
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(3)
    m[i, i] = m[j, j] = c
    m[i, j], m[j, i] = -s, s
    return m


def simulation(g, hz, carry=True, stiffness=1e6, gravity=(0.0, 0.0, -9.81)):
    sim = opdeform.Simulation(g, stiffness, dt=1 / FPS, gravity=gravity)
    sim.set_goal_frequencies(hz)
    sim.set_goals_carry_rest(carry)
    return sim


def lying(v, f):
    """The bar lying on z = 0 (its skin's bottom on the surface), sliding along x at 0.5 m/s and turning about z."""
    return v @ turn(2, 0.3 * np.sin(f / 20)).T + [0.5 * f / FPS, 0.0, 0.1]


def on_lying_goals(bar, kind, carry, frames=60):
    """Strength 1 everywhere, gravity, friction: the largest distance from the goals over the frames."""
    v, g, fit = bar
    sim = simulation(g, np.full(g.n_particles, 1000.0), carry)
    start = fit.fit(lying(v, 0))
    sim.set_state(*start)
    add_contact(sim, kind)
    worst = 0.0
    for f in range(frames):
        goals = fit.fit(lying(v, f))
        sim.set_goals(*goals)
        sim.step()
        worst = max(worst, np.abs(sim.positions - goals[0]).max())
    return worst, lowest(g, *goals)


@pytest.mark.parametrize("kind", ["floor", "plane", "box"])
def test_full_strength_stays_on_goals_that_overlap_the_surface(bar, kind):
    worst, goal_lowest = on_lying_goals(bar, kind, carry=True)
    assert goal_lowest.min() < SURFACE[kind] - 0.025  # the goals' ellipsoids reach 3.07 cm below the skin
    assert worst < 1e-5 * LENGTH  # measured 2.8e-6 m, as with no contact; before: 3.1 cm (floor)


@pytest.mark.parametrize("kind", ["floor", "plane", "box"])
def test_world_space_goals_are_still_pushed_out(bar, kind):
    """Goals not carrying the rest: contact acts on the animated pose as it did, lifting the overlapping
    particles off their goals."""
    worst, _ = on_lying_goals(bar, kind, carry=False, frames=10)
    assert worst > 0.02  # measured 3.1 cm (floor)


SPEED, TILT, STOP = 1.5, 0.03, 30  # m/s down, radians up toward the tip, frame where the goals stop


def falling(v, f):
    """The bar tilted up toward its tip, going down at SPEED until frame STOP, where its root's skin is on
    z = 0 (its particles 2.5 cm in) and its tip's 2.4 cm above."""
    return v @ turn(1, -TILT).T + [0.0, 0.0, 0.1 + max(0.0, SPEED * (STOP - f) / FPS)]


def swing_down(bar, kind):
    """The root half at strength 1, the free half at 0, no gravity: the animation's stop swings the free half
    down. Per frame after the start: each particle's lowest point, and its goal's."""
    v, g, fit = bar
    root = g.centers[:, 0] < LENGTH / 2
    sim = simulation(g, np.where(root, 1000.0, 0.0), stiffness=1e5, gravity=(0.0, 0.0, 0.0))
    start = fit.fit(falling(v, -1))
    sim.set_state(*start, velocities=np.tile([0.0, 0.0, -SPEED], (g.n_particles, 1)))
    sim.set_goals(*start)
    if kind:
        add_contact(sim, kind)
    lows, goal_lows, off_goal = [], [], 0.0
    for f in range(STOP + 60):
        goals = fit.fit(falling(v, f))
        sim.set_goals(*goals)
        sim.step()
        lows.append(lowest(g, sim.positions, sim.rotations))
        goal_lows.append(lowest(g, *goals))
        off_goal = max(off_goal, np.abs(sim.positions - goals[0])[root].max())
    return np.array(lows), np.array(goal_lows), off_goal


@pytest.mark.parametrize("kind", ["floor", "plane", "box"])
def test_a_free_tip_swung_below_the_surface_stops_at_it(bar, kind):
    free_lows, goal_lows, _ = swing_down(bar, None)
    tip = bar[1].centers[:, 0] > 1.5
    assert (free_lows - goal_lows)[STOP:, tip].min() < -1.0  # without contact: 1.23 m below its goals
    lows, goal_lows, root_off = swing_down(bar, kind)
    stop = np.minimum(goal_lows, SURFACE[kind])  # the surface, or the goal's own depth where that is lower
    assert (lows - stop).min() > -1e-9  # measured -5.6e-17 (floor)
    assert lows[:, tip].min() < SURFACE[kind] + 1e-6  # the tip reached the surface
    assert goal_lows.min() < SURFACE[kind] - 0.02  # while the root's goals are 2.5 cm in
    assert root_off < 1e-5 * LENGTH  # and the root stays on them: measured 2.5e-6 m


@pytest.mark.parametrize("kind", ["floor", "plane", "box"])
def test_off_after_on_is_the_same_bits_as_never_set(bar, kind):
    v, g, fit = bar
    hz = np.linspace(0.0, 3.0, g.n_particles)
    never = simulation(g, hz, carry=False)
    toggled = simulation(g, hz, carry=True)
    for sim in (never, toggled):
        sim.set_state(*fit.fit(lying(v, 0)))
        add_contact(sim, kind)
    for f in range(10):
        toggled.set_goals(*fit.fit(lying(v, f)))
        toggled.step()
    toggled.set_goals_carry_rest(False)
    toggled.set_state(never.positions, never.rotations)
    for sim in (never, toggled):
        for f in range(30):
            sim.set_goals(*fit.fit(lying(v, f) - [0.0, 0.0, 0.04]))  # the goals 4 cm lower: into the surface
            sim.step()
    for name in ("positions", "rotations", "velocities", "angular_velocities"):
        np.testing.assert_array_equal(getattr(toggled, name), getattr(never, name), err_msg=name)
