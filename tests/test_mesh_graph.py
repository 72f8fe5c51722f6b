"""Graph.from_mesh: graphs that cover the procedural bodies, per piece and per mode, deterministic, usable
by the solver, and clear errors on bad meshes."""

import numpy as np
import pytest

import opdeform
from opdeform import meshes


def nearest_distance(points, centers):
    return np.sqrt(((points[:, None, :] - centers[None]) ** 2).sum(-1)).min(axis=1)


def area(vertices, triangles):
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()


def volume(vertices, triangles):
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def check_graph(g, n):
    """A graph the solver can use: n particles, radii > 0, proper frames, no duplicate or self edges."""
    assert g.n_particles == n
    assert np.all(g.radii > 0) and np.all(np.isfinite(g.centers))
    axes = g.axes
    np.testing.assert_allclose(axes @ axes.transpose(0, 2, 1), np.broadcast_to(np.eye(3), axes.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(axes), 1.0, atol=1e-12)
    e = g.edges
    assert np.all(e[:, 0] != e[:, 1])
    assert len(np.unique(np.sort(e, axis=1), axis=0)) == len(e)


# (name, mesh, particles, mode, measure of the body, dimension): spacing = (measure / particles)^(1/dimension)
BODIES = [
    ("bar", meshes.bar, 20, "chain", 0.08, 3),
    ("bar", meshes.bar, 20, "auto", 0.08, 3),
    ("capsule", meshes.capsule, 30, "auto", None, 3),
    ("capsule", meshes.capsule, 30, "surface", None, 2),
    ("capsule", meshes.capsule, 30, "volume", None, 3),
    ("sheet", meshes.sheet, 30, "auto", None, 2),
    ("strand", meshes.strand, 10, "auto", 1.0, 1),
    ("strand", lambda: meshes.strand(sag=0.2), 10, "chain", 1.0, 1),
    ("creature", meshes.creature, 100, "auto", None, 3),
]


@pytest.mark.parametrize("name,make,n,mode,measure,dim", BODIES, ids=[f"{b[0]}-{b[3]}" for b in BODIES])
def test_bodies_are_covered_and_connected(name, make, n, mode, measure, dim):
    v, t = make()
    g = opdeform.Graph.from_mesh(v, t, particles=n, mode=mode)
    check_graph(g, n)
    assert g.pieces()[0] == 1
    if measure is None:
        measure = volume(v, t) if dim == 3 else area(v, t)
    spacing = (measure / n) ** (1.0 / dim)
    assert nearest_distance(v, g.centers).max() < 1.5 * spacing


def test_chain_on_the_bar_is_the_papers_chain():
    v, t = meshes.bar(segments=20)
    g = opdeform.Graph.from_mesh(v, t, particles=20, mode="chain")
    assert g.n_particles == 20 and g.n_edges == 19
    e = g.edges
    np.testing.assert_array_equal(np.sort(e, axis=1), np.stack([np.arange(19), np.arange(1, 20)], 1))
    c = g.centers
    assert np.all(np.abs(c[:, 1:]) < 1e-9)  # on the bar's axis
    steps = np.diff(c[:, 0])
    assert np.all(steps > 0) or np.all(steps < 0)  # in order along it
    assert abs(np.abs(steps).mean() - 0.1) < 0.01  # one particle per tenth of the 2 m bar


def test_long_thin_parts_get_long_thin_ellipsoids():
    v, t = meshes.strand(length=1.0, width=0.02, segments=60)
    g = opdeform.Graph.from_mesh(v, t, particles=10)
    r = g.radii
    assert np.all(r[:, 0] > 4 * r[:, 2])
    long_axis = g.axes[:, :, 0]
    assert np.all(np.abs(long_axis[:, 0]) > 0.99)  # along the strand (+x)
    assert g.n_edges == 9  # a strand gives a chain


def test_sheet_particles_lie_along_the_surface():
    v, t = meshes.sheet(size=(1.0, 1.0), resolution=(30, 30))
    g = opdeform.Graph.from_mesh(v, t, particles=49)
    assert np.abs(g.centers[:, 2]).max() < 0.02
    r = g.radii
    assert np.all(r[:, 2] < 0.4 * r[:, 1]) and np.median(r[:, 2] / r[:, 1]) < 0.3  # flat discs
    assert np.all(np.abs(g.axes[:, 2, 2]) > 0.99)  # their short axis is the sheet's normal


def test_volume_fills_and_surface_stays_on_the_shell():
    v, t = meshes.capsule(radius=0.2, length=0.6)
    depth = {}  # distance from the capsule's medial segment; the surface is at 0.2
    for mode in ("volume", "surface"):
        c = opdeform.Graph.from_mesh(v, t, particles=60, mode=mode).centers
        depth[mode] = np.linalg.norm(c - np.clip(c[:, 0], -0.3, 0.3)[:, None] * [1, 0, 0], axis=1)
    assert depth["volume"].mean() < 0.15  # particles through the inside
    assert depth["surface"].min() > 0.17  # a hollow shell: every particle near the surface
    # auto on a closed mesh is volume
    v_auto = opdeform.Graph.from_mesh(v, t, particles=60, mode="auto")
    np.testing.assert_array_equal(v_auto.centers, opdeform.Graph.from_mesh(v, t, particles=60, mode="volume").centers)


def two_capsules():
    a_v, a_t = meshes.capsule(radius=0.1, length=1.0)
    b_v, b_t = meshes.capsule(radius=0.1, length=0.5)
    b_v = b_v + [0.0, 0.5, 0.0]
    return np.concatenate([a_v, b_v]), np.concatenate([a_t, b_t + len(a_v)])


def test_pieces_stay_separate_unless_joined():
    v, t = two_capsules()
    g = opdeform.Graph.from_mesh(v, t, particles=40)
    count, piece = g.pieces()
    assert count == 2
    sizes = np.bincount(piece)
    assert sizes.sum() == 40 and sizes[0] > sizes[1] > 5  # in proportion to the pieces' size
    joined = opdeform.Graph.from_mesh(v, t, particles=40, join_pieces=True)
    assert joined.pieces()[0] == 1
    check_graph(joined, 40)


def test_joined_pieces_far_apart_or_overlapping():
    """Far apart: each keeps its own voxel grid and they are linked by edges; crossing: one solid."""
    a_v, a_t = meshes.capsule(radius=0.05, length=0.5)
    for shift, crossing in (([100.0, 0.0, 0.0], False), ([0.0, 0.0, 0.0], True)):
        b_v = a_v @ np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]) + shift  # turned 90 degrees
        v, t = np.concatenate([a_v, b_v]), np.concatenate([a_t, a_t + len(a_v)])
        g = opdeform.Graph.from_mesh(v, t, particles=20, join_pieces=True)
        check_graph(g, 20)
        assert g.pieces()[0] == 1
        if crossing:  # a particle where the two capsules cross, and more than one edge around it
            middle = np.argmin(np.linalg.norm(g.centers, axis=1))
            assert np.linalg.norm(g.centers[middle]) < 0.05 and np.sum(g.edges == middle) >= 3


