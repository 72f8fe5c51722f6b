"""opdeform.Skin: Sumner weights of the nearest particles, exact rest and rigid poses, normals, float32 and
flat outputs, threads that do not change a bit, and constraints on mesh vertices."""

import numpy as np
import pytest

import opdeform
from opdeform import meshes


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


@pytest.fixture(scope="module")
def creature():
    v, t = meshes.creature()
    g = opdeform.Graph.from_mesh(v, t, particles=100)
    return v, t, g


def rest_state(g):
    return g.centers, np.tile(np.eye(3), (g.n_particles, 1, 1))


def test_rest_state_gives_the_rest_mesh(creature):
    v, t, g = creature
    skin = opdeform.Skin(g, v)
    out = skin.deform(*rest_state(g))
    assert out.dtype == np.float64 and out.shape == v.shape
    np.testing.assert_allclose(out, v, rtol=0, atol=1e-14)
    out32 = skin.deform(*rest_state(g), out=np.empty(3 * len(v), np.float32))  # flat, like foreach_set
    np.testing.assert_array_equal(out32.reshape(-1, 3), v.astype(np.float32))


def test_rigid_motion_moves_the_mesh_rigidly(creature):
    v, t, g = creature
    skin = opdeform.Skin(g, v, triangles=t)
    r = rotation([1.0, 2.0, 0.5], 0.9)
    shift = np.array([0.3, -2.0, 1.5])
    positions = g.centers @ r.T + shift
    normals = np.empty((len(v), 3), np.float32)
    out = skin.deform(positions, np.tile(r, (g.n_particles, 1, 1)), normals_out=normals)
    np.testing.assert_allclose(out, v @ r.T + shift, rtol=0, atol=1e-13)
    np.testing.assert_allclose(normals, skin.rest_normals @ r.T, rtol=0, atol=1e-6)


def test_weights_are_sumner_weights_of_the_nearest_particles(creature):
    v, t, g = creature
    skin = opdeform.Skin(g, v, neighbors=4)
    idx, w = skin.indices, skin.weights
    assert idx.shape == (len(v), 4) and idx.dtype == np.int32 and w.dtype == np.float64
    assert np.all(w >= 0)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=0, atol=1e-14)
    d = np.linalg.norm(v[:, None, :] - g.centers[None], axis=2)
    order = np.argsort(d, axis=1, kind="stable")
    np.testing.assert_array_equal(idx, order[:, :4])  # the four nearest, nearest first
    dmax = np.take_along_axis(d, order[:, 4:5], axis=1)
    expected = (1 - np.take_along_axis(d, order[:, :4], axis=1) / dmax) ** 2
    np.testing.assert_allclose(w, expected / expected.sum(axis=1, keepdims=True), rtol=1e-12)
    for k in range(0, len(v), 97):  # the same weights as the constraints get, bit for bit
        ci, cw = g.skin_weights(v[k], 4)
        assert np.array_equal(ci, idx[k]) and cw.tobytes() == w[k].tobytes()


def test_normals_only_when_asked_and_from_the_given_rest_normals(creature):
    v, t, g = creature
    skin = opdeform.Skin(g, v)
    assert skin.rest_normals is None
    with pytest.raises(ValueError, match="rest normals"):
        skin.deform(*rest_state(g), normals_out=np.empty((len(v), 3)))
    given = np.tile(np.array([0.0, 0.0, 1.0], np.float32), (len(v), 1))
    r = rotation([0, 1, 0], 0.5)
    normals = np.empty((len(v), 3))
    skin.deform(g.centers, np.tile(r, (g.n_particles, 1, 1)), normals_out=normals, rest_normals=given)
    np.testing.assert_allclose(normals, np.tile(r[:, 2], (len(v), 1)), atol=1e-12)


def test_rest_normals_from_triangles_point_outwards():
    v, t = meshes.capsule(radius=0.1, length=1.0)
    g = opdeform.Graph.from_mesh(v, t, particles=20)
    n = opdeform.Skin(g, v, triangles=t).rest_normals
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    medial = np.clip(v[:, 0], -0.5, 0.5)[:, None] * [1, 0, 0]
    assert np.all(np.einsum("ij,ij->i", n, v - medial) > 0)


