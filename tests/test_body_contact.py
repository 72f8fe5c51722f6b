"""Contact between simulated bodies (opdeform.ContactGroup) and within one body (self-contact), docs/contact.md,
issue 13: bodies colliding head on or fast do not pass through each other and keep their momentum, a body
dropped on another stays above it through the impact and comes to rest on it, bodies that start overlapping
come apart slowly, a rod's far end bent onto its other end does not pass into it and comes to rest there, a tail
pulled past its body by a pin or by goals of any strength goes round it, never through, a body at rest with
self-contact on stays at rest to the bit, contact after the iterations only stays an option, and bad input
raises."""

import dataclasses
import pickle

import numpy as np
import pytest

import opdeform
from opdeform import meshes, scenes


@pytest.fixture(scope="module")
def bar():
    v, t = meshes.bar(length=0.6, width=0.3, segments=12, cross=4)
    v = v - v.mean(axis=0)
    return v, t, opdeform.Graph.from_mesh(v, t, particles=100)


def _body(graph, offset, velocity=(0.0, 0.0, 0.0), gravity=(0.0, 0.0, 0.0), k=1e6, **kw):
    sim = opdeform.Simulation(graph, k, dt=1 / 60, gravity=gravity, **kw)
    n = graph.n_particles
    sim.set_state(graph.centers + offset, np.tile(np.eye(3), (n, 1, 1)), np.tile(velocity, (n, 1)))
    return sim


def _momentum(sims):
    return sum((s.graph.volumes[:, None] * s.velocities).sum(axis=0) for s in sims)


@pytest.mark.parametrize("speed, k", [(1.5, 1e6), (20.0, 1e8)])
def test_bodies_colliding_head_on_do_not_pass_through(bar, speed, k):
    """Bars 0.3 m thick never closer than 0.2 m between their centres. Not soft bars (k = 1e6) at 20 m/s: they
    squash as elasticity says (the 5,400 J of their relative motion, k/2 ε² over their 0.054 m³ each, is a strain of
    about 0.32, 10 cm a bar; their centres come within 0.14 m) while their skins stay apart
    (tests/test_skin_pairs.py, head on)."""
    g = bar[2]
    a, b = _body(g, (0.0, 0.0, 0.0), k=k), _body(g, (0.0, 0.0, 0.4), (0.0, 0.0, -speed), k=k)
    group = opdeform.ContactGroup([a, b], friction=0.0)
    before = _momentum([a, b])
    for _ in range(30):
        group.step()
        assert b.positions[:, 2].mean() - a.positions[:, 2].mean() > 0.2  # bars 0.3 thick: never through
    assert _momentum([a, b]) == pytest.approx(before, abs=1e-3 * abs(before[2]))
    # alone, the same bodies pass through each other
    a, b = _body(g, (0.0, 0.0, 0.0), k=k), _body(g, (0.0, 0.0, 0.4), (0.0, 0.0, -speed), k=k)
    for _ in range(30):
        a.step()
        b.step()
    assert b.positions[:, 2].mean() < a.positions[:, 2].mean()


def test_contact_after_the_iterations_only_is_kept_as_an_option(bar):
    """in_iterations=False: the projection after the iterations alone (the add-on's groups), a step a function
    of the states alone: a second group from the same states steps the same to the bit."""
    g = bar[2]
    runs = []
    for _ in range(2):
        a, b = _body(g, (0.0, 0.0, 0.0)), _body(g, (0.0, 0.0, 0.4), (0.0, 0.0, -1.5))
        group = opdeform.ContactGroup([a, b], friction=0.0, in_iterations=False)
        for _ in range(30):
            group.step()
            assert b.positions[:, 2].mean() - a.positions[:, 2].mean() > 0.2
        runs.append(b.positions.copy())
    assert np.array_equal(runs[0], runs[1])
    group.set_contact(0.005, 0.5, in_iterations=True)
    group.step()


def _stack(graph):
    """Two bars on a floor (friction 0.5), the upper one 0.15 m above the lower one, under gravity."""
    a, b = _body(graph, (0.0, 0.0, 0.0), gravity=(0, 0, -9.81)), _body(graph, (0.0, 0.0, 0.45), gravity=(0, 0, -9.81))
    for sim in (a, b):
        sim.set_floor(-0.15, 0.5)
    return a, b


def test_a_body_dropped_on_another_stays_above_it_through_the_impact(bar):
    g = bar[2]
    a, b = _stack(g)
    group = opdeform.ContactGroup([a, b])
    for _ in range(40):
        group.step()
        assert b.positions[:, 2].mean() - a.positions[:, 2].mean() > 0.22
    assert np.abs(a.positions[:, :2].mean(axis=0)).max() < 0.02  # A stays where it was


def _skinned_overlap(graph, vertices, triangles, lower, upper):
    """How deep the upper body's skinned vertices lie inside the lower body's skinned mesh (m, >= 0)."""
    shown = [opdeform.Skin(graph, vertices).deform_sim(sim, push_out=False) for sim in (lower, upper)]
    probe = opdeform.Simulation(graph, 1e6)
    probe.add_collider("mesh", vertices=shown[0], triangles=triangles, resolution=64)
    return max(-probe.collider_distances(shown[1]).min(), 0.0)


def test_a_bar_dropped_on_another_comes_to_rest_on_it(bar):
    """At rest in the sixth second: the upper bar's fastest particle under 0.05 m/s at all but a few steps. A pair
    that starts or stops pressing a particle jolts the bars for a step or two now and then (up to 0.42 m/s, 20 steps
    of 2-13 s before forces faded instead of vanishing, 5 after; docs/contact.md, stacks); one fell on the last step."""
    v, t, g = bar
    a, b = _stack(g)
    group = opdeform.ContactGroup([a, b], friction=0.5)
    group.step(300)
    moving = 0
    for _ in range(60):  # the sixth second
        group.step()
        moving += np.abs(b.velocities).max() >= 0.05
    assert moving <= 3, moving  # at rest
    assert b.positions[:, 2].mean() - a.positions[:, 2].mean() > 0.25  # on it: bars 0.3 thick
    assert np.abs(b.positions[:, :2].mean(axis=0) - a.positions[:, :2].mean(axis=0)).max() < 0.05
    assert _skinned_overlap(g, v, t, a, b) < 0.02 * 0.6  # issue 13: < 2 % of the size


