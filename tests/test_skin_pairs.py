"""The skin as the contact shape between the bodies of a ContactGroup (docs/contact.md, "Contact on the skin
between bodies", issue 27): in the scenes of scripts/skin_pairs.py, members given `set_contact_skin` keep each
other's skin out (no skin vertex deeper than 2 % of its body's size into the other when dropped and at rest and
head on at 10 m/s, 5 % at 20 m/s; head on, members on their ellipsoids too) and closer than their ellipsoids did; head on they keep their momentum and
gain no energy, dropped they gain none; a member's skin set and removed steps as one never given it, and a group
restored from its saved state and pickled members replays, bit for bit."""

import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

import opdeform

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))

import skin_pairs  # noqa: E402  (scripts/ on the path first)


def _momentum(members):
    return sum((m.sim.velocities * m.sim.graph.volumes[:, None] * m.sim.params["density"]).sum(axis=0)
               for m in members)


def _kinetic(members):
    return sum(0.5 * (m.sim.velocities ** 2 * m.sim.graph.volumes[:, None] * m.sim.params["density"]).sum()
               for m in members)


@pytest.mark.parametrize("body", ["blobs", "bars"])
def test_a_dropped_members_skin_stays_out_of_the_other(body):
    drop, rest, _ = skin_pairs.drop(body, "skin")
    assert drop < 0.02 and rest < 0.02, (drop, rest)
    if body == "bars":  # on top (the upper blob rolls off the lower one: the skin has no bumps to hold it)
        _, ellipsoids, _ = skin_pairs.drop(body, "ellipsoids")
        size = skin_pairs.Member(body, 0.0, "skin", True).size
        # the ellipsoids' overhang gone: the skins as far apart as the group's thickness (5 mm), within 2 mm
        assert -rest * size < 0.005 + 0.002 and ellipsoids < 1.5 * rest, (rest, ellipsoids)


@pytest.mark.parametrize("shape", ["ellipsoids", "skin"])
@pytest.mark.parametrize("body", ["blobs", "bars"])
@pytest.mark.parametrize("speed, bound", [(10.0, 0.02), (20.0, 0.05)])
def test_head_on_the_skins_stay_out_momentum_is_kept_and_no_energy_is_gained(body, speed, bound, shape):
    members, group = skin_pairs.pair(body, shape, False)
    moving = members[1].sim
    moving.set_state(moving.positions, moving.rotations, np.tile((0.0, 0.0, -speed), (moving.graph.n_particles, 1)))
    start, energy, deepest = _momentum(members), _kinetic(members), -np.inf
    for _ in range(round(skin_pairs.HEAD_ON_SECONDS / moving.params["dt"])):
        group.step()
        assert all(np.isfinite(m.sim.positions).all() for m in members)
        assert np.abs(_momentum(members) - start).max() < 1e-12 * np.abs(start).max()
        assert _kinetic(members) <= energy * (1.0 + 1e-9)
        deepest = max(deepest, skin_pairs.deepest(members))
    assert deepest < bound, deepest


def test_a_drop_on_the_skin_gains_no_energy():
    members, group = skin_pairs.pair("blobs", "skin", True)

    def energy():
        g = -members[0].sim.params["gravity"][2]
        return _kinetic(members) + sum(
            g * (m.sim.positions[:, 2] * m.sim.graph.volumes * m.sim.params["density"]).sum() for m in members)

    start = energy()
    for _ in range(48):
        group.step()
        assert energy() <= start + 1e-9 * abs(start)


def test_a_skin_set_and_removed_steps_as_none_bit_for_bit():
    runs = []
    for removed in (False, True):
        members, group = skin_pairs.pair("bars", "skin" if removed else "ellipsoids", True)
        for m in members if removed else ():
            m.sim.set_contact_skin(None)
        group.step(40)
        runs.append([m.sim.positions.copy() for m in members])
    assert all(np.array_equal(a, b) for a, b in zip(*runs))


def test_a_skin_kept_from_the_other_bodies_meets_them_with_its_ellipsoids_and_pickles():
    # bodies=False (the add-on's groups): between the bodies the steps are the ellipsoids', bit for bit (no
    # floor: there the skin meets it); a pickled member keeps the choice
    runs = []
    for shape in ("ellipsoids", "skin"):
        members, group = skin_pairs.pair("bars", "ellipsoids", False)
        members[1].sim.set_state(members[1].sim.positions, members[1].sim.rotations,
                                 np.tile((0.0, 0.0, -2.0), (members[1].sim.graph.n_particles, 1)))
        for m in members if shape == "skin" else ():
            m.sim.set_contact_skin(m.skin, bodies=False)
        if shape == "skin":
            group = opdeform.ContactGroup(pickle.loads(pickle.dumps([m.sim for m in members])), friction=0.5)
        lowest = group.sims[0].positions[:, 2].mean()
        group.step(40)
        runs.append([sim.positions.copy() for sim in group.sims])
    assert all(np.array_equal(a, b) for a, b in zip(*runs))
    assert runs[0][0][:, 2].mean() < lowest - 0.5  # the upper one (2 m/s down) pushed the lower one
    (lower, _), _ = skin_pairs.pair("bars", "ellipsoids", True)
    lower.sim.set_contact_skin(lower.skin, bodies=False)
    lower.sim.step(120)
    assert -1e-3 < lower.shown()[:, 2].min() < 0.005  # the skin on its floor (the ellipsoids': 1.1 cm above)


def test_a_member_with_a_skin_meets_one_without():
    members, group = skin_pairs.pair("bars", "ellipsoids", True)
    members[1].sim.set_contact_skin(members[1].skin)
    group.step(120)
    assert skin_pairs.deepest(members) < 0.02
    assert members[1].sim.positions[:, 2].mean() > members[0].sim.positions[:, 2].mean() + 0.2


def test_a_group_on_skins_restored_replays_bit_for_bit():
    members, group = skin_pairs.pair("bars", "skin", True)
    group.step(40)  # the upper bar on the lower one
    saved, sims = group.save_state(), pickle.dumps([m.sim for m in members])
    group.step(5)
    again = opdeform.ContactGroup(pickle.loads(sims))
    again.restore_state(saved)
    again.step(5)
    assert all(np.array_equal(m.sim.positions, sim.positions) for m, sim in zip(members, again.sims))
