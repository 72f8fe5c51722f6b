"""Settings an artist can use (issue 14): stiffness in Pa that keeps the look at any size, presets and their
droop, the error tolerance reached on every step and reported, the frame-rate helper and the panel's warnings.
Figures in docs/settings.md."""
import math
import warnings

import numpy as np
import pytest

import opdeform
from opdeform import materials, meshes, scenes


def tail(scale=1.0, particles=100):
    """The 2 m x 0.2 m tail of the issue, root at x = 0."""
    v, t = meshes.bar(length=2.0, width=0.2, segments=80, cross=4)
    v = v * scale
    return v, t, opdeform.Graph.from_mesh(v, t, particles=particles)


def droop(material, scale=1.0, particles=100, scaling="froude"):
    """Static droop of the pinned tail's tip as a fraction of its length (its modulus and gravity scaled with its
    size by ``scaling``)."""
    v, t, g = tail(scale, particles)
    m = materials.PRESETS[material]
    size = materials.body_size(g)
    sim = opdeform.Simulation(g, materials.stiffness_for(g, m.modulus, size, scaling=scaling), density=m.density,
                              gravity=materials.acting_gravity((0.0, 0.0, -9.81), size, scaling))
    opdeform.pin_vertices(sim, v, np.flatnonzero(v[:, 0] <= 1e-9))
    sim.set_solver("chebyshev")
    sim.solve_static(4000)
    tip = np.flatnonzero(v[:, 0] >= v[:, 0].max() - 1e-9)
    return -float((sim.skin_points(v[tip])[:, 2] - v[tip, 2]).mean()) / (2.0 * scale)


def test_the_same_modulus_droops_the_same_at_any_scale():
    """Both size rules (materials' docstring): "froude" of free bodies, "goal" of bodies following an animation
    (gravity scaled with the size, as the add-on scales Sag's); the two agree at GOAL_REFERENCE_SIZE."""
    for scaling in materials.SCALINGS:
        d = [droop("Rubber", s, scaling=scaling) for s in (0.1, 1.0, 10.0)]
        assert max(d) / min(d) < 1.1, (scaling, d)


def test_the_same_modulus_droops_the_same_at_any_particle_count():
    """The measured calibration: 9.5-10.3 % from 50 to 400 particles (1.08x; one bending k gave 9.1-11.3 %,
    1.25x, and the uniform-strain k 7.0-18.3 %)."""
    d = [droop("Rubber", 1.0, n) for n in (50, 100, 150, 200, 300, 400)]
    assert max(d) / min(d) < 1.1 and 0.08 < min(d) and max(d) < 0.13, d


def test_a_graphs_bending_calibration_is_computed_once(monkeypatch):
    """The add-on asks for k on every frame: the graph's own calibrations (its mesh's moments, sorting the
    mesh's edges: 12.6 ms for a 2,012-vertex Suzanne; the measured one's static solves) are kept with the graph;
    k stays linear in the modulus."""
    _, _, g = tail(particles=50)
    calls = []
    moments = materials._body_second_moment
    monkeypatch.setattr(materials, "_body_second_moment", lambda *a: calls.append(1) or moments(*a))
    for calibration in ("measured", "bending"):
        k = [materials.stiffness_for(g, m, calibration=calibration) for m in (1e7, 2e7, 1e7)]
        assert np.array_equal(k[0], k[2]) and np.allclose(k[1], 2 * k[0], rtol=1e-15, atol=0)
    assert len(calls) == 2  # once for each calibration
    v, t = meshes.bar(length=2.0, width=0.2, segments=80, cross=4)
    materials.stiffness_for(g, 1e7, mesh=(v, t), calibration="bending")  # another mesh: computed, not kept
    materials.stiffness_for(g, 1e7, mesh=(v, t), calibration="bending")
    assert len(calls) == 4