def test_a_capsule_dropped_across_a_bar_rests_on_it_under_the_default_solver():
    """The presets' solver ("auto" under a tolerance) in a group: each member starts from its previous
    rotations, takes plain pairs and iterates in step with the other (it rattled at 0.2-0.37 m/s and slid off
    in 5 s before)."""
    from opdeform import materials

    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    capsule = meshes.capsule(radius=0.15, length=0.8, segments=20, rings=5, body=8)
    bar_v, bar_t = meshes.bar(length=1.0, width=0.3, segments=10, cross=3)
    sims = []
    for v, t, z in ((bar_v - bar_v.mean(axis=0), bar_t, 0.16), (capsule[0] @ turn.T, capsule[1], 0.66)):
        g = opdeform.Graph.from_mesh(v + (0.0, 0.0, z), t, particles=100)
        sim = materials.make_simulation(g, dt=1 / 60)
        sim.set_floor(0.0, 0.5)
        sims.append(sim)
    group = opdeform.ContactGroup(sims, friction=0.5)
    for _ in range(360):  # 6 s
        group.step()
    a, b = sims
    assert b.positions[:, 2].mean() - a.positions[:, 2].mean() > 0.28  # touching: 0.30
    assert np.abs(b.positions[:, :2].mean(axis=0) - a.positions[:, :2].mean(axis=0)).max() < 0.05
    assert np.abs(b.velocities).max() < 0.05
    assert b.step_report["unconverged"] == 0


def test_bodies_that_start_overlapping_come_apart_without_exploding(bar):
    g = bar[2]
    a, b = _body(g, (0.0, 0.0, 0.0)), _body(g, (0.0, 0.0, 0.2))  # 10 cm into each other
    group = opdeform.ContactGroup([a, b])
    fastest = 0.0
    for _ in range(30):
        group.step()
        fastest = max(fastest, np.abs(a.velocities).max(), np.abs(b.velocities).max())
    assert fastest < 1.5  # the 1 m/s recovery, plus what the bodies' elasticity adds
    assert b.positions[:, 2].mean() - a.positions[:, 2].mean() > 0.25


def _layered(bar, scale, together):
    """A body and a copy of it `scale` times larger about its centre (a jacket), both with goals of strength 0.5
    carrying the rest at their own shapes (the add-on's goals: the animated shape is the equilibrium), hopping
    0.3 m three times in 1.5 s, stepped in one group (`together`) or each alone; their positions at each step."""
    v, t, g = bar
    sims = []
    for graph in (g, opdeform.Graph.from_mesh(v * scale, t, particles=100)):
        sim = _body(graph, (0.0, 0.0, 0.0), gravity=(0.0, 0.0, -9.81), k=1e5, damping=0.05)
        sim.set_goal_strength(0.5)
        sim.set_goals_carry_rest(True)
        sims.append(sim)
    group, shown = opdeform.ContactGroup(sims), []
    for step in range(90):
        for sim in sims:
            lift = (0.0, 0.0, 0.3 * abs(np.sin(np.pi * step / 30)))
            sim.set_goals(sim.graph.centers + lift, np.tile(np.eye(3), (sim.graph.n_particles, 1, 1)))
        _ = group.step() if together else [sim.step() for sim in sims]
        shown.append([sim.positions.copy() for sim in sims])
    return np.array(shown)


@pytest.mark.parametrize("scale", [1.05, 1.25])
def test_members_that_overlap_at_their_goals_move_as_alone(bar, scale):
    """Issue 24, finding (4) of docs/goals.md's outside creature: a body and a jacket 5 or 25 % larger following
    one animation overlap at rest; their contact started them interpenetrating and blew them apart (the bird's
    jacket stretched 7x, these bars 0.4-0.6 m off their goals). Pairs that their goals put together are not contact
    (docs/contact.md, "Members that overlap at rest"): in the group each moves as it does alone (within 1 µm)."""
    together, alone = _layered(bar, scale, True), _layered(bar, scale, False)
    assert np.abs(together - alone).max() < 1e-6, np.abs(together - alone).max()

def test_members_with_goals_still_collide_where_their_goals_are_apart(bar):
    """Only pairs the goals put together are left out: two bars with free goals (strength 0, carrying the rest)
    0.4 m apart, one thrown at the other at 1.5 m/s, never pass through (as without goals, the first test)."""
    g = bar[2]
    a, b = _body(g, (0.0, 0.0, 0.0)), _body(g, (0.0, 0.0, 0.4), (0.0, 0.0, -1.5))
    for sim in (a, b):
        sim.set_goal_strength(0.0)
        sim.set_goals_carry_rest(True)
        sim.set_goals(sim.positions, sim.rotations)
    group = opdeform.ContactGroup([a, b], friction=0.0)
    for _ in range(30):
        group.step()
        assert b.positions[:, 2].mean() - a.positions[:, 2].mean() > 0.2


def _ends_now(sim, root, tip, far):
    """Now: the least centre distance of the root's and the tip's particles less their largest radii, and the
    deepest overlap of the tip's ellipsoids with those of the far half of the body, along their centre lines
    (supports, not radii; > 0: one inside the other, which a tail that goes round its body never needs and one
    pulled through it must). The first is lower than the second by as much as the particles turn their short
    axes to the contact (with self-contact's forces they do: the rod's ends -0.039 m, 4.5 mm apart)."""
    g, p = sim.graph, sim.positions
    reach = g.radii.max(axis=1)
    least = (np.linalg.norm(p[root][:, None] - p[tip][None], axis=2) - reach[root][:, None] - reach[tip][None]).min()
    d = p[tip][None] - p[far][:, None]
    distance = np.linalg.norm(d, axis=2)
    n = d / distance[..., None]
    frames = sim.rotations @ g.axes
    moments = frames @ (g.radii[:, :, None] ** 2 * np.eye(3)) @ frames.transpose(0, 2, 1)
    supports = (np.sqrt(np.einsum("ijk,ikl,ijl->ij", n, moments[far], n)) +
                np.sqrt(np.einsum("ijk,jkl,ijl->ij", n, moments[tip], n)))
    return least, (supports - distance).max()


