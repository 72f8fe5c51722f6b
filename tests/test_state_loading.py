"""Loading a saved state is parsing untrusted input (issue 28): every count, id, index, size and float of a
pickled Simulation, Graph, Skin, GoalFit, ContactGroup or mpm.World is checked before anything is allocated or
written; a bad one raises a ValueError (or TypeError) naming it and leaves the object as it was. The bit-flip
test at the end damages real pickles at random: each load succeeds or raises, it never crashes."""

import os
import pickle
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

import opdeform
from opdeform import meshes, mpm

PARTICLE_ID = 31 * 8  # byte offset of od_MpmParticle.id (after 31 doubles), then the int32 material


# -- mpm.World ------------------------------------------------------------------------------------------------
def snow_world():
    world = mpm.World((0, 0, 0), (1, 1, 1), 1 / 32, threads=1)
    world.add_floor(0.1)
    world.add_particles(mpm.fill_box((0.3, 0.3, 0.3), (0.5, 0.5, 0.5), 0.05), orientations=None)
    world.add_particles(mpm.fill_box((0.6, 0.6, 0.3), (0.7, 0.7, 0.4), 0.05), material=mpm.jelly())
    world.step(1 / 60)
    return world


def particle_offset(blob, world, k):
    """Where particle k's record starts in the saved bytes (found by its position: the records are in block
    order, not id order)."""
    at = blob.find(world.positions[k].tobytes())
    assert at > 0
    return at


def patched(blob, offset, fmt, value):
    out = bytearray(blob)
    struct.pack_into(fmt, out, offset, value)
    return bytes(out)


FIELDS = ("positions", "velocities", "orientations", "rotations", "deformation", "affine", "plastic_j")


def fields(world):
    return [world.read(name) for name in FIELDS]


@pytest.mark.parametrize("value, message", [(10**6, "id"), (None, "id"), (-1, "id")])
def test_mpm_particle_id_out_of_range_is_refused(value, message):
    world = snow_world()
    blob = world._core.save_state()
    n = world.n_particles
    bad = patched(blob, particle_offset(blob, world, 0) + PARTICLE_ID, "<i", n + 40 if value is None else value)
    other = snow_world()
    before = fields(other)
    with pytest.raises(ValueError, match=message):
        other._core.load_state(bad)
    for a, b in zip(before, fields(other)):
        np.testing.assert_array_equal(a, b)  # nothing changed
    other.step(1 / 60)


def test_mpm_duplicate_particle_id_is_refused():
    world = snow_world()
    blob = world._core.save_state()
    bad = patched(blob, particle_offset(blob, world, 0) + PARTICLE_ID, "<i", 1)
    with pytest.raises(ValueError, match="id 1 .*twice"):
        snow_world()._core.load_state(bad)


@pytest.mark.parametrize("value", [2, 99, -1, 2**31 - 1])
def test_mpm_particle_material_out_of_range_is_refused(value):
    world = snow_world()
    blob = world._core.save_state()
    bad = patched(blob, particle_offset(blob, world, 3) + PARTICLE_ID + 4, "<i", value)
    with pytest.raises(ValueError, match="material"):
        snow_world()._core.load_state(bad)


@pytest.mark.parametrize("field, value, message", [
    (0, 1e300, "outside"), (0, -5.0, "outside"), (0, float("nan"), "outside"), (3, float("inf"), "not finite"),
    (15 + 4, float("nan"), "not finite"), (30, 0.0, "plastic"), (30, -1.0, "plastic")])
def test_mpm_particle_values_are_checked(field, value, message):
    world = snow_world()
    blob = world._core.save_state()
    bad = patched(blob, particle_offset(blob, world, 5) + 8 * field, "<d", value)
    with pytest.raises(ValueError, match=message):
        snow_world()._core.load_state(bad)


def test_mpm_orientations_and_collider_frames_are_checked():
    world = snow_world()
    blob = world._core.save_state()
    quat = world.orientations[0].tobytes()
    at = blob.find(quat)
    with pytest.raises(ValueError, match="orientation"):
        snow_world()._core.load_state(patched(blob, at, "<d", 2.0))
    frame = np.eye(3).tobytes()  # the floor's rotation R0 is the identity, the last thing saved is its frames
    at = blob.rfind(frame)
    assert at > 0
    with pytest.raises(ValueError, match="collider"):
        snow_world()._core.load_state(patched(blob, at, "<d", 3.0))