def test_deform_sim_matches_the_simulations_own_skinning(creature):
    v, t, g = creature
    sim = opdeform.Simulation(g, 2e5)
    sim.set_state(g.centers + [0, 0, 0.4], np.tile(np.eye(3), (g.n_particles, 1, 1)))
    sim.set_floor(0.0, 0.5)
    sim.step(40)
    skin = opdeform.Skin(g, v)
    out = skin.deform_sim(sim, push_out=False)
    np.testing.assert_allclose(out, sim.skin_points(v), rtol=0, atol=1e-12)


def test_threads_do_not_change_a_bit():
    v, t = meshes.subdivide(*meshes.creature(64), levels=2)  # over 32768 vertices: the threaded path
    assert len(v) > 40000
    g = opdeform.Graph.from_mesh(v, t, particles=150)
    one, every = opdeform.Skin(g, v, triangles=t, threads=1), opdeform.Skin(g, v, triangles=t, threads=0)
    assert one.indices.tobytes() == every.indices.tobytes() and one.weights.tobytes() == every.weights.tobytes()
    rng = np.random.default_rng(1)
    positions = g.centers + rng.normal(0, 0.02, g.centers.shape)
    rotations = np.array([rotation(rng.normal(size=3), rng.uniform(0, 0.5)) for _ in range(g.n_particles)])
    results = []
    for skin in (one, every):
        normals = np.empty((len(v), 3), np.float32)
        out = skin.deform(positions, rotations, normals_out=normals)
        results.append(out.tobytes() + normals.tobytes())
    assert results[0] == results[1]


def test_vertices_follow_only_their_own_piece():
    a_v, a_t = meshes.capsule(radius=0.1, length=1.0)
    b_v = a_v + [0.0, 0.25, 0.0]  # a second capsule close beside the first
    v = np.concatenate([a_v, b_v])
    t = np.concatenate([a_t, a_t + len(a_v)])
    g = opdeform.Graph.from_mesh(v, t, particles=30)
    count, piece = g.pieces()
    assert count == 2
    skin = opdeform.Skin(g, v, neighbors=6)
    own = piece[skin.indices[:, 0]]
    assert np.all(piece[skin.indices] == own[:, None])
    assert np.all(own[: len(a_v)] != own[len(a_v):].reshape(-1)[0])


def test_small_graphs_and_pieces_use_fewer_neighbors():
    v, t = meshes.bar(segments=4, cross=1)
    g = opdeform.Graph.from_mesh(v, t, particles=3, mode="chain")
    skin = opdeform.Skin(g, v, neighbors=8)
    assert skin.neighbors == 3
    np.testing.assert_allclose(skin.weights.sum(axis=1), 1.0)
    np.testing.assert_allclose(skin.deform(*rest_state(g)), v, atol=1e-14)


def test_bad_arguments(creature):
    v, t, g = creature
    skin = opdeform.Skin(g, v)
    n = g.n_particles
    pos, rot = rest_state(g)
    with pytest.raises(ValueError, match="neighbors"):
        opdeform.Skin(g, v, neighbors=0)
    with pytest.raises(ValueError, match="not finite"):
        opdeform.Skin(g, np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match="refers to vertex"):
        opdeform.Skin(g, v, triangles=[[0, 1, len(v)]])
    with pytest.raises(ValueError, match="positions"):
        skin.deform(pos[:-1], rot)
    with pytest.raises(ValueError, match="rotations"):
        skin.deform(pos, rot[:, :2])
    with pytest.raises(ValueError, match="out"):
        skin.deform(pos, rot, out=np.empty((len(v), 3), np.int32))
    with pytest.raises(ValueError, match="out"):
        skin.deform(pos, rot, out=np.empty((3, len(v))))
    with pytest.raises(ValueError, match="out"):
        skin.deform(pos, rot, out=np.empty((len(v), 6))[:, ::2])
    with pytest.raises(TypeError):
        opdeform.Skin("not a graph", v)
    assert skin.n_vertices == len(v) and n == 100


# -- constraints on mesh vertices ----------------------------------------------------------------------------

def bar_sim():
    v, t = meshes.bar(segments=20, cross=2)
    g = opdeform.Graph.from_mesh(v, t, particles=20, mode="chain")
    return v, t, opdeform.Simulation(g, 1e8)


