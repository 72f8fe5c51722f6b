"""The skin as the contact shape of the floor and the colliders (docs/contact.md, "Contact on the skin", issue 27):
Blender's 2.7 m Suzanne at 100 particles rests with its skin within 0.5 cm of the floor, a sphere and a ramp
(with the ellipsoids 3-4 cm above) and never dips into them; a drop gains no energy; a box slides down a ramp
as Coulomb says or sticks; with goals carrying the rest it is pushed by its excess only; without a skin the
steps are those of before, bit for bit; a pickle keeps the skin (and carries it again when the goals' rest
changes); bad input raises naming the argument with nothing changed."""

import math
import pathlib
import pickle

import numpy as np
import pytest

import opdeform
from opdeform import materials, meshes, scenes

import test_goal_contact as gc

FIXTURE = pathlib.Path(__file__).parent / "reference" / "suzanne_subdivided.npz"
FPS = 24
RAMP = math.radians(30.0)
RAMP_NORMAL = np.array([-math.sin(RAMP), 0.0, math.cos(RAMP)])


@pytest.fixture(scope="module")
def suzanne():
    data = np.load(FIXTURE)
    return data["vertices"].astype(np.float64), data["triangles"]


def _drop(suzanne, kind, skin_shape, seconds=2.5):
    """Suzanne (the add-on's defaults, 100 particles) dropped 0.3 m onto the floor, a sphere or a ramp: the
    simulation, its skin and the skin's least signed distance per frame (skinned, without the push-out)."""
    rest, tris = suzanne
    normal = {"floor": np.array([0.0, 0.0, 1.0]), "sphere": np.array([0.0, 0.0, 1.0]), "ramp": RAMP_NORMAL}[kind]
    above = {"floor": 0.3, "sphere": 1.3, "ramp": 0.3}[kind]
    start = rest + normal * (above - (rest @ normal).min())
    graph = opdeform.Graph.from_mesh(start, tris, particles=100)
    skin = opdeform.Skin(graph, start)
    steps = materials.substeps_for(FPS)
    sim = materials.make_simulation(graph, dt=1.0 / (FPS * steps))
    if kind == "floor":
        sim.set_floor(0.0, 0.5)
    elif kind == "sphere":
        sim.add_collider("sphere", radius=1.0)
    else:
        sim.add_collider("plane", normal=tuple(RAMP_NORMAL), friction=0.5)
    if skin_shape:
        sim.set_contact_skin(skin)
    gaps = []
    for _ in range(int(seconds * FPS)):
        sim.step(steps)
        shown = skin.deform_sim(sim, push_out=False)
        gaps.append((shown[:, 2] if kind == "floor" else sim.collider_distances(shown)).min())
    return sim, skin, np.array(gaps)