def test_mpm_header_and_material_table_are_checked():
    world = snow_world()
    blob = world._core.save_state()
    start = blob.find(struct.pack("<i", world.n_particles))  # the header: count, materials, colliders, since
    assert start == 8
    for offset, value, message in [(12, 17, "material"), (12, -1, "material"), (20, -5, "reorder"),
                                   (20, 2**31 - 1, "reorder")]:
        with pytest.raises(ValueError, match=message):
            snow_world()._core.load_state(patched(blob, offset, "<i", value))
    density = struct.pack("<d", 600.0)  # the snow material's density, in the first slot
    at = blob.find(density)
    for value in (-600.0, float("nan"), 0.0, 1e300):
        with pytest.raises(ValueError, match="material"):
            snow_world()._core.load_state(patched(blob, at, "<d", value))


def test_mpm_good_state_loads_and_continues():
    world = snow_world()
    back = pickle.loads(pickle.dumps(world))
    for a, b in zip(fields(world), fields(back)):
        np.testing.assert_array_equal(a, b)
    world.step(1 / 60)
    back.step(1 / 60)
    np.testing.assert_array_equal(world.positions, back.positions)


def test_mpm_pickle_replays_only_the_model_calls():
    world = snow_world()
    saved = world.__getstate__()
    for calls in ([("__reduce_ex__", (2,))], [("step", (1.0,))], [("add_particles", ((0.5, 0.5, 0.5),))], [7],
                  "calls", [("__init__", "x")]):
        back = mpm.World.__new__(mpm.World)
        with pytest.raises((ValueError, TypeError), match="calls"):
            back.__setstate__(dict(saved, calls=calls))


# -- Simulation -----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def bar():
    v, t = meshes.bar(length=2.0)
    return v, t, opdeform.Graph.from_mesh(v, t, particles=30)


def rigged(v, graph):
    """Goals carrying the rest with their motion, damping and link softness per particle, a collider, a floor, a
    field, constraints with a removal: every part of a Simulation's pickle."""
    sim = opdeform.Simulation(graph, 1e6, dt=1 / 48, damping=0.01)
    sim.set_floor(-0.4, 0.5)
    pins = opdeform.pin_vertices(sim, v, np.flatnonzero(v[:, 0] < 1e-9))
    sim.remove_constraint(pins[1])
    sim.add_direction_constraint((2.0, 0.0, 0.0), (0, 0, 1))
    sim.add_collider("sphere", radius=0.2, translation=(1.0, 0.0, -0.5))
    sim.add_force_field("wind", strength=2.0)
    sim.set_goal_strength(0.5)
    sim.set_goals_carry_rest(True)
    sim.set_goals(graph.centers + (0.0, 0.0, 0.01))
    sim.step(2)
    sim.set_goals(graph.centers + (0.0, 0.0, 0.02))
    sim.set_particle_damping(np.linspace(0.0, 0.1, graph.n_particles))
    sim.set_link_softness(np.linspace(0.05, 1.0, graph.n_particles))
    sim.set_stretch_limit(1.2)
    sim.set_contact_skin(opdeform.Skin(graph, v))
    sim.step(3)
    return sim


def test_simulation_constraint_counts_are_refused_up_front(bar):
    v, _, graph = bar
    saved = rigged(v, graph).__getstate__()
    for change, message in [({"ids_before": 2**40}, "ids_before"), ({"ids_before": -1}, "ids_before"),
                            ({"ids_before": 1.5}, "ids_before"), ({"history": [2**40]}, "history"),
                            ({"history": list(range(2 * 10**6 + 1))}, "history"), ({"history": "abc"}, "history"),
                            ({"constraints": {2**40: [0, (0, 0, 0), None, 1.0]}}, "constraints"),
                            ({"targets": {5: (0, 0, 0), 2**35: (0, 0, 0)}}, "targets"),
                            ({"collider_ids": 2**40}, "collider_ids"),
                            ({"colliders": {2**33: None}}, "colliders"),
                            ({"fields": [("__class__", ())]}, "fields"), ({"fields": [("step", (10**9,))]}, "fields")]:
        start = time.perf_counter()
        with pytest.raises((ValueError, TypeError), match=message):
            opdeform.Simulation.__new__(opdeform.Simulation).__setstate__(dict(saved, **change))
        assert time.perf_counter() - start < 1.0, change


