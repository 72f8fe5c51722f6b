"""Calibration for any body (issue 24): a plate, an L-shaped bracket and the character's tail droop alike at two
particle counts, and a body in separate pieces is calibrated piece by piece without an exception. The sweep over 50-400
particles and other bodies: scripts/bench calibration (docs/settings.md)."""
import numpy as np

import opdeform
from opdeform import materials, meshes

RUBBER = materials.PRESETS["Rubber"]


def droop(vertices, triangles, particles, held, tip, length, material=RUBBER):
    """Static drop of the tip vertices over ``length`` under ``material``, the held vertices pinned."""
    g = opdeform.Graph.from_mesh(vertices, triangles, particles=particles)
    sim = opdeform.Simulation(g, materials.stiffness_for(g, material.modulus), density=material.density)
    opdeform.pin_vertices(sim, vertices, np.flatnonzero(held))
    sim.set_solver("chebyshev")
    sim.solve_static(2000)
    return -float((sim.skin_points(vertices[tip])[:, 2] - vertices[tip, 2]).mean()) / length


def box(lo, hi, segments, cross):
    v, t = meshes.bar(length=1.0, width=1.0, segments=segments, cross=cross)
    return (v + [0.0, 0.5, 0.5]) * (np.asarray(hi) - lo) + lo, t


def test_a_plate_droops_alike_at_100_and_200_particles_and_as_beam_theory_says():
    """1 x 0.5 x 0.08 m, clamped at a short end: 14.8 and 14.9 % (before: 2.9 and 3.9 %, 1.35x, 0.2 of beam
    theory: the k of the plate's stiff in-plane bending)."""
    v, t = box((0.0, -0.25, -0.04), (1.0, 0.25, 0.04), 40, 20)
    d = [droop(v, t, n, v[:, 0] <= 1e-9, v[:, 0] >= 1.0 - 1e-9, 1.0) for n in (100, 200)]
    theory = 1.5 * RUBBER.density * 9.81 / (RUBBER.modulus * 0.08 ** 2)  # q L^4 / (8 E I), E at 1 m
    assert max(d) / min(d) < 1.15 and 0.8 < min(d) / theory and max(d) / theory < 1.2, (d, theory)


def bracket():
    """The L of scripts/bench calibration: surface nets of the union of two boxes."""
    def distance(p):
        boxes = []
        for lo, hi in (((0.0, -0.1, 0.0), (1.0, 0.1, 0.1)), ((0.8, -0.1, 0.0), (1.0, 0.6, 0.1))):
            q = np.abs(p - (np.add(lo, hi) / 2)) - np.subtract(hi, lo) / 2
            boxes.append(np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0))
        return np.minimum(*boxes)
    return meshes._closed_surface(distance, np.array([-0.05, -0.15, -0.05]), np.array([1.05, 0.65, 0.15]), 0.02)


def test_an_l_bracket_droops_alike_at_50_and_200_particles():
    """Arms of 1.0 and 0.6 m, section 0.2 x 0.1 m, lying flat, clamped at the long arm's end: each arm is
    calibrated as a body of its own (13.1 and 12.1 %; before, one bending k for the L: 18.8 and 13.3 %, 1.42x;
    over 50-400 particles 1.09x, was 1.68x)."""
    v, t = bracket()
    d = [droop(v, t, n, v[:, 0] <= v[:, 0].min() + 1e-3, v[:, 1] >= v[:, 1].max() - 0.02, 1.6) for n in (50, 200)]
    assert max(d) / min(d) < 1.15, d


def test_the_l_bracket_droops_alike_at_75_and_300_particles():
    """Its straight parts calibrated one by one, then levelled against the continuum frame (bending and the long
    arm's torsion): 14.6 and 15.4 % (before the levelling 12.3 and 14.5 %, 1.17x; over seven counts from 50 to
    400 particles 1.07x, was 1.26x: scripts/bench calibration)."""
    v, t = bracket()
    d = [droop(v, t, n, v[:, 0] <= v[:, 0].min() + 1e-3, v[:, 1] >= v[:, 1].max() - 0.02, 1.6) for n in (75, 300)]
    assert max(d) / min(d) < 1.1, d