def _ends(x):
    """The rod's root end, tip end (0.15 m each) and far half from the tip (its axis along x)."""
    return np.flatnonzero(x < x.min() + 0.15), np.flatnonzero(x > x.max() - 0.15), np.flatnonzero(x < x.max() - 0.6)


def _bend_end_onto_end(self_contact, sweep):
    """A 1.2 m rod along x, its root end held by two pins, the pin on its tip carried on a half circle about the
    middle through `sweep` half turns (1: the target ends on the root, 1.2: past it, beyond the body). Over the
    motion, the least distance of the two ends' particles less the sum of their largest radii and the deepest
    overlap of the tip's ellipsoids with the far half's (_ends_now), and the tip's last height (the root is at
    z = 0): (least, height, deepest)."""
    sim, _, _, tip, targets = scenes.bent_rod(self_contact, sweep)  # its axis is x
    parts = _ends(sim.graph.centers[:, 0])
    least, deepest = np.inf, -np.inf
    for target in targets:
        sim.set_constraint_target(tip, target)
        sim.step()
        now = _ends_now(sim, *parts)
        least, deepest = min(least, now[0]), max(deepest, now[1])
    return least, sim.positions[parts[1], 2].mean(), deepest


def test_a_rods_end_bent_onto_its_other_end_does_not_pass_into_it():
    """Measured by the ellipsoids' overlap, not by centre distance less radii: that was -0.026 m with the
    projection alone, is -0.039 with self-contact's forces (the end particles turn their short axes to the
    contact), while the ellipsoids are 2.0 and 4.5 mm apart."""
    assert _bend_end_onto_end(False, 1.0)[2] > 0.05  # without self-contact the ends overlap (91 mm)
    assert _bend_end_onto_end(True, 1.0)[2] < 0.0  # with it they touch (4.5 mm apart)


def test_a_rods_end_held_pressed_onto_its_other_end_comes_to_rest():
    """Self-contact's forces hold the pinned ends pressed without shaking them (fastest particle 0.015 m/s over
    the last second of 10 s; 0.046 with the projection alone, 2.2 with the pairs' normals turned as between
    bodies)."""
    sim, _, _, tip, targets = scenes.bent_rod(True, 1.0, steps=600)
    fastest = []
    for target in targets:
        sim.set_constraint_target(tip, target)
        sim.step()
        fastest.append(np.abs(sim.velocities).max())
    assert max(fastest[-60:]) < 0.05


def test_a_tail_pulled_past_its_body_does_not_pass_through_it():
    """A pin pulls the tip past its root: it goes round the root, pushing the soft rod aside (its tip ends 0.34
    m below the root), never into it (the projection alone let it 21.5 mm in; without self-contact 99 mm)."""
    assert _bend_end_onto_end(False, 1.2)[2] > 0.05
    assert _bend_end_onto_end(True, 1.2)[2] < 0.005  # 2.1 mm, within the contact thickness


def _goal_tail(strength, self_contact=True, sweep=1.2, steps=120):
    """bent_rod's capsule held by goals instead of pins: its root end (0.15 m) on goals at rest at strength 1,
    its tip end on goals carried rigidly about the middle through `sweep` half turns in 90 of `steps` steps
    (1.2: past the root, beyond the body) at `strength`, the rest free. As _bend_end_onto_end: (least, height,
    deepest)."""
    v, t = meshes.capsule(radius=0.06, length=1.2)
    g = opdeform.Graph.from_mesh(v, t, particles=60)
    sim = opdeform.Simulation(g, 1e5, dt=1 / 60, gravity=(0, 0, 0), damping=0.05)
    if self_contact:
        sim.set_self_contact()
    x = g.centers[:, 0]
    parts, middle = _ends(x), np.array([(x.min() + x.max()) / 2, 0.0, 0.0])
    root, tip = x < x.min() + 0.15, x > x.max() - 0.15
    sim.set_goal_strength(np.where(root, 1.0, np.where(tip, strength, 0.0)))
    least, deepest = np.inf, -np.inf
    for k in range(steps):
        a = np.pi * sweep * min(1.0, (k + 1) / 90)
        turn = np.array([[np.cos(a), 0.0, -np.sin(a)], [0.0, 1.0, 0.0], [np.sin(a), 0.0, np.cos(a)]])
        goals, rotations = g.centers.copy(), np.tile(np.eye(3), (g.n_particles, 1, 1))
        goals[tip], rotations[tip] = (g.centers[tip] - middle) @ turn.T + middle, turn
        sim.set_goals(goals, rotations)
        sim.step()
        now = _ends_now(sim, *parts)
        least, deepest = min(least, now[0]), max(deepest, now[1])
    return least, sim.positions[tip, 2].mean(), deepest


def test_a_tail_pulled_past_its_body_by_goals_passes_through_it_without_self_contact():
    for strength in (0.5, 0.9, 1.0):
        assert _goal_tail(strength, self_contact=False)[2] > 0.05  # 88-91 mm: through


@pytest.mark.parametrize("strength", [0.5, 0.9, 1.0])
def test_a_tail_pulled_past_its_body_by_goals_does_not_pass_through_it(strength):
    """Goals of any strength: the tip stays on its root (0.5) or goes round it, never into it (deepest overlap
    -3.8 / 0.9 / 0.6 mm at 0.5 / 0.9 / 1.0; the projection alone let it -0.5 / 73 / 54 mm in)."""
    assert _goal_tail(strength)[2] < 0.005


def test_a_body_at_rest_with_self_contact_stays_at_rest_to_the_bit(bar):
    g = bar[2]
    plain, touching = (_body(g, (0.0, 0.0, 0.0), gravity=(0, 0, -9.81)) for _ in range(2))
    touching.set_self_contact(exclusion_ring=0)  # the rest overlaps alone exclude the neighbours
    for sim in (plain, touching):
        sim.set_floor(-0.15, 0.5)
        sim.step(60)
    assert np.array_equal(plain.positions, touching.positions)
    assert touching.self_contact["exclusion_ring"] == 0


