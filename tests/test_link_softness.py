"""A softness per link (Simulation.set_link_softness; docs/goals.md, "An outside knight"): each link (i, j) is
weighted min(r_i, r_j) on both of its halves, where a stiffness scale s_i weighs only particle i's half of each.
All 1 is the same bits as never set; one softness for all is that stiffness scale; the energy is the dense
reference's; every local and global step lowers it; a link's compliance goes as one over its weight, where a
particle's scale leaves its links half stiff; bad input raises naming the entry; a pickle keeps it."""
import pickle

import numpy as np
import pytest

import opdeform
from opdeform import scenes
from test_core import assert_descends, lattice_graph

K = 1e11  # the Fig. 1 bar 100 times stiffer than the paper's: a sag of 1.1 mm, well inside the linear range


def pinned_bar(k=scenes.BAR_STIFFNESS):
    """The Fig. 1 bar with its pins' weight fixed (not k's), so that k alone scales the elastic energy."""
    sim = opdeform.Simulation(scenes.bar_graph(), k)
    for p in scenes.end_face_points(0.0):
        sim.add_position_constraint(p, weight=1e3 * scenes.BAR_STIFFNESS * sim.graph.volumes.mean())
    return sim


def one_particle(n, p, value):
    out = np.ones(n)
    out[p] = value
    return out


def test_softness_of_ones_is_the_same_bits_and_of_one_value_is_that_stiffness_scale():
    plain, ones, soft, scaled = pinned_bar(), pinned_bar(), pinned_bar(), pinned_bar()
    n = plain.graph.n_particles
    ones.set_link_softness(np.ones(n))
    soft.set_link_softness(np.full(n, 0.3))
    scaled.set_stiffness_scale(np.full(n, 0.3))
    for sim in (plain, ones, soft, scaled):
        sim.step(10)
    assert np.array_equal(plain.positions, ones.positions) and np.array_equal(plain.rotations, ones.rotations)
    assert np.abs(soft.positions - scaled.positions).max() < 1e-12
    assert np.abs(soft.rotations - scaled.rotations).max() < 1e-12
    assert soft.energy() == pytest.approx(scaled.energy(), rel=1e-12)
    assert np.abs(soft.positions - plain.positions).max() > 1e-3  # 0.3 of the stiffness moves the bar
    assert soft.link_softness.tolist() == [0.3] * n and plain.link_softness is None
    soft.set_link_softness(None)
    assert soft.link_softness is None


def dense_elastic_energy(sim, scale, softness):
    """k/2 Σ over directed edges (i, j) of s_j min(r_i, r_j) [tr((R_i - R_j) Ā_j (R_i - R_j)ᵀ)
    + v_j |R_i (X̄_j - X̄_i) - (x_j - x_i)|²] (METHOD.md eq. 3), Ā = Ē 0.2 v diag(radii²) Ēᵀ, summed in numpy."""
    g = sim.graph
    moments = np.einsum("nab,nb,ncb->nac", g.axes, 0.2 * g.volumes[:, None] * g.radii ** 2, g.axes)
    x, rot = sim.positions, sim.rotations
    e = 0.0
    for i, j in np.concatenate([g.edges, g.edges[:, ::-1]]):
        d = rot[i] - rot[j]
        r = rot[i] @ (g.centers[j] - g.centers[i]) - (x[j] - x[i])
        w = scale[j] * min(softness[i], softness[j])
        e += w * (np.trace(d @ moments[j] @ d.T) + g.volumes[j] * r @ r)
    return 0.5 * sim.params["stiffness"] * e


def test_the_energy_is_the_dense_references():
    """The elastic energy of a turned and stretched lattice, as the change of the static objective when k
    doubles at the same state (the pins' and gravity's terms do not move), against the dense sum."""
    g = lattice_graph(3, 3, 4)
    n = g.n_particles
    rng = np.random.default_rng(4)
    scale, softness = rng.uniform(0.2, 5.0, n), rng.uniform(0.01, 1.0, n)
    sim = opdeform.Simulation(g, 1e4)
    for p in g.centers[:3]:
        sim.add_position_constraint(p, weight=10.0)
    sim.set_stiffness_scale(scale)
    sim.set_link_softness(softness)
    sim.set_state(g.centers * [1.3, 1.0, 0.8], g.axes, rng.normal(0.0, 2.0, (n, 3)), rng.normal(0.0, 20.0, (n, 3)))
    sim.step(3)
    sim.solve_static(1)
    before = sim.energy()
    sim.set_params(stiffness=2e4)  # a number makes the stiffness uniform: the scale set again
    sim.set_stiffness_scale(scale)
    elastic = sim.energy() - before
    reference = dense_elastic_energy(sim, scale, softness) / 2
    assert reference > 0.1 * abs(before)  # the lattice is deformed
    assert elastic == pytest.approx(reference, rel=1e-10)
    softened = softness.copy()
    softened[7] = 0.001  # one particle: only its links' terms change
    sim.set_link_softness(softened)
    changed = sim.energy() - (before + elastic)
    assert -changed > 1e-3 * reference
    assert changed == pytest.approx(dense_elastic_energy(sim, scale, softened) - 2 * reference, rel=1e-10)