@pytest.mark.parametrize("kind", ["floor", "sphere", "ramp"])
def test_suzanne_rests_with_its_skin_within_half_a_centimetre(suzanne, kind):
    """The skin's closest approach over 2.5 s (skinned, without the push-out): the floor keeps no gap, a
    collider its thickness (5 mm); with the ellipsoids 3.4-3.9 cm (scripts/skin_contact.py). On the floor it
    stays there (on the sphere it rolls off after 3 s, on the ramp, mu = 0.5 < tan 30 degrees, it slides)."""
    sim, skin, gaps = _drop(suzanne, kind, True, seconds=3.0 if kind == "floor" else 2.5)
    assert -1e-6 < gaps.min() < 0.0051  # never inside, even without the push-out
    if kind == "floor":
        assert np.abs(gaps[-FPS // 2:]).max() < 0.005
    assert sim.n_contact_points == 4 * skin.n_vertices
    _, _, ellipsoids = _drop(suzanne, kind, False)
    assert ellipsoids.min() > 0.02  # the ellipsoids' overhang, what the skin removes


def test_a_drop_on_the_skin_gains_no_energy(suzanne):
    """Gravity's and the motion's energy of the centres never rises above the drop's start."""
    sim, _, _ = _drop(suzanne, "floor", True, seconds=0.0)
    mass = sim.graph.volumes * sim.params["density"]
    energy = []
    for _ in range(2 * FPS * materials.substeps_for(FPS)):
        sim.step()
        v, z = sim.velocities, sim.positions[:, 2]
        energy.append(float((mass * (0.5 * (v ** 2).sum(axis=1) + 9.81 * z)).sum()))
    start = float((mass * 9.81 * sim.graph.centers[:, 2]).sum())
    assert max(energy) < start and energy[-1] < start - 0.5 * (start - min(energy))


@pytest.fixture(scope="module")
def blob():
    v, t = meshes.capsule(radius=0.2, length=0.2)  # 0.6 x 0.4 x 0.4 m
    return v, t, opdeform.Graph.from_mesh(v, t, particles=100)


def _cube_on_a_ramp(mu, seconds=2.0, fps=240):
    """The 0.3 m Rubber cube on its skin on a 30-degree plane (scenes.RampCube): (distance travelled, degrees
    turned), as tests/test_contact.py's cube on its ellipsoids."""
    scene = scenes.RampCube(mu, fps, skin=True)
    scene.sim.step(int(seconds * fps))
    return scene.moved()


def test_a_box_on_its_skin_slides_down_a_ramp_as_coulomb_says_and_sticks_above_tan_theta():
    """mu = 0.3: g (sin - mu cos) with the preset's damping (3.90 m in 2 s); mu = 1 (> tan 30 degrees) holds."""
    a, c = 9.81 * (0.5 - 0.3 * math.cos(RAMP)), materials.PRESETS["Rubber"].damping
    slid, turned = _cube_on_a_ramp(0.3)
    assert slid == pytest.approx(a / c * (2.0 - (1.0 - math.exp(-2.0 * c)) / c), rel=0.03) and turned < 3.0
    held, turned = _cube_on_a_ramp(1.0)
    assert held < 0.03 and turned < 3.0


def _scene(blob, skin=False):
    v, t, g = blob
    sim = opdeform.Simulation(g, 3e4, dt=1 / 60)
    sim.set_state(g.centers + (0.0, 0.0, 1.35), np.tile(np.eye(3), (g.n_particles, 1, 1)))
    sim.add_collider("sphere", radius=1.0)
    sim.set_floor(0.0, 0.5)
    if skin:
        sim.set_contact_skin(opdeform.Skin(g, v))
    return sim


def test_without_a_skin_the_steps_are_those_of_before(blob):
    plain, cleared, skinned = _scene(blob), _scene(blob, True), _scene(blob, True)
    cleared.set_contact_skin(None)
    assert cleared.n_contact_points == 0 and skinned.n_contact_points > 0
    for sim in (plain, cleared, skinned):
        sim.step(60)
    assert np.array_equal(plain.positions, cleared.positions)
    assert np.array_equal(plain.rotations, cleared.rotations)
    assert not np.allclose(plain.positions, skinned.positions, atol=1e-3)  # the skin is what touches


def test_a_pickle_keeps_the_skin(blob):
    sim = _scene(blob, True)
    sim.step(20)
    copy = pickle.loads(pickle.dumps(sim))
    assert copy.n_contact_points == sim.n_contact_points
    sim.step(20)
    copy.step(20)
    assert np.array_equal(sim.positions, copy.positions)


def test_a_pickle_carries_the_skin_again_when_the_goals_rest_changes(blob):
    """With goals carrying the rest a particle carries only its vertices of weight >= CONTACT_WEIGHT; a restored
    copy turned off and on again carries what a simulation never pickled does, to the bit."""
    fresh, restored = _scene(blob), _scene(blob)
    for sim in (fresh, restored):
        sim.set_goal_strength(0.5)
        sim.set_goals_carry_rest(True)
        sim.set_contact_skin(opdeform.Skin(sim.graph, blob[0]))
    restored = pickle.loads(pickle.dumps(restored))
    carried = fresh.n_contact_points
    for carry in (False, True, False):
        for sim in (fresh, restored):
            sim.set_goals_carry_rest(carry)
        assert restored.n_contact_points == fresh.n_contact_points
    assert fresh.n_contact_points > carried
    for sim in (fresh, restored):
        sim.step(20)
    assert np.array_equal(fresh.positions, restored.positions)


def test_bad_skin_input_raises_and_changes_nothing(blob):
    v, t, g = blob
    sim = _scene(blob, True)
    count = sim.n_contact_points
    other = opdeform.Graph.from_mesh(v, t, particles=20)
    cases = [((v, np.full(len(v), g.n_particles)), "particles\\[0\\] = 100 is out of range"),
             ((np.where(np.arange(len(v))[:, None] == 3, np.nan, v), np.zeros(len(v))), "points"),
             ((v, np.zeros(len(v) - 1)), "particles")]
    for args, match in cases:
        with pytest.raises(ValueError, match=match):
            sim.set_contact_points(*args)
        assert sim.n_contact_points == count
    with pytest.raises(ValueError, match="skin"):
        sim.set_contact_skin(opdeform.Skin(other, v))
    assert sim.n_contact_points == count


@pytest.mark.parametrize("kind", ["floor", "plane"])
def test_with_goals_carrying_the_rest_the_skin_is_pushed_by_its_excess_only(kind):
    """tests/test_goal_contact.py's bar on its skin: on strength-1 goals lying on the surface it stays on them
    (with the goals not carrying the rest the plane's 5 mm thickness lifts it); its free tip, swung down by
    the animation's stop, stops with its skin at the surface."""
    v, t = meshes.bar(length=gc.LENGTH, width=0.2, segments=20, cross=2)
    g = opdeform.Graph.from_mesh(v, t, particles=40)
    fit, skin = opdeform.GoalFit(g, v), opdeform.Skin(g, v)

    def on_goals(carry):
        sim = gc.simulation(g, np.full(g.n_particles, 1000.0), carry)
        sim.set_state(*fit.fit(gc.lying(v, 0)))
        gc.add_contact(sim, kind)
        sim.set_contact_skin(skin)
        worst = 0.0
        for f in range(30):
            goals = fit.fit(gc.lying(v, f))
            sim.set_goals(*goals)
            sim.step()
            worst = max(worst, np.abs(sim.positions - goals[0]).max())
        return worst

    assert on_goals(True) < 1e-5 * gc.LENGTH
    if kind == "plane":
        assert on_goals(False) > 0.004
    root = g.centers[:, 0] < gc.LENGTH / 2
    sim = gc.simulation(g, np.where(root, 1000.0, 0.0), stiffness=1e5, gravity=(0.0, 0.0, 0.0))
    start = fit.fit(gc.falling(v, -1))
    sim.set_state(*start, velocities=np.tile([0.0, 0.0, -gc.SPEED], (g.n_particles, 1)))
    sim.set_goals(*start)
    gc.add_contact(sim, kind)
    sim.set_contact_skin(skin)
    tip, lowest, shown = v[:, 0] > 1.5, np.inf, np.inf
    for f in range(gc.STOP + 60):
        sim.set_goals(*fit.fit(gc.falling(v, f)))
        sim.step()
        lowest = min(lowest, skin.deform_sim(sim, push_out=False)[tip, 2].min())
        shown = min(shown, skin.deform_sim(sim)[tip, 2].min())
    # the tip's skin reached it, not past: with goals carrying the rest a particle carries no copy of weight below
    # CONTACT_WEIGHT, so the skin as blended may dip 0.1 mm (0.005 % of the bar), which the push-out lifts
    assert gc.SURFACE[kind] - 2e-4 < lowest < gc.SURFACE[kind] + 1e-3
    assert shown > gc.SURFACE[kind] - 1e-6