def test_a_member_no_other_reaches_steps_as_it_would_alone():
    """A body in a group with another 5 m away lands on its floor as it would alone, to the bit, under the default
    tolerance: before, every member of a group with forces iterated in step with the others, its floor after the
    iterations, and the capsule landed up to 5 cm otherwise (docs/contact.md, "Members far apart")."""
    v, t = meshes.capsule(radius=0.2, length=0.6)

    def dropped(shift):
        sim = opdeform.Simulation(opdeform.Graph.from_mesh(v + shift, t, particles=60), 3e5, dt=1 / 240,
                                  gravity=(0.0, 0.0, -9.81))
        sim.set_floor(0.0)
        return sim
    alone, member, far = dropped((0.0, 0.0, 0.5)), dropped((0.0, 0.0, 0.5)), dropped((5.0, 0.0, 1.0))
    group = opdeform.ContactGroup([member, far])
    for _ in range(36):
        alone.step(10)
        group.step(10)
    assert alone.positions[:, 2].min() < 0.12  # landed
    for name in ("positions", "rotations", "velocities", "angular_velocities"):
        np.testing.assert_array_equal(getattr(member, name), getattr(alone, name), err_msg=name)


def test_a_group_saved_and_restored_with_its_members_steps_on_bit_for_bit(bar):
    """The forces a group keeps between steps (their warm start) are its state: restored with the members'
    states (here by pickling them), the next steps are those that followed the save."""
    a, b = _stack(bar[2])
    group = opdeform.ContactGroup([a, b])
    group.step(40)  # the upper bar rests on the lower one
    saved, members = group.save_state(), pickle.dumps((a, b))
    assert saved[0].shape[1] == 2 and saved[1].shape == (len(saved[0]), 10) and (saved[1][:, 0] > 0).any()
    group.step(5)
    again = opdeform.ContactGroup(pickle.loads(members))
    again.restore_state(saved)
    again.step(5)
    assert all(np.array_equal(x.positions, y.positions) for x, y in zip((a, b), again.sims))
    fresh = opdeform.ContactGroup(pickle.loads(members))  # a new group has no forces: not the same steps
    fresh.step(5)
    assert not np.array_equal(b.positions, fresh.sims[1].positions)
    fresh.restore_state(None)
    assert fresh.save_state()[0].shape == (0, 2)


def test_bad_input(bar):
    g = bar[2]
    a = _body(g, (0, 0, 0))
    with pytest.raises(TypeError):
        opdeform.ContactGroup([a, "b"])
    with pytest.raises(ValueError, match="thickness"):
        opdeform.ContactGroup([a, _body(g, (0, 0, 1))], thickness=0.0)
    with pytest.raises(ValueError, match="twice"):
        opdeform.ContactGroup([a, a])
    with pytest.raises(ValueError, match="exclusion_ring"):
        a.set_self_contact(exclusion_ring=3)
    assert a.self_contact is None
    other = opdeform.Simulation(g, 1e6, dt=1 / 30)
    with pytest.raises(ValueError, match="dt"):
        opdeform.ContactGroup([a, other]).step()
    group = opdeform.ContactGroup([a, _body(g, (0, 0, 1))])
    n = 2 * g.n_particles
    for pairs, forces, match in (([[0, n]], np.zeros((1, 10)), "pairs"), ([[3, 2]], np.zeros((1, 10)), "pairs"),
                                 ([[0, 1]], [[np.nan] + [0] * 9], "finite"), ([[0, 1]], [[-1.0] + [0] * 9], ">= 0"),
                                 ([[0, 1]], [[0] * 6 + [1, 0, 0, np.inf]], "finite"),
                                 ([[0, 1]], np.zeros((1, 7)), "forces"), ([[0, 1]], np.zeros((2, 10)), "forces")):
        with pytest.raises(ValueError, match=match):
            group.restore_state((pairs, forces))
        assert group.save_state()[0].shape == (0, 2)


def _preset_body(vertices, triangles, z, preset, density=None, rate=60):
    """A body of a materials preset (its density unless given) z above its rest, on a floor (μ = 0.5), 1/rate s."""
    from opdeform import materials

    m = materials.PRESETS[preset]
    if density is not None:
        m = dataclasses.replace(m, density=density)
    sim = materials.make_simulation(opdeform.Graph.from_mesh(vertices + (0.0, 0.0, z), triangles, particles=100), m,
                                    dt=1 / rate)
    sim.set_floor(0.0, 0.5)
    return sim


def _centres_energy(sims):
    """The kinetic and potential energy of the members' particles' centres (J)."""
    return sum(s.params["density"] * (s.graph.volumes * (0.5 * (s.velocities ** 2).sum(axis=1) + 9.81 * s.positions[:, 2])).sum()
               for s in sims)


def _stacked_seconds(lower, upper, seconds, rate=60):
    """Steps the two in a group (μ = 0.5, `rate` steps a second) and yields, each second, (height of the upper's centre above the
    lower's, distance aside, the upper's fastest particle, how far the energy of the particles' centres, kinetic
    and potential, rose above its start at any step so far (J))."""
    group = opdeform.ContactGroup([lower, upper], friction=0.5)
    start, rise = _centres_energy((lower, upper)), -np.inf
    for _ in range(seconds):
        for _ in range(rate):
            group.step()
            rise = max(rise, _centres_energy((lower, upper)) - start)
        above = upper.positions[:, 2].mean() - lower.positions[:, 2].mean()
        aside = np.linalg.norm(upper.positions[:, :2].mean(axis=0) - lower.positions[:, :2].mean(axis=0))
        yield above, aside, np.abs(upper.velocities).max(), rise