def test_energy_never_rises_with_a_link_softness():
    n = scenes.BAR_PARTICLES
    rng = np.random.default_rng(1)
    sim = scenes.fig1_bar()
    sim.set_stiffness_scale(rng.uniform(0.2, 5.0, n))
    sim.set_link_softness(rng.uniform(0.01, 1.0, n))
    assert_descends(sim)
    stiff = pinned_bar(1e14)  # the right side from residuals (global_solve.c od_NeedsCorrection)
    stiff.set_link_softness(rng.uniform(0.01, 1.0, n))
    assert_descends(stiff)


def static_sag(softness=None, scale=None):
    sim = scenes.fig1_bar(K)
    sim.set_solver(accelerator="anderson")  # the plain iteration needs 10^4+ iterations past a 100x softer link
    sim.set_link_softness(softness)
    sim.set_stiffness_scale(scale)
    sim.solve_static(4000)
    sag = scenes.tip_sag(sim)
    sim.solve_static(2000)
    assert scenes.tip_sag(sim) == pytest.approx(sag, rel=1e-6)  # converged
    return scenes.tip_sag(sim)


def test_a_soft_particle_softens_both_halves_of_its_links():
    """The bar's particle 5 with softness r: its two links are r times as stiff, so in the linear range the sag
    they add goes as 1/r - 1: r = 0.01 adds 99 times what r = 0.5 adds. Its stiffness scale at 0.01 instead
    leaves the other half of each link stiff: under 1/20 of that."""
    n, p = scenes.BAR_PARTICLES, 5
    base = static_sag()
    half = static_sag(one_particle(n, p, 0.5)) - base
    hundredth = static_sag(one_particle(n, p, 0.01)) - base
    scaled = static_sag(scale=one_particle(n, p, 0.01)) - base
    assert hundredth / half == pytest.approx(99.0, rel=0.02)  # measured 98.97
    assert hundredth > 20 * base and scaled < hundredth / 20  # measured 26.6x and 1/35


def test_a_change_refactors_once_a_stiffness_keeps_it_and_bad_input_raises_naming_the_entry():
    sim = scenes.fig1_bar()
    n = sim.graph.n_particles
    softness = np.linspace(0.1, 1.0, n)
    sim.step()
    sim.set_link_softness(softness)
    sim.step()
    sim.set_link_softness(softness.copy())  # the same values: the factor is kept
    sim.step()
    assert sim.counters["factorizations"] == 2
    sim.set_params(stiffness=np.linspace(1e9, 2e9, n))  # a new k and scale keep the softness
    assert np.array_equal(sim.link_softness, softness)
    for bad, shown in ((0.0, "0"), (-0.5, "-0.5"), (1.5, "1.5"), (np.nan, "nan"), (np.inf, "inf")):
        with pytest.raises(ValueError, match=rf"^link softness\[3\] = {shown} must be in \(0, 1\]$"):
            sim.set_link_softness(one_particle(n, 3, bad))
        assert np.array_equal(sim.link_softness, softness)
    with pytest.raises(ValueError, match="softness"):
        sim.set_link_softness(np.ones(n + 1))
    with pytest.raises(ValueError, match="softness"):
        opdeform.Simulation(sim.graph, 1e6).set_link_softness(np.full(n, np.nan))


def test_pickle_keeps_the_softness_and_replays_to_the_same_bits():
    sim = scenes.fig1_bar()
    sim.set_link_softness(np.linspace(0.05, 1.0, sim.graph.n_particles))
    sim.step(3)
    copy = pickle.loads(pickle.dumps(sim))
    assert np.array_equal(copy.link_softness, sim.link_softness)
    sim.step(5)
    copy.step(5)
    assert np.array_equal(copy.positions, sim.positions) and np.array_equal(copy.rotations, sim.rotations)
    saved = sim.__getstate__()
    del saved["link_softness"]  # written before link softness existed: all 1
    older = opdeform.Simulation.__new__(opdeform.Simulation)
    older.__setstate__(saved)
    assert older.link_softness is None