def test_above_the_measured_calibrations_particle_count_the_bending_k_stands_in(monkeypatch):
    """The measured k costs about 2.5 ms a particle (26 s an artist would wait at 10,000): above
    materials._MEASURED_MAX particles every particle gets the bending k."""
    _, _, g = tail(particles=50)
    monkeypatch.setattr(materials, "_MEASURED_MAX", 49)
    k = materials.stiffness_for(g, 1.5e7)
    assert k.shape == (50,) and np.all(k == materials.stiffness_for(g, 1.5e7, calibration="bending"))


def test_the_measured_k_comes_in_gradually_with_the_bodys_length():
    """Between 3 and 5 times longer than thick the measured k is blended with the bending k: switched at 3 alone,
    a 0.2 m square Jelly bar drooped 3.75 % at 0.60 m and 6.08 % at 0.62 m (an outside review)."""
    k = {}
    for length in (0.6, 0.62, 1.2):
        v, t = meshes.bar(length=length, width=0.2, segments=24, cross=4)
        g = opdeform.Graph.from_mesh(v, t, particles=150)
        k[length] = materials.stiffness_for(g, 1.5e7) / materials.stiffness_for(g, 1.5e7, calibration="bending")
    assert np.all(k[0.6] == 1.0)  # under 3: the bending k
    assert abs(k[0.62].mean() - 1.0) < 0.03  # just over: nearly so (0.978: the tip levelling blended in too)
    assert np.ptp(k[1.2]) > 0.1  # a beam: its own k per particle


def test_a_closed_mesh_with_faces_turned_both_ways_has_the_same_moments():
    """A closed mesh whose faces are wound either way (the add-on's test tail) is turned outward piece by piece
    before its volume and second moment are taken (it fell back to the particles' own J: the tail's droop then
    spread 1.19x over 50-300 particles under the measured k; 1.06x now); an open mesh has none."""
    v, t = meshes.bar(length=2.0, width=0.2, segments=20, cross=4)
    two = np.concatenate([t, t[:, ::-1] + len(v)])  # two bodies: the second turned inside out
    both = np.concatenate([v, v + (0.0, 1.0, 0.0)])
    turned = two.copy()
    flip = np.random.default_rng(1).random(len(two)) < 0.4
    turned[flip] = turned[flip][:, ::-1]
    volume, second = materials._closed_mesh_moments(both, np.concatenate([t, t + len(v)]))
    again = materials._closed_mesh_moments(both, turned)
    assert volume == pytest.approx(2 * 0.08) and again[0] == pytest.approx(volume, rel=1e-12)
    np.testing.assert_allclose(again[1], second, rtol=1e-12, atol=1e-15)
    assert materials._closed_mesh_moments(v, t[1:]) is None  # a face missing: open


def test_presets_droop_as_documented():
    d = {name: droop(name) for name in materials.PRESETS}
    assert 0.08 < d["Rubber"] < 0.14  # the default: roughly 10 %
    assert d["Jelly"] > d["Flesh"] > d["Rubber"] > d["Stiff"]
    assert d["Stiff"] < 0.02


def clip(make, tolerance=0.0, iterations=10, accelerator="none"):
    """A 2-second clip (120 steps) of a bar of scripts/bench error: frames, each step's report, the counters."""
    sim, animate = make(iterations)
    sim.set_solver(accelerator, tolerance=tolerance)
    frames, reports = [], []
    for f in range(120):
        animate(f / 60.0)
        sim.step()
        frames.append(sim.positions)
        reports.append(sim.step_report)
    return np.array(frames), reports, sim.counters


def sagging_bar(iterations):
    return scenes.fig1_bar(iterations=iterations), lambda t: None


def twisted_bar(iterations):
    bar = scenes.TwistedBar(damping=0.02, iterations=iterations)
    return bar.sim, bar.animate


def clip_error(make, frames):
    ref, _, _ = clip(make, iterations=400, accelerator="chebyshev")
    return float(np.sqrt(((frames - ref) ** 2).sum(-1).mean()) / scenes.BAR_LENGTH)