def test_an_l_bracket_whose_straight_part_falls_apart_is_calibrated():
    """At 1.5 and 3 times its size and 200 particles the particles nearest the long arm's segment made two pieces,
    one held at neither end: stiffness_for raised solve_static's "no position constraint" (a traceback on Build
    in the add-on). Now the part's largest piece is calibrated, and the L droops as at its own size."""
    v, t = bracket()
    held, tip = v[:, 0] <= v[:, 0].min() + 1e-3, v[:, 1] >= v[:, 1].max() - 0.02
    d = [droop(v * s, t, 200, held, tip, 1.6 * s) for s in (1.0, 1.5, 3.0)]
    assert max(d) / min(d) < 1.1, d


def test_the_continuum_frame_bends_a_straight_bar_as_beam_theory_and_twists_an_l():
    """_frame_tip, the levelling's reference: a 1 x 0.2 x 0.1 m cantilever of cells within 2 % of q L^4 / 8 E I
    both ways across; an L of two such arms (0.8 and 0.6 m) deflects at its tip about twice what its arms' bending alone
    gives: the short arm's weight twists the long one."""
    h = 0.02
    axes = [np.arange(lo, hi, h) + h / 2 for lo, hi in ((0.0, 1.0), (-0.1, 0.1), (-0.05, 0.05))]
    cells = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    line = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]])
    tip = np.flatnonzero(cells[:, 0] >= 1.0 - h)
    area = 0.2 * 0.1
    for direction, second in (((0.0, 0.0, 1.0), 0.2 * 0.1 ** 3 / 12), ((0.0, 1.0, 0.0), 0.1 * 0.2 ** 3 / 12)):
        found = materials._frame_tip(cells, h, line, np.array(direction), tip)
        assert abs(found / (area / (8.0 * second)) - 1.0) < 0.02, (direction, found)
    long_arm = cells[cells[:, 0] < 0.8]
    short_arm = long_arm[long_arm[:, 0] < 0.6][:, [1, 0, 2]] + [0.7, 0.1, 0.0]  # x 0.6..0.8, y 0.1..0.7
    l_cells = np.concatenate([long_arm, short_arm])
    corners = np.array([[0.0, 0.0, 0.0], [0.7, 0.0, 0.0], [0.7, 0.7, 0.0]])
    tip = np.flatnonzero(l_cells[:, 1] >= l_cells[:, 1].max() - h)
    second = 0.2 * 0.1 ** 3 / 12
    # each arm's bending (E = 1, per unit weight): the short arm's q L^4 / 8 EI, the long arm's own and its end load's
    bending = area * (0.6 ** 4 / 8.0 + 0.7 ** 4 / 8.0 + 0.6 * 0.7 ** 3 / 3.0) / second
    found = materials._frame_tip(l_cells, h, corners, np.array([0.0, 0.0, 1.0]), tip)
    assert 1.3 * bending < found < 2.5 * bending, (found, bending)  # 2.02: the long arm twists


def test_a_levelling_against_no_continuum_compliance_leaves_the_k_as_it_was():
    g = opdeform.Graph([[0.0, 0, 0], [0.2, 0, 0], [0.4, 0, 0]], np.full((3, 3), 0.1), [[0, 1], [1, 2]])
    ratio = np.array([1.0, 2.0, 3.0])
    held, tip = g.centers[:1], g.centers[2:]
    for continuum in (0.0, np.nan):
        ends = [(held, tip, [(np.array([0.0, 0.0, 1.0]), continuum)])] * 2
        assert materials._levelled(g, ratio, np.array([0.0, 0.5, 1.0]), 0.4, ends, 1.0) is ratio


def test_the_characters_tail_droops_alike_at_75_and_150_particles():
    """Its k is fitted held as the body holds it (two rings of particles round its root free, the core's grid cells
    nearest the next ring held): its tip drops 9.0 and 8.9 mm (scripts/bench calibration: 1.20 and 1.18 % of its length;
    before, held at its root's neighbours: 1.28 and 1.76 %, 1.37x; over seven counts from 50 to 400 particles 1.10x,
    was 1.37x)."""
    v, t, held, tip = character_tail()
    d = [droop(v, t, n, held, tip, 1.0, materials.PRESETS["Jelly"]) for n in (75, 150)]
    assert max(d) / min(d) < 1.1, d


def test_the_skeleton_splits_the_bracket_at_its_corner_and_leaves_straight_bodies_whole():
    v, t = bracket()
    corners = materials._Grid(v, t, cells=materials._SKELETON_CELLS).skeleton()
    assert len(corners) == 3 and np.allclose(corners[1, :2], (0.9, 0.0), atol=0.02), corners
    for lo, hi in (((0.0, -0.25, -0.04), (1.0, 0.25, 0.04)), ((0.0, -0.1, -0.1), (2.0, 0.1, 0.1))):
        v, t = box(lo, hi, 40, 8)
        assert len(materials._Grid(v, t, cells=materials._SKELETON_CELLS).skeleton()) == 2