def test_pinned_end_holds_the_bar():
    v, t, sim = bar_sim()
    end = np.flatnonzero(v[:, 0] == 0.0)
    group = np.linspace(0.0, 1.0, len(end))  # a painted vertex group: the first vertex has weight 0
    ids = opdeform.pin_vertices(sim, v, end, weights=group)
    assert len(ids) == len(end) - 1 == sim.n_constraints and all(isinstance(i, int) for i in ids)
    sim.step(120)
    skin = opdeform.Skin(sim.graph, v)
    out = skin.deform_sim(sim)
    assert np.abs(out[end[1:]] - v[end[1:]]).max() < 2e-3  # held
    tip = np.flatnonzero(v[:, 0] == 2.0)
    assert out[tip, 2].mean() < -1e-3  # the free end sags


def test_pin_vertices_checks_its_arguments():
    v, t, sim = bar_sim()
    with pytest.raises(ValueError, match="out of range"):
        opdeform.pin_vertices(sim, v, [0, len(v)])
    with pytest.raises(ValueError, match="weights"):
        opdeform.pin_vertices(sim, v, [0, 1], weights=[1.0, -1.0])
    with pytest.raises(ValueError, match="weights"):
        opdeform.pin_vertices(sim, v, [0, 1], weights=[1.0])
    ids = opdeform.pin_vertices(sim, v, [0, 1], weight=5.0)
    assert len(ids) == 2 and sim.n_constraints == 2


def test_vertex_direction_turns_the_end():
    v, t, sim = bar_sim()
    opdeform.pin_vertices(sim, v, np.flatnonzero(v[:, 0] == 0.0))
    tip = int(np.flatnonzero((v[:, 0] == 2.0) & (v[:, 1] == 0.0) & (v[:, 2] == 0.0))[0])
    cid = opdeform.add_vertex_direction(sim, v, tip, [0.0, 0.0, 1.0])
    target = rotation([1, 0, 0], 0.5) @ [0.0, 0.0, 1.0]
    sim.set_constraint_target(cid, target)
    sim.set_params(gravity=(0.0, 0.0, 0.0))
    sim.solve_static(300)
    idx, w = sim.graph.skin_weights(v[tip])
    turned = np.einsum("j,jab,b->a", w, sim.rotations[idx], [0.0, 0.0, 1.0])
    assert np.dot(turned / np.linalg.norm(turned), target) > 0.99
    with pytest.raises(ValueError, match="out of range"):
        opdeform.add_vertex_direction(sim, v, len(v), [0, 0, 1])


@pytest.mark.parametrize("neighbors", [4, 6, 5])
def test_the_baseline_blend_gives_the_same_mesh(neighbors):
    """x86-64: the AVX2 + FMA blend (where the processor has it) and the SSE2 one (OPDEFORM_NO_AVX2=1) agree to
    rounding, at the default 4 neighbours, the skin seams' 6 (docs/goals.md) and another; each is checked exactly against the rest
    and rigid poses above."""
    import os
    import subprocess
    import sys
    code = ("import numpy as np, opdeform, sys; from opdeform import meshes\n"
            "v, t = meshes.subdivide(*meshes.creature(64), levels=1)\n"
            "g = opdeform.Graph.from_mesh(v, t, particles=80)\n"
            "rng = np.random.default_rng(3)\n"
            "q, _ = np.linalg.qr(rng.normal(size=(g.n_particles, 3, 3)))\n"
            "q *= np.sign(np.linalg.det(q))[:, None, None]\n"
            "n = np.empty((len(v), 3))\n"
            f"out = opdeform.Skin(g, v, neighbors={neighbors}, triangles=t)"
            ".deform(g.centers + rng.normal(0, 0.05, g.centers.shape), q, normals_out=n)\n"
            "sys.stdout.buffer.write(out.tobytes() + n.tobytes())\n")
    runs = []
    for off in ("1", "0"):
        env = dict(os.environ, OPDEFORM_NO_AVX2=off)
        runs.append(np.frombuffer(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                                                 check=True).stdout).reshape(2, -1, 3))
    np.testing.assert_allclose(runs[1], runs[0], rtol=0, atol=1e-13)