def test_duplicate_vertices_and_degenerate_triangles():
    v, t = meshes.capsule()
    reference = opdeform.Graph.from_mesh(v, t, particles=30)
    # A triangle soup: every triangle has its own three vertices (split normals, UV seams).
    soup_v, soup_t = v[t.reshape(-1)], np.arange(3 * len(t), dtype=np.int32).reshape(-1, 3)
    soup = opdeform.Graph.from_mesh(soup_v, soup_t, particles=30)
    assert soup.pieces()[0] == 1
    for name in ("centers", "radii", "axes", "edges"):
        np.testing.assert_array_equal(getattr(soup, name), getattr(reference, name))
    # Zero-area triangles (a repeated vertex, three collinear vertices) and an unused vertex.
    extra_v = np.concatenate([v, [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.05, 0.0, 0.0], [9.0, 9.0, 9.0]]])
    k = len(v)
    extra_t = np.concatenate([t, [[0, 0, 1], [k, k + 1, k + 2], [3, 3, 3]]])
    g = opdeform.Graph.from_mesh(extra_v, extra_t, particles=30)
    check_graph(g, 30)
    assert g.pieces()[0] == 2  # the collinear triangle inside the capsule is a piece of its own


def test_same_mesh_same_graph_bit_for_bit():
    v, t = meshes.creature()
    a = opdeform.Graph.from_mesh(v, t, particles=80)
    b = opdeform.Graph.from_mesh(v.copy(), t.copy(), particles=80)
    for name in ("centers", "radii", "axes", "edges"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes()


def test_graph_runs_in_the_simulation():
    v, t = meshes.creature()
    g = opdeform.Graph.from_mesh(v, t, particles=60)
    sim = opdeform.Simulation(g, 2e5)
    sim.set_state(g.centers + [0.0, 0.0, 0.3], np.tile(np.eye(3), (60, 1, 1)))
    sim.set_floor(0.0, 0.5)
    sim.step(60)
    assert np.all(np.isfinite(sim.positions))
    assert sim.positions[:, 2].min() > -0.05  # on the floor, not through it


@pytest.mark.parametrize("mode", ["auto", "volume", "surface", "chain"])
def test_a_users_obj_builds(tmp_path, mode):
    v, t = meshes.creature()
    path = tmp_path / "creature.obj"
    opdeform.io.write_obj(path, v, t)
    rv, rt = opdeform.io.read_obj(path)
    g = opdeform.Graph.from_mesh(rv, rt, particles=50, mode=mode)
    check_graph(g, 50)
    assert g.pieces()[0] == 1


@pytest.mark.parametrize("vertices,triangles,kwargs,message", [
    (np.zeros((0, 3)), np.zeros((0, 3), int), {}, "empty"),
    (np.eye(3), np.zeros((0, 3), int), {"particles": 1}, "empty"),
    (np.eye(3), [[0, 1, 3]], {"particles": 1}, "refers to vertex 3"),
    (np.eye(3), [[0, -1, 2]], {"particles": 1}, "refers to vertex -1"),
    ([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], [[0, 1, 2]], {"particles": 1}, r"vertices\[2\] is not finite"),
    (np.eye(3), [[0, 1, 2]], {"particles": 4}, "only 3 distinct vertices"),
    (np.eye(3), [[0, 1, 2]], {"particles": 0}, "particles"),
    (np.eye(3), [[0, 1, 2]], {"particles": 1, "mode": "blob"}, "mode"),
    (np.eye(3)[:, :2], [[0, 1, 2]], {"particles": 1}, "vertices must have shape"),
])
def test_bad_meshes_are_value_errors(vertices, triangles, kwargs, message):
    with pytest.raises(ValueError, match=message):
        opdeform.Graph.from_mesh(vertices, triangles, **kwargs)


def test_fewer_vertices_than_particles_counts_distinct_vertices():
    v, t = meshes.bar(segments=2, cross=1)  # 16 distinct corners and edge points
    soup_v = v[t.reshape(-1)]
    soup_t = np.arange(len(soup_v), dtype=np.int32).reshape(-1, 3)
    with pytest.raises(ValueError, match=f"only {len(v)} distinct vertices"):
        opdeform.Graph.from_mesh(soup_v, soup_t, particles=len(v) + 1)


def test_more_pieces_than_particles():
    """The largest pieces get a particle each; the vertices of the others follow their nearest particle."""
    v, t = [], []
    for i in range(5):
        pv, pt = meshes.capsule(radius=0.05 + 0.01 * i, length=0.3)
        t.append(pt + sum(len(x) for x in v))
        v.append(pv + [0.0, 0.5 * i, 0.0])
    v, t = np.concatenate(v), np.concatenate(t)
    g = opdeform.Graph.from_mesh(v, t, particles=3)
    check_graph(g, 3)
    assert g.pieces()[0] == 3 and g.n_edges == 0
    assert np.all(g.centers[:, 1] > 0.9)  # on the three largest capsules (y = 1.0, 1.5, 2.0)
    skin = opdeform.Skin(g, v)
    np.testing.assert_allclose(skin.deform(g.centers, np.tile(np.eye(3), (3, 1, 1))), v, atol=1e-14)