def character_tail():
    """meshes.character(), its torso (the middle 60 % of the body's capsule) held, and its tail's tip vertices."""
    v, t = meshes.character()
    near = {}
    for name, (a, b, ra, rb) in meshes.CHARACTER_PARTS.items():
        a, b = np.array(a), np.array(b)
        h = np.clip(((v - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
        near[name] = np.linalg.norm(v - (a + h[:, None] * (b - a)), axis=1) - (ra + (rb - ra) * h), h
    own = np.array(list(near))[np.argmin([d for d, _ in near.values()], axis=0)]
    held = (own == "body") & (near["body"][1] > 0.2) & (near["body"][1] < 0.8)
    tip = (own == "tail") & (near["tail"][1] >= 0.999)
    return v, t, held, tip


def test_the_characters_tail_droops_alike_at_50_and_200_particles():
    """meshes.character() held by its torso, Jelly: its tail (2 particles at 50) calibrated as a cantilever of its
    own cross-sections droops about 10 mm at its tip at both (before: 1.0 and 4.0 mm, one k for the body)."""
    v, t, held, tip = character_tail()
    d = [droop(v, t, n, held, tip, 1.0, materials.PRESETS["Jelly"]) for n in (50, 200)]
    assert 0.005 < min(d) and max(d) / min(d) < 1.15, d


def two_bars():
    """Two 1 x 0.1 m bars on one line, 0.3 m apart: one object of two pieces."""
    (a, ta), (b, tb) = (box((x, -0.05, -0.05), (x + 1.0, 0.05, 0.05), 40, 4) for x in (0.0, 1.3))
    return np.concatenate([a, b]), np.concatenate([ta, tb + len(a)]).astype(np.int32)


def test_a_body_in_two_pieces_is_calibrated_piece_by_piece():
    """Before, the measured calibration held the body's end faces, which missed one piece: solve_static raised
    "connected piece 0 of the graph has no position constraint". Each piece now droops as it does alone."""
    v, t = two_bars()
    g = opdeform.Graph.from_mesh(v, t, particles=60)
    count, label = g.pieces()
    k = materials.stiffness_for(g, RUBBER.modulus)
    assert count == 2 and k.shape == (60,) and np.all(np.isfinite(k) & (k > 0))
    sim = opdeform.Simulation(g, k, density=RUBBER.density)
    ends = np.flatnonzero(np.isin(np.round(v[:, 0], 9), (0.0, 1.3)))
    opdeform.pin_vertices(sim, v, ends)
    sim.set_solver("chebyshev")
    sim.solve_static(2000)
    tips = [np.flatnonzero(np.round(v[:, 0], 9) == x) for x in (1.0, 2.3)]
    d = [-(sim.skin_points(v[tip])[:, 2] - v[tip, 2]).mean() for tip in tips]
    assert 0.005 < min(d) and max(d) / min(d) < 1.15, d


def test_a_piece_with_no_edge_takes_the_other_pieces_mean_k():
    centers = [[0.0, 0, 0], [0.2, 0, 0], [0.4, 0, 0], [0.6, 0, 0], [3.0, 0, 0]]
    g = opdeform.Graph(centers, np.full((5, 3), 0.1), [[0, 1], [1, 2], [2, 3]])
    k = materials.stiffness_for(g, 1e6, calibration="bending")
    assert g.pieces()[0] == 2 and k.shape == (5,) and np.all(k > 0) and k[4] == k[:4].mean()


def test_a_closed_body_flatter_than_a_grid_cell_keeps_the_grid_small():
    """A closed capsule 1.2 x 0.2 m squashed to 20 um: the calibration's grid takes about its cells in columns
    (before: 2.9 million for 200,000 cells; squashed to 20 nm, 1.2 billion, and Build raised MemoryError:
    scripts/calibration_sweep.py), and the body is calibrated and checked."""
    v, t = meshes.capsule()
    v = v * [1.0, 1.0, 1e-4]
    grid = materials._Grid(v, t)
    assert grid.shape[0] * grid.shape[1] < 1.1 * materials._GRID_CELLS, grid.shape
    g = opdeform.Graph.from_mesh(v, t, particles=50)
    k = materials.stiffness_for(g, RUBBER.modulus)
    assert np.all(np.isfinite(k) & (k > 0)) and materials.thin_appendages(g, v, t) == []