def test_a_stiff_sphere_resting_off_centre_on_another_does_not_creep():
    """Issue 27: a Stiff sphere (1 m) dropped 5 cm onto a like one on the floor, at 240 steps a second (the add-on's
    24 fps and 10 substeps), rests on one pair whose normal leans 5 degrees, its friction a tenth to a third of its
    bound, and must stay where it came to rest. It crept 0.014 -> 0.076 m aside from 3 to 13 s: friction measured
    from each step's start let the 15 um a step that the step's last solve left slide; anchored where the pair
    began to stick, 0.005 -> 0.012 m (docs/contact.md, "Stacks", stop 46)."""
    v, t = meshes.capsule(radius=0.5, length=1e-3, segments=32, rings=8, body=1)
    lower, upper = _preset_body(v, t, 0.5, "Stiff", rate=240), _preset_body(v, t, 1.55, "Stiff", rate=240)
    seconds = list(_stacked_seconds(lower, upper, 13, 240))[2:]
    asides = [aside for _, aside, _, _ in seconds]
    assert min(above for above, _, _, _ in seconds) > 0.9, seconds
    assert max(asides) < 0.025 and asides[-1] - asides[0] < 0.015, asides


def test_a_soft_round_body_dropped_on_a_like_one_stays_on_top():
    """Issue 27: Rubber spheres (0.6 m), one dropped 0.1 m onto the other, rest on top from 3 s to 13 s (it rolled
    off within 3 s: 0.69 m aside, 0.75 m/s): the members' rigid motions in each update of the forces
    (docs/contact.md, stacks)."""
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    v = v + (0.0, 0.0, 0.3)
    lower, upper = _preset_body(v, t, 0.0, "Rubber"), _preset_body(v, t, 0.7, "Rubber")
    for second, (above, aside, fastest, _) in enumerate(_stacked_seconds(lower, upper, 13), 1):
        if second >= 3:
            assert above > 0.55 and aside < 0.1 and fastest < 0.05, (second, above, aside, fastest)


def test_at_24_steps_a_second_rubber_spheres_stacked_rest_on_top_without_gaining_energy():
    """Issue 27: at one step a frame (1/24 s), Rubber spheres (0.6 m), one dropped 0.1 m onto the other as the
    stacking bench places them, rest on top from 3 s to 13 s without gaining energy. They tipped over as one and
    rolled off (0.68 m aside): at that step the floor's rolling couple in the solves hardly turns a member; the
    patch's roll after the projections holds them (docs/contact.md, stacks, stop 38)."""
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    v = v + (0.0, 0.0, 0.3)
    lower, upper = _preset_body(v, t, 0.0, "Rubber", rate=24), _preset_body(v, t, 0.7, "Rubber", rate=24)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, 24), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.55 and aside < 0.1 and fastest < 0.05, (second, above, aside, fastest)


@pytest.mark.parametrize("rate", [60, 240])
def test_jelly_spheres_stacked_rest_on_top_without_gaining_energy(rate):
    """Issue 27: Jelly spheres (0.6 m), one dropped 0.1 m onto the other settled on the floor, rest on top from 3 s
    to 13 s at 60 and 240 steps a second without gaining energy. They tipped over as one, the lower rolling on its
    floor, and were off it at 3 s (1.0-1.1 m aside): a round member rolls over the particles its floor's friction
    pins, with nothing of a contact patch's rolling resistance (docs/contact.md, stacks, ninth round)."""
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    lower = _preset_body(v, t, 0.31, "Jelly", rate=rate)
    lower.step(rate)
    upper = _preset_body(v, t, lower.positions[:, 2].mean() + 0.7, "Jelly", rate=rate)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, rate), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.55 and aside < 0.1 and fastest < 0.05, (second, above, aside, fastest)


@pytest.mark.parametrize("preset", ["Jelly", "Rubber"])
def test_at_24_steps_a_second_spheres_stacked_on_a_settled_one_rest_on_top(preset):
    """Issue 27: at one step a frame (1/24 s), spheres (0.6 m), one dropped 0.1 m onto the other settled on the floor
    first, rest on top from 3 s to 13 s without gaining energy. The upper crept off (0.252 m aside at 13 s Jelly,
    0.643 m Rubber): the patch rolls after the projections rolled the lower back on its floor and carried its top
    from under the upper, a slip friction never saw; the upper is now carried with it (docs/contact.md, "Stacks",
    stop 41)."""
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    lower = _preset_body(v, t, 0.31, preset, rate=24)
    lower.step(24)
    upper = _preset_body(v, t, lower.positions[:, 2].mean() + 0.7, preset, rate=24)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, 24), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.55 and aside < 0.05 and fastest < 0.01, (second, above, aside, fastest)


def test_a_member_gone_non_finite_within_a_group_call_is_refused_not_a_crash():
    """A group call of several steps whose member's state turns NaN in its first (spinning at 1e300 rad/s) raises
    SolverError and keeps every member's state. The carry (stop 41) ordered the members by their centres' heights:
    a NaN centre was below none and none below it, and it looked for the missing storey past the members (a
    segfault)."""
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    lower, upper = _preset_body(v, t, 0.31, "Rubber", rate=24), _preset_body(v, t, 1.0, "Rubber", rate=24)
    group = opdeform.ContactGroup([lower, upper], friction=0.5)
    group.step()
    lower.set_state(lower.positions, lower.rotations, np.zeros((lower.graph.n_particles, 3)),
                    np.full((lower.graph.n_particles, 3), 1e300))
    kept = (lower.positions, upper.positions)
    with pytest.raises(opdeform.SolverError):
        group.step(4)
    assert np.array_equal(lower.positions, kept[0]) and np.array_equal(upper.positions, kept[1])