@pytest.mark.parametrize("make", [sagging_bar, twisted_bar])
def test_the_tolerance_is_reached_on_every_step_and_reported(make):
    frames, reports, _ = clip(make, materials.DEFAULT_TOLERANCE, accelerator=materials.DEFAULT_ACCELERATOR)
    for r in reports:
        assert r["steps"] == 1 and r["unconverged"] == 0
        assert 0.0 <= r["error"] <= materials.DEFAULT_TOLERANCE
        assert 1 <= r["iterations"] <= 100
    assert clip_error(make, frames) < 2e-3  # 0.2 % of the bar's length over the 2-second clip (issue 14)


def test_the_default_chooses_plain_pairs_on_the_twisted_bar_and_chebyshev_on_the_sagging_bar():
    """The issue's cost goal (at most 2x plain 10 pairs a step) is measured by scripts/bench error; here its
    deterministic part: the default makes fewer pairs than plain 10 a step on both bars, accelerated (the
    dearer pairs) on the sagging bar only (tolerance.c's design note)."""
    assert materials.DEFAULT_ACCELERATOR == "auto"
    for make, chebyshev in ((twisted_bar, False), (sagging_bar, True)):
        _, reports, counters = clip(make, materials.DEFAULT_TOLERANCE, accelerator=materials.DEFAULT_ACCELERATOR)
        pairs = sum(r["iterations"] for r in reports)
        accelerated = counters["accelerated"] + counters["rejected"]
        assert pairs < 10 * 120
        assert (accelerated > pairs / 2) if chebyshev else (accelerated < pairs / 10), (make, pairs, accelerated)


def test_auto_without_a_tolerance_is_chebyshev():
    a, b = scenes.fig1_bar(), scenes.fig1_bar()
    a.set_solver("auto")
    b.set_solver("chebyshev")
    a.step(5)
    b.step(5)
    assert a.solver["accelerator"] == "auto" and a.step_report["error"] == -1.0
    assert np.array_equal(a.positions, b.positions)


def test_without_a_tolerance_a_step_is_exactly_its_iterations():
    sim = scenes.fig1_bar()
    sim.step(3)
    assert sim.tolerance == 0.0 and sim.max_iterations == 100
    assert sim.step_report == dict(steps=3, iterations=30, most_iterations=10, error=-1.0, unconverged=0)


def test_a_step_that_hits_the_cap_is_reported():
    sim = scenes.fig1_bar()
    sim.set_solver(tolerance=1e-14, max_iterations=3)
    sim.step(2)
    r = sim.step_report
    assert r["iterations"] == 6 and r["unconverged"] == 2 and r["error"] > 1e-14


def test_a_turned_handle_is_followed_at_defaults():
    bar = scenes.TwistedBar()
    bar.sim.set_solver(materials.DEFAULT_ACCELERATOR, tolerance=materials.DEFAULT_TOLERANCE)
    bar.pose(math.radians(60.0), (0.0, 0.0, 0.0))
    bar.sim.step(30)  # 0.5 s
    a, b = bar.sim.skin_points([(2.0, 0.0, 0.0), (2.0, 0.1, 0.0)])
    assert abs(math.degrees(math.atan2(b[2] - a[2], b[1] - a[1])) - 60.0) < 10.0


def test_substeps_give_one_step_size_at_every_frame_rate():
    assert [materials.substeps_for(f) for f in (24, 30, 48, 60)] == [10, 8, 5, 4]
    assert [materials.substeps_for(f, 1 / 120) for f in (24, 30, 60)] == [5, 4, 2]
    assert materials.step_damping(0.0, 0.1) == 0.0
    assert materials.step_damping(1.0, 0.5) == pytest.approx(2 * materials.step_damping(1.0, 0.25)
                                                             - materials.step_damping(1.0, 0.25) ** 2)