def test_simulation_goal_motion_damping_link_softness_and_contact_skin_are_checked(bar):
    v, _, graph = bar
    saved = rigged(v, graph).__getstate__()
    velocities, angular, steps = saved["goal_motion"]
    n = graph.n_particles
    for motion, message in [((velocities, angular, -2), "steps"), ((velocities, angular, 2**40), "steps"),
                            ((velocities[:3], angular, steps), "velocities"),
                            ((np.full((n, 3), np.nan), angular, steps), "goal velocities"),
                            ((velocities, angular), "goal_motion")]:
        with pytest.raises((ValueError, TypeError), match=message):
            opdeform.Simulation.__new__(opdeform.Simulation).__setstate__(dict(saved, goal_motion=motion))
    for damping in (np.full(n, 2.0), np.full(n, np.nan), np.zeros(n + 1)):
        with pytest.raises(ValueError, match="damping"):
            opdeform.Simulation.__new__(opdeform.Simulation).__setstate__(dict(saved, particle_damping=damping))
    for softness in (np.zeros(n), np.full(n, np.nan), np.ones(n + 1)):
        with pytest.raises(ValueError, match="softness"):
            opdeform.Simulation.__new__(opdeform.Simulation).__setstate__(dict(saved, link_softness=softness))
    for bound, message in [((0.5, None), "stretch limit"), ((np.nan, None), "stretch limit"),
                           ((1.2, np.ones(3)), "gradient"), ((1.2, np.full(len(graph.edges), -1.0)), "gradient")]:
        with pytest.raises(ValueError, match=message):
            opdeform.Simulation.__new__(opdeform.Simulation).__setstate__(dict(saved, stretch_bound=bound))
    rest, indices, weights, bodies = saved["contact_skin"]
    for skin, message in [((rest, indices), "contact_skin"), ((rest, indices[:3], weights, bodies), "indices"),
                          ((rest, indices, weights[:, :1], bodies), "weights"),
                          ((rest, indices + n, weights, bodies), "out of range")]:
        with pytest.raises(ValueError, match=message):
            opdeform.Simulation.__new__(opdeform.Simulation).__setstate__(dict(saved, contact_skin=skin))


def test_simulation_pickle_continues_to_the_same_bits(bar):
    v, _, graph = bar
    sim = rigged(v, graph)
    back = pickle.loads(pickle.dumps(sim))
    sim.step(5)
    back.step(5)
    np.testing.assert_array_equal(sim.positions, back.positions)


# -- ContactGroup ---------------------------------------------------------------------------------------------
def touching_group(graph):
    a, b = opdeform.Simulation(graph, 1e6), opdeform.Simulation(graph, 1e6)
    b.set_state(graph.centers + (0.0, 0.0, 0.03), np.tile(np.eye(3), (graph.n_particles, 1, 1)))
    group = opdeform.ContactGroup([a, b], thickness=0.05)
    group.step(2)
    return group


def test_contact_group_pairs_are_not_wrapped_to_int32(bar):
    group = touching_group(bar[2])
    pairs, forces = group.save_state()
    assert len(pairs) > 0
    before = group.save_state()
    for wrapped in (pairs.astype(np.int64) + 2**32, pairs.astype(np.int64) - 2**32, pairs.astype(np.float64) + 0.5):
        with pytest.raises(ValueError, match="pairs"):
            group.restore_state((wrapped, forces))
    after = group.save_state()
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])


@pytest.mark.parametrize("column, value, message", [(0, 1e300, "force"), (1, -1e300, "force"), (4, 5.0, "normal"),
                                                     (5, 0.0, "normal"), (7, 1e308, "anchor"), (9, -2e3, "anchor")])
def test_contact_group_forces_out_of_range_are_refused(bar, column, value, message):
    group = touching_group(bar[2])
    pairs, forces = group.save_state()
    bad = forces.copy()
    bad[0, column] = value
    if 4 <= column < 7:
        bad[0, 4:7] = (value, 0.0, 0.0)
    with pytest.raises(ValueError, match=message):
        group.restore_state((pairs, bad))
    group.restore_state((pairs, forces))
    group.step(1)


# -- GoalFit --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("scale", [1e300, 1e200, 1e-300])
def test_goal_fit_of_huge_or_tiny_coordinates_gives_frames(bar, scale):
    """Before: NaN frames at 1e300 and 1e200, silently (the covariance's products overflowed)."""
    v, _, graph = bar
    fit = opdeform.GoalFit(graph, v)
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    positions, rotations = fit.fit(v @ turn.T * scale)
    assert np.all(np.isfinite(positions)) and np.all(np.isfinite(rotations))
    np.testing.assert_allclose(rotations, np.broadcast_to(turn, rotations.shape), atol=1e-9)


def test_goal_fit_that_overflows_is_refused(bar):
    v, _, graph = bar
    fit = opdeform.GoalFit(graph, v)
    for animated in (np.where(v > 0.5 * v.max(axis=0), 1.5e308, -1.5e308), v * np.inf):
        with pytest.raises(ValueError, match="animated"):
            fit.fit(animated)


def test_goal_fit_names_a_vertex_it_reads_that_is_not_finite_before_an_overflow(bar):
    """The vertices are checked where a particle's centroid is not finite: the message is that of a check before
    the fit (the first vertex read, in the particles' order), also where an earlier particle overflows; a vertex
    no particle reads is never looked at."""
    v, _, graph = bar
    fit = opdeform.GoalFit(graph, v)
    order = fit.indices.reshape(-1)
    for animated in (v.copy(), np.where(v > 0.5 * v.max(axis=0), 1.5e308, -1.5e308)):
        animated[order[-1]] = np.nan
        with pytest.raises(ValueError, match=rf"animated vertices\[{order[-1]}\] is not finite"):
            fit.fit(animated)
    unread = np.setdiff1d(np.arange(len(v)), order)
    if len(unread):
        animated = v.copy()
        animated[unread] = np.nan
        assert np.all(np.isfinite(fit.fit(animated)[0]))