@pytest.mark.parametrize("strength", [0.7, 1.0])
def test_a_member_its_goals_lift_under_another_rises_as_they_do(strength):
    """Issue 27: two Rubber spheres (0.6 m) stacked, meeting their floor with their skins and each other with their
    ellipsoids (the add-on's default, where members' impacts are inelastic: docs/contact.md, stacks, stop 38); the
    lower's goals (strength 0.7 or 1) lift it at 1 m/s with the upper on it. From the third step of 15 its centre
    rises within 0.25 m/s of them: the impacts' landing slowed a member pressed onto its floor to |g|/60 s = 0.16 m/s
    whatever held it, goals too, the first 4-12 steps (docs/contact.md, stacks, stop 39, land)."""
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    v = v + (0.0, 0.0, 0.3)
    lower, upper = _preset_body(v, t, 0.0, "Rubber"), _preset_body(v, t, 0.61, "Rubber")
    for sim, z in ((lower, 0.0), (upper, 0.61)):
        sim.set_contact_skin(opdeform.Skin(sim.graph, v + (0.0, 0.0, z)), bodies=False)
    group = opdeform.ContactGroup([lower, upper], friction=0.5)
    group.step(120)
    start = lower.positions.copy()
    lower.set_goal_strength(strength)
    for step in range(1, 16):
        lower.set_goals(start + (0.0, 0.0, step / 60), lower.rotations)
        group.step()
        rise = lower.velocities[:, 2].mean()
        assert step < 3 or abs(rise - 1.0) < 0.25, (step, rise)
    assert upper.positions[:, 2].mean() > lower.positions[:, 2].mean() + 0.55  # carried on it


def test_two_creatures_dropped_one_on_the_other_never_gain_energy():
    """Issue 27: two 1,000-particle creatures (k = 2e5), one dropped onto the other on the floor (3.1 m/s at the
    impact; the contact bench's stacked pair), 4 s: the energy of the particles' centres never rises above its
    start. With the floor's rolling couple at the impact it rose 92 kJ in 3 of 5 starts 0 to 1 cm apart (it is left
    out at impacts, docs/contact.md, stacks, ninth round)."""
    v, t = meshes.creature(64)
    g = opdeform.Graph.from_mesh(v, t, particles=1000)
    lift = np.ptp(g.centers[:, 2]) + 2.0 * g.radii.max()
    for apart in (0.0, 0.003):
        sims = [opdeform.Simulation(g, 2e5, damping=0.02) for _ in range(2)]
        for k, sim in enumerate(sims):
            sim.set_state(g.centers + (apart * k, 0.0, k * lift), np.tile(np.eye(3), (g.n_particles, 1, 1)))
            sim.set_floor(g.centers[:, 2].min() - g.radii.max(), 0.5)
        group = opdeform.ContactGroup(sims)
        start = _centres_energy(sims)
        for step in range(240):
            group.step()
            assert _centres_energy(sims) <= start, (apart, step)


def test_a_rubber_creature_dropped_on_another_at_240_steps_a_second_stays_on_top():
    """Issue 27, the stacks bench's creatures (`scripts/bench stacking --stacks --rate 240`): two Rubber creatures
    (1.6 m long, 0.54 m wide, 100 particles), the upper dropped 0.1 m onto the lower on the floor at 240 steps a
    second; from 3 to 13 s the upper's centre stays 0.48 m above the lower's, within 0.135 m aside, at rest. Before
    the members' inelastic impact acted on members their floor holds inside the iterations, the upper bounced at
    the landing, tipped 16 degrees onto the lower's flank and slid off (1.10 m aside at 9 s; docs/contact.md,
    "Stacks", stop 44)."""
    v, t = meshes.creature(24)
    lower, upper = _preset_body(v, t, 0.0, "Rubber", rate=240), _preset_body(v, t, 1.06, "Rubber", rate=240)
    group = opdeform.ContactGroup([lower, upper], friction=0.5)
    group.step(3 * 240)
    for second in range(4, 14):
        group.step(240)
        above = upper.positions[:, 2].mean() - lower.positions[:, 2].mean()
        aside = np.linalg.norm(upper.positions[:, :2].mean(axis=0) - lower.positions[:, :2].mean(axis=0))
        assert above > 0.48 and aside < 0.135, (second, above, aside)
    assert np.abs(upper.velocities).max() < 0.05


def _slab():
    v, t = meshes.bar(length=0.8, width=0.8, segments=8, cross=8)
    v = v - v.mean(axis=0)
    v[:, 2] *= 0.25  # 0.8 x 0.8 x 0.2 m
    return v, t


@pytest.mark.parametrize("ratio", [10, 1000, 1e6])
def test_a_slab_much_denser_dropped_on_another_never_gains_energy(ratio):
    """Issue 27: the energy of the particles' centres (kinetic and potential) never rises above its start when a
    Stiff slab 10 to 1e6 times as dense is dropped 0.05 m onto another on the floor (the floor's reaction inside
    the iterations gained 2.9 kJ at 1,000 and 10.5 MJ of 39 MJ at 1e6 before it was kept to members of comparable
    mass), and at 10 times it stays on top."""
    v, t = _slab()
    light = 1000.0 if ratio < 1e3 else 100.0
    lower, upper = _preset_body(v, t, 0.1, "Stiff", light), _preset_body(v, t, 0.35, "Stiff", light * ratio)
    for above, aside, _, rise in _stacked_seconds(lower, upper, 4):
        assert rise <= 0.0, rise
        assert ratio > 10 or (above > 0.15 and aside < 0.05), (above, aside)


@pytest.mark.parametrize("preset", ["Jelly", "Rubber", "Stiff"])
@pytest.mark.parametrize("ratio", [100, 1000])
def test_a_slab_100_to_1000_times_as_dense_dropped_on_another_rests_on_top(preset, ratio):
    """Issue 27: a slab 100 or 1,000 times as dense as the one below (0.8 x 0.8 x 0.2 m, dropped 0.05 m) rests on
    top of it from 3 s to 13 s (its centre more than half their height above the lower's, fastest particle under
    0.05 m/s) and the drop never gains energy: the lower slab on its floor stands immovable to it (shock
    propagation, docs/contact.md, stacks). It sank to 0.035-0.041 m above (Jelly, Rubber 100:1) or passed through
    (Rubber 1,000:1, Stiff)."""
    v, t = _slab()
    light = 1000.0 if ratio < 1e3 else 100.0
    lower, upper = _preset_body(v, t, 0.1, preset, light), _preset_body(v, t, 0.35, preset, light * ratio)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.1 and aside < 0.05 and fastest < 0.05, (second, above, aside, fastest)