def jiggle(fps, substeps, seconds=3.0):
    """The default tail released from rest: its tip's frequency (zero crossings about the static pose) and
    RMS offset from that pose over the first and second halves, frames sampled at ``fps``."""
    v, t, g = tail()
    root, tip = np.flatnonzero(v[:, 0] <= 1e-9), np.flatnonzero(v[:, 0] >= v[:, 0].max() - 1e-9)
    sims = [materials.make_simulation(g, dt=1.0 / (fps * substeps)) for _ in range(2)]
    for sim in sims:
        opdeform.pin_vertices(sim, v, root)
    sims[1].set_solver("chebyshev")
    sims[1].solve_static(4000)
    rest = sims[1].skin_points(v[tip])[:, 2].mean()
    z = []
    for _ in range(int(seconds * fps)):
        sims[0].step(substeps)
        z.append(sims[0].skin_points(v[tip])[:, 2].mean() - rest)
    z, time = np.array(z), np.arange(1, len(z) + 1) / fps
    k = np.flatnonzero(z[:-1] * z[1:] < 0)
    crossings = time[k] - z[k] * (time[k + 1] - time[k]) / (z[k + 1] - z[k])
    half = time <= seconds / 2
    return ((len(crossings) - 1) / (2 * (crossings[-1] - crossings[0])), np.sqrt((z[half] ** 2).mean()),
            np.sqrt((z[~half] ** 2).mean()))


def test_substeps_for_give_the_same_jiggle_at_24_and_60_fps():
    """docs/settings.md's frame-rate table: with substeps_for the look agrees (the issue asks 20 %)."""
    slow, fast = jiggle(24, materials.substeps_for(24)), jiggle(60, materials.substeps_for(60))
    assert slow[0] > 0.5 and slow[2] > 0.01  # it jiggles, and still does in the second half
    for a, b in zip(slow, fast):
        assert abs(a / b - 1.0) < 0.05, (slow, fast)


def test_scale_keeps_the_stiffness_formula():
    v, t, g = tail()
    small = opdeform.Graph(g.centers, g.radii, g.edges, g.axes)  # no mesh: the particles' second moment
    big = opdeform.Graph(g.centers * 10, g.radii * 10, g.edges, g.axes)
    # k ~ modulus * size / spacing^2: ten times larger, a tenth of k (the measured k comes from static solves
    # stopped after a fixed number of iterations: round-off moves it by up to 7e-6)
    for calibration, rel in zip(materials.CALIBRATIONS, (1e-4, 1e-9, 1e-9)):
        k = materials.stiffness_for(small, 1e6, calibration=calibration)
        assert materials.stiffness_for(big, 1e6, calibration=calibration) == pytest.approx(k / 10, rel=rel)
    # from a mesh: its second moment (the same with the mesh given or remembered by from_mesh)
    k = materials.stiffness_for(g, 1e6)
    assert materials.stiffness_for(small, 1e6, mesh=(v, t)) == pytest.approx(k, rel=1e-4)
    assert materials.stiffness_for(big, 1e6, mesh=(v * 10, t)) == pytest.approx(k / 10, rel=1e-4)
    with pytest.raises(ValueError):
        materials.stiffness_for(g, -1.0)
    with pytest.raises(ValueError):
        materials.stiffness_for(g, 1e6, calibration="fudge")
    # following an animation above GOAL_REFERENCE_SIZE: E ~ size^2, so ten times larger keeps k (the same
    # frequencies at any size); at it and below the froude rule's E (the goal rule only stiffens)
    huge = opdeform.Graph(g.centers * 100, g.radii * 100, g.edges, g.axes)
    k = materials.stiffness_for(big, 1e6, scaling="goal")
    assert materials.stiffness_for(huge, 1e6, scaling="goal") == pytest.approx(k, rel=1e-4)
    assert np.array_equal(materials.stiffness_for(small, 1e6, scaling="goal"), materials.stiffness_for(small, 1e6))
    at = materials.GOAL_REFERENCE_SIZE
    for size in (0.01, 1.0, at):
        assert materials.acting_modulus(1e6, size, "goal") == pytest.approx(materials.acting_modulus(1e6, size))
        assert materials.acting_gravity((0.0, 0.0, -9.81), size, "goal") == (0.0, 0.0, -9.81)
    assert materials.acting_gravity((0.0, 0.0, -9.81), 2 * at, "goal") == pytest.approx((0.0, 0.0, -19.62))
    with pytest.raises(ValueError, match="scaling"):
        materials.stiffness_for(g, 1e6, scaling="cubic")
    with pytest.raises(ValueError, match="size"):
        materials.acting_gravity((0.0, 0.0, -9.81), 0.0, "goal")