def test_shown_offset_is_the_numpy_passes_bit_for_bit(creature):
    v, t, g = creature
    skin = opdeform.Skin(g, v)
    rng = np.random.default_rng(3)
    skinned, reference = v + rng.normal(0, 0.1, v.shape), v + rng.normal(0, 0.1, v.shape)
    lock = np.repeat(rng.uniform(0, 1, (len(v), 1)), 3, axis=1)
    incoming = (v + rng.normal(0, 1.0, v.shape)).astype(np.float32)
    for weights in (lock, None):
        offset, out = np.empty_like(incoming), np.empty_like(incoming)
        skin.shown_offset(skinned, reference, weights, incoming, offset, out)
        expected = (skinned - reference) * (1.0 if weights is None else weights)
        np.testing.assert_array_equal(offset, expected.astype(np.float32))
        np.testing.assert_array_equal(out, incoming + expected.astype(np.float32))
    with pytest.raises(ValueError, match="input"):  # a float64 input: numpy would add in float64
        skin.shown_offset(skinned, reference, lock, incoming.astype(np.float64), offset, out)
    with pytest.raises(ValueError, match="lock"):
        skin.shown_offset(skinned, reference, lock[:-1], incoming, offset, out)


def test_shown_offset_of_particle_frames_is_their_deform_then_the_offset_bit_for_bit():
    """The goals' skin made in the offset's pass (``shown_offset`` given particle frames) equals ``deform`` into a
    float64 array then ``shown_offset``, to the bit: with the AVX2 blend and without, one thread and the pool."""
    import os
    import subprocess
    import sys
    code = ("import sys, numpy as np, opdeform\n"
            "from opdeform import meshes\n"
            "v, t = meshes.subdivide(*meshes.subdivide(*meshes.creature()))\n"
            "g = opdeform.Graph.from_mesh(v, t, particles=150)\n"
            "rng = np.random.default_rng(5)\n"
            "q, _ = np.linalg.qr(rng.normal(size=(g.n_particles, 3, 3)))\n"
            "goals = (g.centers + rng.normal(0, 0.05, g.centers.shape), q * np.sign(np.linalg.det(q))[:, None, None])\n"
            "skinned = v + rng.normal(0, 0.1, v.shape)\n"
            "lock = np.repeat(rng.uniform(0, 1, (len(v), 1)), 3, axis=1)\n"
            "incoming = (v + rng.normal(0, 1.0, v.shape)).astype(np.float32)\n"
            "for threads in (1, 4):\n"
            "    skin = opdeform.Skin(g, v, threads=threads)\n"
            "    for weights in (lock, None):\n"
            "        fused, apart = np.empty((2, 2) + v.shape, np.float32)\n"
            "        skin.shown_offset(skinned, goals, weights, incoming, *fused)\n"
            "        skin.shown_offset(skinned, skin.deform(*goals), weights, incoming, *apart)\n"
            "        assert fused.tobytes() == apart.tobytes(), (threads, weights is None)\n"
            "print(len(v))\n")
    for off in ("1", "0"):
        env = dict(os.environ, OPDEFORM_NO_AVX2=off)
        run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        assert run.returncode == 0, run.stderr[-2000:]
        assert int(run.stdout) > 2 * 8192  # two deform chunks: the pool takes the vertices in pieces


def test_shown_offset_of_particle_frames_checks_them(creature):
    v, t, g = creature
    skin = opdeform.Skin(g, v)
    skinned, incoming = np.zeros(v.shape), np.zeros(v.shape, np.float32)
    offset, out = np.empty_like(incoming), np.empty_like(incoming)
    positions, rotations = rest_state(g)
    with pytest.raises(ValueError, match="rotations"):
        skin.shown_offset(skinned, (positions, rotations[:-1]), None, incoming, offset, out)
    with pytest.raises(ValueError, match="input"):
        skin.shown_offset(skinned, (positions, rotations), None, incoming.astype(np.float64), offset, out)
    skin.shown_offset(skinned, (positions, rotations), None, incoming, offset, out)
    np.testing.assert_array_equal(offset, (-skin.deform(positions, rotations)).astype(np.float32))