@pytest.mark.parametrize("preset", ["Jelly", "Rubber", "Stiff"])
def test_a_slab_1e6_times_as_dense_never_passes_through_the_one_below(preset):
    """Issue 27: a slab 1e6 times as dense dropped 0.05 m onto another stays above it for 13 s (its centre more
    than half their height above the lower's) without gaining energy, at rest from 3 s (it spreads over the lower
    one under its own weight). It passed through within 2 s (0.22-0.25 m below)."""
    v, t = _slab()
    lower, upper = _preset_body(v, t, 0.1, preset, 100.0), _preset_body(v, t, 0.35, preset, 1e8)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13), 1):
        assert rise <= 0.0 and above > 0.1 and aside < 0.05, (second, rise, above, aside)
        assert second < 3 or fastest < 0.05, (second, fastest)


def _on_a_settled_slab(preset, lower_density, upper_density, rate):
    """A slab of `preset` settled alone on the floor for 1 s at `rate` steps a second and a like one 0.05 m above
    it: (lower, upper)."""
    v, t = _slab()
    lower = _preset_body(v, t, 0.13, preset, lower_density, rate)
    lower.step(rate)
    return lower, _preset_body(v, t, lower.positions[:, 2].mean() + 0.25, preset, upper_density, rate)


@pytest.mark.parametrize("preset, ratio", [("Jelly", 10), ("Rubber", 10), ("Rubber", 100), ("Stiff", 100),
                                           ("Rubber", 1000), ("Stiff", 1000)])
def test_at_240_steps_a_second_a_slab_10_to_1000_times_as_dense_rests_on_top(preset, ratio):
    """Issue 27, at the add-on's steps (1/240 s): a slab 10, 100 or 1,000 times as dense dropped 0.05 m onto one
    resting on the floor rests on top from 3 s to 13 s without gaining energy. A step's |g| h (0.04 m/s) as the
    speed beyond which a rising member braces nothing let the lower slab's own motion cross it and back: the upper
    one buzzed; at 10:1 the pushes of members of comparable mass, per step, slid it off (docs/contact.md,
    stacks)."""
    light = 1000.0 if ratio < 1e3 else 100.0
    lower, upper = _on_a_settled_slab(preset, light, light * ratio, 240)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, 240), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.1 and aside < 0.05 and fastest < 0.05, (second, above, aside, fastest)


@pytest.mark.parametrize("ratio", [2, 3, 5])
def test_at_240_steps_a_second_a_stiff_slab_2_to_5_times_as_dense_rests_on_top(ratio):
    """Issue 27, at 1/240 s: a Stiff slab 2 to 5 times as dense dropped 0.05 m onto one resting on the floor rests on
    top from 3 s to 13 s without gaining energy. It rests on a few pairs; one of them, left apart by the last
    iterations, lost its force at once every other step (the broad phase no longer found it, or the gather dropped
    it), and the slab rocked at 0.12-0.16 m/s: a force now fades, never dropped (docs/contact.md, stacks)."""
    lower, upper = _on_a_settled_slab("Stiff", 1000.0, 1000.0 * ratio, 240)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, 240), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.1 and aside < 0.05 and fastest < 0.05, (second, above, aside, fastest)


@pytest.mark.parametrize("ratio", [2, 3, 5])
def test_at_24_steps_a_second_a_stiff_slab_2_to_5_times_as_dense_rests_on_top(ratio):
    """Issue 27, at one step a frame (1/24 s): a Stiff slab 2, 3 or 5 times as dense dropped 0.05 m onto one resting
    on the floor rests on top from 3 s to 13 s without gaining energy. It rests on 5-7 of its 100 particles, whose
    pairs' own rate moved it by their share: its friction lagged the pairs' leaning normals and it crept off (0.81 /
    0.54 m aside at 3 / 5 times); the interface's friction now takes the members' rigid step too (docs/contact.md,
    stacks, eleventh round). Twice as dense it slid off from 8 s (0.542 m aside at 13 s), the patch rolls sliding it
    on the lower slab; it is carried with it now (stop 41)."""
    lower, upper = _on_a_settled_slab("Stiff", 1000.0, 1000.0 * ratio, 24)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, 24), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.1 and aside < 0.05 and fastest < 0.05, (second, above, aside, fastest)


def test_at_24_steps_a_second_a_stiff_slab_twice_as_dense_rests_on_top_as_the_bench_places_it():
    """Issue 27: the stacking bench's Stiff slab on one half as dense at 1/24 s (`scripts/bench stacking --stacks
    --rate 24`, the lower placed on the floor) rests on top from 3 s to 13 s without gaining energy; it slid off at 5 s
    (0.99 m aside) before the interface's friction took the members' rigid step (docs/contact.md, stacks, eleventh
    round)."""
    v, t = _slab()
    lower, upper = _preset_body(v, t, 0.1, "Stiff", 1000.0, 24), _preset_body(v, t, 0.35, "Stiff", 2000.0, 24)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, 24), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.1 and aside < 0.05 and fastest < 0.05, (second, above, aside, fastest)


@pytest.mark.parametrize("preset", ["Rubber", "Stiff"])
def test_at_240_steps_a_second_a_slab_1e6_times_as_dense_never_passes_through(preset):
    """Issue 27, at 1/240 s: a slab 1e6 times as dense dropped 0.05 m onto one resting on the floor stays above it
    for 13 s without gaining energy, at rest from 4 s (it spreads over the lower one under its own weight)."""
    lower, upper = _on_a_settled_slab(preset, 100.0, 1e8, 240)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, 240), 1):
        assert rise <= 0.0 and above > 0.1 and aside < 0.05, (second, rise, above, aside)
        assert second < 4 or fastest < 0.05, (second, fastest)