def test_bending_calibration_matches_a_continuum_beam():
    """The mesh's second moment of a 2 m x 0.2 m x 0.2 m box is V h^2 / 12 about each cross axis; an open mesh
    falls back to the particles' own, which differs from it by a few per cent."""
    v, t, g = tail()
    volume, second = materials._closed_mesh_moments(v, t)
    assert volume == pytest.approx(0.08, rel=1e-12)
    assert np.diag(second) == pytest.approx([0.08 * 4 / 12, 0.08 * 0.04 / 12, 0.08 * 0.04 / 12], rel=1e-9)
    assert materials._closed_mesh_moments(v, t[1:]) is None
    k_mesh, k_open = (materials.stiffness_for(g, 1e6, mesh=m, calibration="bending") for m in ((v, t), (v, t[1:])))
    assert 0.8 < k_open / k_mesh < 1.2


def test_panel_values_map_to_a_simulation():
    table = materials.preset_table()
    assert [p["name"] for p in table] == list(materials.PRESETS)
    assert all(p["description"] and p["modulus"] > 0 for p in table)
    _, _, g = tail()
    rubber = materials.PRESETS["Rubber"]
    sim_kw, solver_kw, substeps = materials.simulation_settings(g, rubber.modulus, rubber.density, rubber.damping,
                                                                fps=24)
    assert substeps == 10 and sim_kw["dt"] == pytest.approx(1 / 240)
    assert sim_kw["stiffness"] == pytest.approx(materials.stiffness_for(g, rubber.modulus))
    sim = opdeform.Simulation(g, **sim_kw)
    sim.set_solver(**solver_kw)
    assert sim.tolerance == rubber.tolerance
    with pytest.raises(ValueError):
        materials.simulation_settings(g, 1e6, 1000, 0.3, substeps=0)


def test_stretch_warning():
    _, _, g = tail()
    ratio, edges = materials.stretch_warning(g, g.centers)
    assert ratio == pytest.approx(1.0) and len(edges) == 0
    stretched = g.centers * np.array([3.0, 1.0, 1.0])
    ratio, edges = materials.stretch_warning(g, stretched)
    assert ratio > 2.0 and len(edges) > 0


def test_thin_part_warning():
    v, t, coarse = tail(particles=20)
    thickness, spacing, warn = materials.thin_part_warning(coarse, v, t)
    assert thickness == pytest.approx(0.2, rel=0.05) and warn
    _, _, fine = tail(particles=400)
    assert not materials.thin_part_warning(fine, v, t)[2]


def test_an_open_sheet_has_no_thin_part():
    """No ray from a sheet meets an opposite side: infinite thickness, no warning (before: NaN and numpy's
    "invalid value" warning at every Build of a sheet; scripts/calibration_sweep.py)."""
    v, t = meshes.sheet()
    g = opdeform.Graph.from_mesh(v, t, particles=50)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        thickness, _, warn = materials.thin_part_warning(g, v, t)
    assert thickness == math.inf and not warn