@pytest.mark.parametrize("scale", [1e-185, 1e-300])
def test_goal_fit_of_a_tiny_flat_rest_mesh_binds(bar, scale):
    """Found by fuzz_goal_fit: the search grid's cell underflowed to 0 (NaN cast to int under UBSan; here a
    MemoryError "out of memory for a search grid over 170 points")."""
    v, _, graph = bar
    flat = v.copy()
    flat[:, 2] = 0.0
    fit = opdeform.GoalFit(graph, flat * scale)
    assert fit.indices.min() >= 0 and fit.indices.max() < len(v)
    np.testing.assert_allclose(fit.weights.sum(axis=1), 1.0, rtol=1e-12)


def test_goal_fit_of_a_rest_mesh_spanning_more_than_the_doubles_is_refused(bar):
    """Found by fuzz_goal_fit's campaign: vertices at -1.5e308 and 1.5e308 (finite) span an infinite extent: NaN
    cell counts (UBSan, nearest.c)."""
    v, _, graph = bar
    far = v.copy()
    far[0], far[1] = -1.5e308, 1.5e308
    with pytest.raises(ValueError, match="span"):
        opdeform.GoalFit(graph, far)


# -- bit flips over real pickles ------------------------------------------------------------------------------
FLIPS = 100 if os.environ.get("OPDEFORM_SANITIZED") else 400  # per object


def real_pickles():
    """A pickle of every kind of saved object, each with all of its parts."""
    v, t = meshes.bar(length=2.0)
    graph = opdeform.Graph.from_mesh(v, t, particles=30)
    plain = opdeform.Graph(graph.centers, graph.radii, graph.edges, graph.axes)
    group = touching_group(graph)
    world = snow_world()
    world.set_wind("noise", velocity=(0.5, 0.0, 0.0))
    world.add_collider("sphere", radius=0.1, translation=(0.5, 0.5, 0.8))
    world.step(1 / 60)
    objects = {"simulation": rigged(v, graph), "graph": graph, "plain graph": plain,
               "skin": opdeform.Skin(graph, v), "goal fit": opdeform.GoalFit(graph, v),
               "contact group state": group.save_state(), "mpm world": world}
    return {name: pickle.dumps(obj) for name, obj in objects.items()}, group


def load(name, blob, group):
    obj = pickle.loads(blob)
    if name == "contact group state":
        group.restore_state(obj)
        group.step(1)
    elif name == "simulation":
        obj.step(1)
    elif name == "mpm world":
        obj.step(1 / 240)
        obj.read("rotations")


def flip_all(seed=28):
    """Flips 1 to 8 random bits of each pickle FLIPS times; every load ends in success or an exception. Prints
    one line per object: loads, successes and the exception types seen."""
    blobs, group = real_pickles()
    rng = np.random.default_rng(seed)
    for name, blob in blobs.items():
        ok, errors = 0, {}
        for _ in range(FLIPS):
            damaged = bytearray(blob)
            for bit in rng.integers(0, 8 * len(blob), rng.integers(1, 9)):
                damaged[bit // 8] ^= 1 << (bit % 8)
            try:
                load(name, bytes(damaged), group)
                ok += 1
            except Exception as e:  # noqa: BLE001 - any clean exception is the point
                errors[type(e).__name__] = errors.get(type(e).__name__, 0) + 1
        print(f"{name}: {FLIPS} loads, {ok} loaded, {sorted(errors.items())}", flush=True)


def test_bit_flips_never_crash():
    start = time.perf_counter()
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if "ASAN_OPTIONS" in env:  # a flipped pickle length asks for 2^60 bytes: NULL and MemoryError, as without ASan
        env["ASAN_OPTIONS"] += ":allocator_may_return_null=1"
    out = subprocess.run([sys.executable, __file__, "flips"], capture_output=True, text=True, timeout=300, env=env)
    assert out.returncode == 0, f"exit {out.returncode}\n{out.stdout[-3000:]}\n{out.stderr[-3000:]}"
    lines = out.stdout.strip().splitlines()
    assert len(lines) == 7 and all(f"{FLIPS} loads" in line for line in lines), out.stdout
    print(f"{time.perf_counter() - start:.1f} s\n" + out.stdout)


if __name__ == "__main__" and sys.argv[1:] == ["flips"]:
    flip_all()