@pytest.mark.parametrize("preset, densities", [("Stiff", (1000.0, 1000.0, 1e5)), ("Rubber", (100.0, 1e4, 1e6))])
def test_three_slabs_the_upper_much_denser_stay_stacked(preset, densities):
    """Issue 27: three slabs dropped 0.05 m onto each other, the top one 100 times as dense as the one below it,
    stay stacked for 6 s (each centre more than half the slabs' height above the one below) without gaining energy:
    the middle one, resting on the lowest, is supported and braces the top one (docs/contact.md, stacks). The
    Stiff stack fell apart at 3 s (its energy 12 kJ above the start)."""
    v, t = _slab()
    sims = [_preset_body(v, t, 0.1 + 0.25 * k, preset, d) for k, d in enumerate(densities)]
    group = opdeform.ContactGroup(sims, friction=0.5)
    start = _centres_energy(sims)
    for second in range(1, 7):
        for _ in range(60):
            group.step()
            assert _centres_energy(sims) <= start, second
        z = [s.positions[:, 2].mean() for s in sims]
        assert z[1] - z[0] > 0.1 and z[2] - z[1] > 0.1, (second, z)


@pytest.mark.parametrize("preset", ["Rubber", "Jelly"])
def test_at_24_steps_a_second_a_slab_on_one_1000_times_as_dense_rests_on_top(preset):
    """Issue 27, at one step a frame (1/24 s): a slab dropped 0.05 m onto one 1,000 times as dense resting on the
    floor (crushed bumpy under its own weight) rests on top from 3 s to 13 s without gaining energy. The Rubber slab
    rests on 3-5 pairs, each updated at a particle's own rate, most at their Coulomb bound: it slid off at 6 s (0.186
    m/s at 3 s); the pairs of a member resting on much heavier ones now take its rate as a rigid body, shared over
    them (docs/contact.md, stacks, stop 46). The Jelly slab stayed centred but a corner particle flapped (0.129 m/s
    at 3 s): its pair began one step 0.3 mm overlapping, was measured along its push direction and lifted, the next
    began apart and was measured along its centre line; the normal of a pair barely overlapping now turns between
    the two with the overlap (docs/contact.md, "Stop 49")."""
    from opdeform import materials

    density = materials.PRESETS[preset].density
    lower, upper = _on_a_settled_slab(preset, density * 1000, density, 24)
    for second, (above, aside, fastest, rise) in enumerate(_stacked_seconds(lower, upper, 13, 24), 1):
        assert rise <= 0.0, (second, rise)
        if second >= 3:
            assert above > 0.1 and aside < 0.05 and fastest < 0.05, (second, above, aside, fastest)


@pytest.mark.parametrize("preset, rate", [("Jelly", 24), ("Rubber", 60)])
def test_a_light_slab_on_one_1000_times_as_dense_stays_centred_on_it(preset, rate):
    """Issue 27: a slab dropped 0.05 m onto one 1,000 times as dense resting on the floor (crushed bumpy under its
    own weight) stays on top, centred within 1 cm, without gaining energy, from 1 s to 13 s. In the solves the heavy
    slab falls (its floor holds it after them), and across the pairs' leaning normals that fall read as slip in as
    many directions: the light slab's friction, at its bound, held against it and not against the normals' lean. The
    Jelly slab slid off at 24 steps a second (0.95 m aside from 3 s), the Rubber one crept 0.033 m at 60; measured
    against where the heavy end started the step, 0.005 and 0.001 m (docs/contact.md, "Stop 48"). That the Jelly one
    also rests: test_at_24_steps_a_second_a_slab_on_one_1000_times_as_dense_rests_on_top."""
    from opdeform import materials

    density = materials.PRESETS[preset].density
    lower, upper = _on_a_settled_slab(preset, density * 1000, density, rate)
    for second, (above, aside, _, rise) in enumerate(_stacked_seconds(lower, upper, 13, rate), 1):
        assert rise <= 0.0 and above > 0.1 and aside < 0.01, (second, rise, above, aside)


def _turn_of(now, then):
    """The rotation that best takes the points `then` to `now` about their means (Kabsch)."""
    u, _, vt = np.linalg.svd((now - now.mean(axis=0)).T @ (then - then.mean(axis=0)))
    return u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt


@pytest.mark.parametrize("rate, axis, degrees", [(60, 0, 15.0), (60, 1, -15.0), (240, 0, -15.0)])
def test_a_slab_resting_on_a_tilting_one_rides_it_without_creeping(rate, axis, degrees):
    """Issue 27: a Stiff slab resting on another that its goals hold in the air and tilt 15 degrees about a
    horizontal axis over 2 s (μ = 1 between them: the pairs' normals, leaning up to 15 degrees on the particles'
    bumps, stay inside their cones) stays where it rests on it: its centre, seen from the lower slab, moves less
    than 1.5 cm from before the tilt to 2 s after it. Friction measured in world coordinates read the common turn as
    a slip and pulled the upper slab back to where it had been in the world: it crept 3.6-4.6 cm; measured in the
    frame of the lower slab's particle, which turns with it, 0.1-0.4 cm (docs/contact.md, "Stacks", stop 47)."""
    v, t = _slab()
    lower, upper = _preset_body(v, t, 0.5, "Stiff", rate=rate), _preset_body(v, t, 0.71, "Stiff", rate=rate)
    rest, rotations = lower.positions.copy(), lower.rotations.copy()
    lower.set_goal_strength(1.0)
    lower.set_goals(rest, rotations)
    group = opdeform.ContactGroup([lower, upper], friction=1.0)
    group.step(2 * rate)
    before = upper.positions.mean(axis=0) - lower.positions.mean(axis=0)
    centre = rest.mean(axis=0)
    for k in range(1, 2 * rate + 1):
        angle = np.radians(degrees) * (0.5 - 0.5 * np.cos(np.pi * k / (2 * rate)))
        c, s = np.cos(angle), np.sin(angle)
        tilt = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
        tilt = tilt if axis == 0 else tilt[[1, 0, 2]][:, [1, 0, 2]]  # about x, or about y
        lower.set_goals((rest - centre) @ tilt.T + centre, tilt @ rotations)
        group.step()
    group.step(2 * rate)
    turn = _turn_of(lower.positions, rest)
    assert abs(np.degrees(np.arccos((np.trace(turn) - 1.0) / 2.0)) - abs(degrees)) < 0.5  # the lower slab tilted
    after = turn.T @ (upper.positions.mean(axis=0) - lower.positions.mean(axis=0))
    assert after[2] > 0.15 and np.linalg.norm(after - before) < 0.015, (before, after)