def test_thin_appendages_with_too_few_particles():
    """The character's ears, tail and feet (a grid opening, as the calibration finds them) have 0-2 particles
    each at 50-200 particles and 3-6 at 400: named below 400, not at 400; an open mesh has none."""
    v, t = meshes.character()
    counts = {}
    for n in (50, 100, 400):
        parts = materials.thin_appendages(opdeform.Graph.from_mesh(v, t, particles=n), v, t)
        counts[n] = sorted(count for _, _, count in parts)
    assert len(counts[50]) == 5 and max(counts[50]) <= 2 and len(counts[100]) == 5 and counts[400] == []
    tail_part = materials.thin_appendages(opdeform.Graph.from_mesh(v, t, particles=100), v, t)[0]
    assert tail_part[1] == pytest.approx(0.65, abs=0.1) and tail_part[0][1] > 0.5  # the longest: the tail, behind
    bar, bt = meshes.bar()
    assert materials.thin_appendages(opdeform.Graph.from_mesh(bar, bt, particles=20), bar, bt[1:]) == []


def ear_on_a_head():
    """A 0.6 m ball with a thin flat ear on top (0.18 x 0.024 x 0.32 m, smoothly joined), a closed mesh."""
    def distance(p):
        ball = np.linalg.norm(p - [0.0, 0.0, 0.3], axis=-1) - 0.3
        ear = (np.linalg.norm((p - [0.0, 0.0, 0.68]) / [0.09, 0.012, 0.16], axis=-1) - 1.0) * 0.012
        h = np.clip(0.5 + 0.5 * (ear - ball) / 0.02, 0.0, 1.0)
        return ear + (ball - ear) * h - 0.02 * h * (1.0 - h)
    return meshes._closed_surface(distance, np.array([-0.35, -0.35, -0.05]), np.array([0.35, 0.35, 0.9]), 0.008)


def test_a_thin_ears_edges_stay_under_one_and_a_half_times_their_length_on_a_nodding_head():
    """Issue 24's "no edge over 1.5x its animated length" (docs/goals.md, "Edges that stretch"): a thin plate's
    k, fitted to its cantilever bending across its thickness, fell to the floor under the body's (1/64), and its
    particles' edges, at Floppy's modulus and softness, stretched with the motion (the dog's ears 1.86x at 1,000
    particles; this ear 1.59x at 400 particles). The floor is now 1/20: 1.38x, the ear still swinging 0.12 m."""
    v, t = ear_on_a_head()
    g = opdeform.Graph.from_mesh(v, t, particles=400)
    ear = g.centers[:, 2] > 0.62
    k = materials.stiffness_for(g, 1.5e6) * np.where(ear, 0.13, 1.0)  # Floppy: 1.5 MPa, the ear soft (x 0.13)
    dt = 1.0 / 48.0
    sim = opdeform.Simulation(g, k, density=1050.0, dt=dt, damping=materials.step_damping(12.0, dt))
    sim.set_goal_strength(np.where(ear, 0.46, 1.0))
    sim.set_goals_carry_rest(True)
    edges = g.edges[ear[g.edges].any(axis=1)]
    stretch, swing = [], []
    for f in range(48):  # the head nods 20 degrees about the ball's bottom at 2 Hz, 24 frames a second
        c, s = np.cos(0.35 * np.sin(np.pi * f / 6.0)), np.sin(0.35 * np.sin(np.pi * f / 6.0))
        turn = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
        goals = g.centers @ turn.T
        sim.set_goals(goals, np.repeat(turn[None], g.n_particles, axis=0))
        sim.step(2)
        x = sim.positions
        length = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)
        stretch.append((length / np.linalg.norm(goals[edges[:, 0]] - goals[edges[:, 1]], axis=1)).max())
        swing.append(np.linalg.norm(x[ear] - goals[ear], axis=1).max())
    assert max(stretch) < 1.5
    assert max(swing) > 0.05  # still loose: it swings, not held to the head


def test_handle_warning():
    sim = scenes.fig1_bar()
    assert not materials.handle_warning(sim, speed=1.0, fps=24)[1]
    assert materials.handle_warning(sim, speed=5.0, fps=24)[1]  # 0.21 m a step on a 2 m bar
    assert not materials.handle_warning(sim, speed=5.0, fps=24, substeps=5)[1]
