"""Loose parts never tear (issue 12): Blender's Suzanne subdivided twice (a head and two separate eyeballs,
tests/reference/suzanne_subdivided.npz, made by tests/blender/make_suzanne.py) dropped on the floor keeps
every triangle edge under 3x its rest length at 100 and 1,000 particles and its eyes in their sockets,
with the small pieces attached (the default) or with particles of their own; no vertex and no constraint
is skinned by particles of another mesh piece."""

from pathlib import Path

import numpy as np
import pytest

import opdeform
from opdeform import mesh, meshes
from suzanne_check import DropCheck, mesh_pieces_of_vertices

SUZANNE = Path(__file__).parent / "reference" / "suzanne_subdivided.npz"
STEPS = 120  # 2 s at h = 1/60


@pytest.fixture(scope="module")
def suzanne():
    data = np.load(SUZANNE)
    return data["vertices"].astype(np.float64), data["triangles"]


def test_suzanne_has_a_head_and_two_eyes(suzanne):
    v, t = suzanne
    sizes = np.bincount(mesh_pieces_of_vertices(len(v), t))
    assert len(v) == 7958 and len(t) == 15744 and sorted(sizes) == [497, 497, 6964]


@pytest.mark.parametrize("small_pieces", ["attach", "own"])
@pytest.mark.parametrize("particles", [100, 1000])
def test_no_vertex_or_constraint_skinned_across_pieces(suzanne, particles, small_pieces):
    v, t = suzanne
    piece = mesh_pieces_of_vertices(len(v), t)
    g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces=small_pieces)
    count, particle_piece = mesh.mesh_pieces(g)
    assert count == 3 and g.pieces()[0] == 1  # the eyes hang on the head
    head = np.argmax(np.bincount(piece))
    own = np.bincount(particle_piece, minlength=3)
    skin = opdeform.Skin(g, v)
    skinned_by = particle_piece[skin.indices]
    for q in range(3):
        rows = piece == q
        if small_pieces == "own" or q == head:
            assert own[q] >= 4 and np.all(skinned_by[rows] == q)
        else:  # attached: no particles; every vertex takes the same head particles and weights (rigid)
            assert own[q] == 0 and np.all(skinned_by[rows] == head)
            assert np.all(skin.indices[rows] == skin.indices[rows][0])
            assert np.all(skin.weights[rows] == skin.weights[rows][0])
    # Constraints (pin_vertices) take the same weights as the skin, bit for bit: on each piece, and on the
    # head vertex nearest each eye's centre (a socket, whose nearest particle may be the eye's).
    sockets = [np.flatnonzero(piece == head)[np.argmin(np.linalg.norm(v[piece == head] - v[piece == q].mean(axis=0),
                                                                      axis=1))] for q in range(3) if q != head]
    for vertex in np.r_[np.flatnonzero(np.r_[True, np.diff(piece) != 0]), sockets]:
        idx, w = g.skin_weights(v[vertex], skin.neighbors)
        np.testing.assert_array_equal(idx, skin.indices[vertex])
        np.testing.assert_array_equal(w, skin.weights[vertex])


def test_small_is_a_share_of_the_mesh_not_a_size(suzanne):
    v, t = suzanne
    for scale in (0.01, 1.0, 100.0):
        g = opdeform.Graph.from_mesh(v * scale, t, particles=100)
        assert np.bincount(mesh.mesh_pieces(g)[1], minlength=3).tolist() == [0, 0, 100]


def drop(v, t, particles, small_pieces):
    """The creature scene's set-up (scripts/demo_mesh.py: k = 2e7, damping 0.01, friction 0.5, tilted 15
    degrees, 0.3 m above the floor) for 2 s. Returns the worst edge stretch and the worst eye offset from
    the rigid motion of its socket (head vertices within two eye radii), over the head's size."""
    g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces=small_pieces)
    sim = opdeform.Simulation(g, 2e7, damping=0.01)
    c, s = np.cos(np.radians(15.0)), np.sin(np.radians(15.0))
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    lift = np.array([0.0, 0.0, 0.3 - (v @ tilt.T)[:, 2].min()])
    sim.set_state(g.centers @ tilt.T + lift, np.tile(tilt, (g.n_particles, 1, 1)))
    sim.set_floor(0.0, 0.5)
    skin = opdeform.Skin(g, v)
    check = DropCheck(v, t)
    out = np.empty_like(v)
    for _ in range(STEPS):
        sim.step()
        check.update(skin.deform_sim(sim, out=out))
    return check.stretch, check.offset


@pytest.mark.parametrize("small_pieces", ["attach", "own"])
@pytest.mark.parametrize("particles", [100, 1000])
def test_suzanne_dropped_keeps_its_edges_and_eyes(suzanne, particles, small_pieces):
    """Before the fix: 191x and 283x, eyes off by 22 % and 28 % of the head's size."""
    stretch, offset = drop(*suzanne, particles, small_pieces)
    assert stretch < DropCheck.STRETCH, f"an edge stretched {stretch:.2f}x"
    assert offset < DropCheck.EYE, f"an eye left its socket by {offset:.3f} of the head's size"


SHELL_PARTICLES = mesh.SHELL_PARTICLES
COMPACT_PARTICLES = mesh.SMALL_PIECE_PARTICLES


def kitbash():
    """A 1.6 m capsule body with a 0.9 m trunk and a 0.33 m horn (long solids), a 0.1 m eyeball (compact) and an
    open 0.3 m square patch as detached shells that pierce it, each under a tenth of its volume (a kitbashed
    creature's trunk, ears, horns, eyes: docs/goals.md's ellie; bpy 5.2's Skin modifier leaves such patches)."""
    body = meshes.capsule(radius=0.3, length=1.0)  # along x, -0.8..0.8 m
    trunk = meshes.capsule(radius=0.05, length=0.8)
    horn = meshes.capsule(radius=0.04, length=0.25)
    eye = meshes.capsule(radius=0.05, length=0.0, body=1)  # a sphere
    patch = meshes.sheet((0.3, 0.3), (4, 4))
    parts = [body[0], trunk[0] + [0.95, 0.0, 0.0], horn[0][:, ::-1] + [0.0, 0.0, 0.35],  # the horn along z
             eye[0] + [0.5, -0.27, 0.0], patch[0] + [-0.4, 0.0, 0.25]]
    first = np.cumsum([0] + [len(p) for p in parts])
    t = np.vstack([m[1] + first[i] for i, m in enumerate((body, trunk, horn, eye, patch))])
    return np.vstack(parts), t


@pytest.mark.parametrize("particles", [50, 100, 200, 400])
def test_long_detached_shells_of_their_own_get_their_floor_beyond_the_budget(particles):
    """Each long or flat detached shell of its own has at least SHELL_PARTICLES particles at any count, added
    beyond the budget, so its look hardly moves with the count (ellie's secondary motion 1.56-2.03 % at
    100-1,000 particles, 2.9x apart with 4 from the budget: docs/goals.md); the body keeps its share of the
    budget; a compact shell (an eye) and an open patch keep COMPACT_PARTICLES from it (16 blew up bpy 5.2's
    open patches inside gob's body). Before: 4 each, taken from it."""
    v, t = kitbash()
    g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces="own")
    count, of_particle = mesh.mesh_pieces(g)
    per_piece = np.bincount(of_particle, minlength=count)
    assert count == 5 and per_piece[1:3].min() >= SHELL_PARTICLES, per_piece
    assert per_piece[3] == per_piece[4] == COMPACT_PARTICLES, per_piece
    assert per_piece[0] >= 0.8 * particles and g.n_particles > particles, per_piece
    assert g.pieces()[0] == 1  # joined to the body


def studded(studs=300):
    """A 1.6 m capsule body among `studs` loose 4 cm spheres (studs, sequins, rivets, scattered up to 2 m from it),
    each well under a tenth of the body's volume."""
    body = meshes.capsule(radius=0.3, length=1.0)
    stud = meshes.capsule(radius=0.02, length=0.0, segments=8, rings=4, body=1)
    at = np.random.default_rng(1).uniform(-1.0, 1.0, (studs, 3)) * [2.0, 2.0, 1.0]
    v = np.vstack([body[0], *(stud[0] + a for a in at)])
    t = np.vstack([body[1], *(stud[1] + len(body[0]) + i * len(stud[0]) for i in range(studs))])
    return v, t


@pytest.mark.parametrize("particles", [50, 100, 1000])
def test_many_small_shells_of_their_own_leave_the_body_half_the_budget(particles):
    """Compact small shells of their own take COMPACT_PARTICLES each from the budget before the body gets a
    second: 300 studs left the body 1 particle of 100, and the studs past the budget were skinned by other studs'
    particles up to 1 m away. Now the studs' particles take at most half the budget (largest first), the next
    studs' are added beyond it up to half of it again (the outside dancer's hair ribbons past its skirt cards,
    docs/goals.md "Cards and ribbons (stop 50)"), and the studs left out ride the body rigidly, as attached ones
    do."""
    v, t = studded()
    piece = mesh_pieces_of_vertices(len(v), t)
    body = np.argmax(np.bincount(piece))
    g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces="own")
    count, of_particle = mesh.mesh_pieces(g)
    per_piece = np.bincount(of_particle, minlength=count)
    assert count == 301 and per_piece[body] >= particles // 2, per_piece[body]
    studs = np.delete(per_piece, body)
    assert particles // 2 < studs.sum() <= particles and studs.max() <= COMPACT_PARTICLES  # (fewer: a stud's voxels)
    assert len(of_particle) <= particles + particles // 2, len(of_particle)
    skinned_by = of_particle[opdeform.Skin(g, v).indices]
    own = per_piece[piece] > 0
    assert np.all(skinned_by[own] == piece[own][:, None])  # with particles: its own
    assert np.all(skinned_by[~own] == body)  # left out: the body's, never another stud's


def with_button(particles, at=(0.2, 0.0, 0.3)):
    """The kitbash's capsule body with a 44 mm ball (a button) half sunk into its top, as a graph with small
    pieces of their own: (graph, vertices, triangles, the button's vertices)."""
    ball = meshes.capsule(radius=0.022, length=0.0, segments=12, rings=6, body=1)
    v, t = with_shell((ball[0] + at, ball[1]))
    return opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces="own"), v, t, len(v) - len(ball[0])


def test_a_shell_at_its_floor_of_particles_moves_rigidly():
    """A compact shell with its floor of 4 particles (each about as large as it) is skinned from one anchor over
    them, as an attached shell over its host's: dropped 0.6 m, the button's edges stretched 3.81x when its
    particles, each skinned by its nearest, were pulled apart by their links to the body (gob's buttons at 50
    particles: 1.72x, docs/goals.md); rigid, under 1.01x. It keeps particles of its own, and still moves."""
    g, v, t, first = with_button(100)
    count, of_particle = mesh.mesh_pieces(g)
    assert np.bincount(of_particle)[1] == COMPACT_PARTICLES
    skin = opdeform.Skin(g, v)
    assert np.all(skin.indices[first:] == skin.indices[first]) and np.all(skin.weights[first:] == skin.weights[first])
    assert np.all(of_particle[skin.indices[first]] == 1)
    sim = opdeform.Simulation(g, 1e5, damping=0.01)
    sim.set_state(g.centers + [0.0, 0.0, 0.6], np.tile(np.eye(3), (g.n_particles, 1, 1)))
    sim.set_floor(0.0, 0.5)
    edges = np.unique(np.sort(np.r_[t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1), axis=0)
    edges = edges[(edges >= first).all(axis=1)]
    rest = np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1)
    edges, rest = edges[rest > 1e-9], rest[rest > 1e-9]  # the ball's poles repeat a vertex
    out, worst, travel = np.empty_like(v), 1.0, 0.0
    for _ in range(90):
        sim.step()
        p = skin.deform_sim(sim, out=out)
        worst = max(worst, (np.linalg.norm(p[edges[:, 0]] - p[edges[:, 1]], axis=1) / rest).max())
        travel = max(travel, np.abs(p[first:] - v[first:]).max())
    assert worst < 1.01, worst
    assert travel > 0.5  # it fell with the body


def test_bad_small_pieces():
    v, t = opdeform.meshes.capsule()
    with pytest.raises(ValueError, match="small_pieces"):
        opdeform.Graph.from_mesh(v, t, particles=10, small_pieces="glue")
    assert mesh.mesh_pieces(opdeform.Graph([[0.0, 0.0, 0.0]], [[1.0, 1.0, 1.0]], np.zeros((0, 2)))) == (0, None)


ROOT_LINKS = mesh.ROOT_LINKS


def with_shell(shell):
    """The kitbash's 1.6 m capsule body (along x, radius 0.3 m) and one detached shell (vertices, triangles)."""
    body = meshes.capsule(radius=0.3, length=1.0)
    return np.vstack([body[0], shell[0]]), np.vstack([body[1], shell[1] + len(body[0])])


def hanging_ear():
    """A flat 0.35 m ear (0.1 x 0.035 m across) hanging down along the body's side from a root inside it, 4-6 cm
    from the body along most of its length (docs/goals.md's dog)."""
    v, t = meshes.capsule(radius=0.05, length=0.25)
    v = (v * [1.0, 1.0, 0.35])[:, [2, 0, 1]]  # along y, flat across x
    a = np.radians(-75.0)
    turn = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    return v @ turn.T + [0.0, 0.29, 0.02], t


def droop(graph, moved, k):
    """The largest static displacement of the particles ``moved`` under gravity, the others pinned (stiffness k
    per particle, 1,000 kg/m^3)."""
    sim = opdeform.Simulation(graph, k, density=1000.0, gravity=(0.0, 0.0, -9.81))
    for p in np.delete(graph.centers, moved, axis=0):
        sim.add_position_constraint(p)
    sim.solve_static(800)
    return np.linalg.norm(sim.positions[moved] - graph.centers[moved], axis=1).max()


@pytest.mark.parametrize("particles", [50, 100, 400])
def test_a_shell_along_a_line_is_linked_at_its_root_and_bends_as_its_own(particles):
    """A detached shell along a line (an ear, a tail) is linked to the body from the ROOT_LINKS particles nearest
    it, so that its own stiffness sets how it bends: the body held, the ear ten times softer droops 5.6-6.9 times
    as far (50-400 particles). Before, every particle was linked to the nearest body particle, and the ear
    hanging along the body was held by the body all along it: 1.2-2.2 times (the dog's ears moved 0.03 mm for
    the head's 155 mm, and the same when 100 times softer: docs/goals.md). A flat shell (a plate, which a single
    layer of particles does not hold in shape) keeps a link from each particle."""
    v, t = with_shell(hanging_ear())
    g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces="own")
    of = mesh.mesh_pieces(g)[1]
    e = g.edges
    assert ((of[e[:, 0]] == 1) != (of[e[:, 1]] == 1)).sum() == ROOT_LINKS
    ear = np.flatnonzero(of == 1)
    k = np.full(g.n_particles, 1e6)
    stiff = droop(g, ear, k)
    k[ear] = 1e5
    softer = droop(g, ear, k) / stiff
    assert softer > 3.5, f"ten times softer, the ear droops {softer:.2f} times as far"
    plate = meshes.capsule(radius=0.2, length=0.1)  # 0.5 x 0.4 x 0.04 m, lying on the body
    g = opdeform.Graph.from_mesh(*with_shell((plate[0] * [1.0, 1.0, 0.1] + [0.0, 0.0, 0.35], plate[1])),
                                 particles=particles, small_pieces="own")
    of = mesh.mesh_pieces(g)[1]
    e = g.edges
    assert ((of[e[:, 0]] == 1) != (of[e[:, 1]] == 1)).sum() == (of == 1).sum() >= SHELL_PARTICLES


@pytest.mark.parametrize("particles", [50, 100, 400])
def test_a_linked_shell_takes_one_stiffness(particles):
    """The calibration ("measured") gives a detached shell linked to the body (a mesh piece joined to it by
    edges: the ear) one k, its particles' volume-weighted geometric mean. Before, the ear
    took the body's measured k at each particle's place: 64x apart from particle to particle (the clamp's both
    ends), and the kid's ponytail, 12x apart side by side, stretched 1.58-1.82x (docs/goals.md)."""
    g = opdeform.Graph.from_mesh(*with_shell(hanging_ear()), particles=particles, small_pieces="own")
    ear = mesh.mesh_pieces(g)[1] == 1
    k = opdeform.materials.stiffness_for(g, 1e6)
    assert ear.sum() > 1 and k[ear].max() / k[ear].min() < 1.0 + 1e-9, k[ear]


def skirt(top=0.1, hem=-0.2, around=24, rows=6):
    """An open cone from radius 0.16 m at ``top`` to 0.25 m at ``hem`` (a skirt: a sheet of no thickness), rings
    from the top down."""
    z, r = np.linspace(top, hem, rows + 1), np.linspace(0.16, 0.25, rows + 1)
    a = 2.0 * np.pi * np.arange(around) / around
    v = np.array([[ri * np.cos(x), ri * np.sin(x), zi] for zi, ri in zip(z, r) for x in a])
    j = np.arange(around)
    quads = [(i * around + j, i * around + (j + 1) % around) for i in range(rows)]
    t = np.vstack([np.column_stack(c) for p, q in quads for c in ((p, q, q + around), (p, q + around, p + around))])
    return v, t


def spin_skirt(particles, modulus=3e6, rate=9.0, soft_stiffness=1.0):
    """A skirt round a body (a 0.74 m upright capsule) turning 180 degrees about z in 8 frames (kid's spin,
    docs/goals.md), then 6 frames still: the skirt is a piece of its own, Follow 1 at its waistband to 0.37 at
    its hem (the add-on's Shell Min lifts the painted 0.1 there), the body 1; softness 1 - the painted Follow
    (k x soft_stiffness ** softness, the add-on's Soft Stiffness); Fleshy's 3 MPa and 9/s at 24 fps, 10
    substeps. Yields (graph, simulation, goals, the mesh's vertices and triangles, the skirt's first vertex)
    each frame."""
    body = meshes.capsule(radius=0.12, length=0.5)
    sv, st = skirt()
    bv = body[0][:, [1, 2, 0]]
    v, t = np.vstack([bv, sv]), np.vstack([body[1], st + len(bv)])
    s = (0.1 - sv[:, 2]) / 0.3
    painted = np.concatenate([np.zeros(len(bv)), 0.9 * s * s * (3.0 - 2.0 * s)])  # 1 - the painted Follow
    g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces="own")
    dt, fit = 1.0 / 240.0, opdeform.GoalFit(g, v)
    k = opdeform.materials.stiffness_for(g, modulus) * soft_stiffness ** np.clip(fit.particle_values(painted), 0, 1)
    sim = opdeform.Simulation(g, k, density=1050.0, dt=dt, gravity=(0.0, 0.0, 0.0),
                              damping=opdeform.materials.step_damping(rate, dt))
    sim.set_goal_strength(np.clip(fit.particle_values(1.0 - 0.7 * painted), 0.0, 1.0))
    sim.set_goals_carry_rest(True)
    for f in range(14):
        x = min(f / 8.0, 1.0)
        a = np.pi * x * x * (3.0 - 2.0 * x)
        turn = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
        goals = fit.fit(v @ turn.T)
        sim.set_goals(*goals)
        sim.step(10)
        yield g, sim, goals, (v, t), len(bv)


def spun_hem(particles):
    """The largest offset (m) of the skirt's hem particles from their goals in spin_skirt."""
    worst = 0.0
    for g, sim, goals, _, _ in spin_skirt(particles):
        count, label = g.pieces()
        sheet = label != np.argmax(np.bincount(label))
        hem = sheet & (g.centers[:, 2] < g.centers[sheet, 2].min() + 0.05)
        worst = max(worst, np.linalg.norm(sim.positions[hem] - goals[0][hem], axis=1).max())
    assert count == 2 and hem.sum() >= 4, (count, hem.sum())
    return worst


@pytest.mark.parametrize("particles", [50, 100, 400])
def test_a_sheet_held_at_one_edge_swings_at_the_other_in_a_turn(particles):
    """A piece of its own that is an open sheet (a skirt) is as soft as a membrane (materials._sheets_floored):
    its hem, painted low, lags 7.2-8.1 mm behind its goals in a 180-degree spin (50-400 particles; 9.0-13.6 mm
    while the goals between frames went along the chord, whose 11 mm sagitta at the hem's 34 degrees a frame
    was most of it: docs/goals.md, "A rig turning fast"). Calibrated as a body of its own (a tube as thick as
    its particles, 0.8-2.0x the body's k), it moved with its waistband: 0.7-0.9 mm (the kid's skirt 1.2 mm)."""
    worst = spun_hem(particles)
    assert worst > 3e-3, f"the hem lagged {1e3 * worst:.2f} mm"


def test_a_sheet_swings_alike_at_any_particle_count():
    """A sheet's k from its own swing (materials._hanging_ratio), not the body's k / _SOFTEST: the hem's lag in
    the spin 7.2-8.1 mm over 50-400 particles (1.13x apart). Loaded along the way from its waistband (hanging)
    instead of across it, 8.1 / 6.5 / 5.4 / 4.1 mm (1.98x: for one k a sheet in tension gives 5.4x more at 400
    particles than at 50, one loaded across 3.7x); 9.0-29.0 mm (3.2x) at the body's k / _SOFTEST."""
    lags = [spun_hem(n) for n in (50, 100, 200, 400)]
    assert max(lags) < 1.25 * min(lags), [round(1e3 * x, 1) for x in lags]


def test_a_sheets_vertices_blend_more_particles():
    """The skin blends each vertex of an open sheet of its own over 6 particles, the body's over 4
    (OD_SHEET_SKIN): in spin_skirt at the Floppy look (1.5 MPa, 12/s, Soft Stiffness 0.1) at 50 particles the
    skirt's longest edge is 1.38x its rest length, 1.54x with 4 (100 / 200 / 400 particles: 1.61 / 1.59 / 1.47x
    -> 1.50 / 1.56 / 1.44x; there the particles themselves part). The kid's skirt at Floppy 100 particles
    stretched 1.56x across the seam of its hem row, 1.32x after (docs/goals.md)."""
    worst, skin = 0.0, None
    for g, sim, _, (v, t), first in spin_skirt(50, 1.5e6, 12.0, 0.1):
        skin = skin or opdeform.Skin(g, v)
        e = np.unique(np.sort(t[t.min(axis=1) >= first][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
        x = skin.deform(sim.positions, sim.rotations)
        length = np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1) / np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
        worst = max(worst, length.max())
    w = skin.weights
    assert skin.neighbors == 6 and not w[:first, 4:].any() and (w[first:, 4:].sum(axis=1) > 0.0).all()
    assert worst < 1.5, f"a skirt edge {worst:.3f}x its rest length"


@pytest.mark.parametrize("particles", [50, 300])
def test_a_shells_goal_frames_follow_its_own_vertices(particles):
    """A low-poly box (8 vertices, a backpack) 25 mm over a dense body, turned 20 degrees about its own centre
    while the body stays: every goal frame of the box's particles is that turn, every body particle's the
    identity. The goal fit takes each particle's 16 nearest rest vertices of its own piece (mesh/goal_fit.c);
    before, they were the nearest of any piece: the box's particles, mostly fitted to the body's vertices, turned
    0-2 degrees (the kid's backpack followed its chest: docs/goals.md)."""
    body, box = meshes.capsule(radius=0.2, length=0.6), meshes.bar(length=0.24, width=0.1, segments=1, cross=1)
    v = np.vstack([body[0], box[0] + (-0.12, 0.0, 0.225 - box[0][:, 2].min())])
    t = np.vstack([body[1], box[1] + len(body[0])])
    g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces="own")
    count, piece = mesh.mesh_pieces(g)
    on_box = piece == piece[np.argmax(g.centers[:, 2])]
    assert count == 2 and 4 <= on_box.sum() < particles // 2
    a = np.radians(20.0)
    turn = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    animated, middle = v.copy(), v[len(body[0]):].mean(axis=0)
    animated[len(body[0]):] = (v[len(body[0]):] - middle) @ turn.T + middle
    fit = opdeform.GoalFit(g, v)
    positions, rotations = fit.fit(animated)
    assert np.all((fit.indices >= len(body[0])) == on_box[:, None])
    np.testing.assert_allclose(rotations[on_box], np.broadcast_to(turn, (on_box.sum(), 3, 3)), atol=1e-9)
    np.testing.assert_allclose(positions[on_box], (g.centers[on_box] - middle) @ turn.T + middle, atol=1e-9)
    np.testing.assert_allclose(rotations[~on_box], np.broadcast_to(np.eye(3), ((~on_box).sum(), 3, 3)), atol=1e-9)


def card(width=0.04, length=0.3, rows=6):
    """An open strip (a hair card: a sheet of no thickness, 2 x rows + 1 vertices) standing up from the top of
    the kitbash's body (with_shell), its root 2 cm inside it."""
    z = 0.28 + np.linspace(0.0, length, rows + 1)
    v = np.array([[x, 0.0, zi] for zi in z for x in (-width / 2, width / 2)])
    p = 2 * np.arange(rows)
    return v, np.vstack([np.column_stack((p, p + 1, p + 3)), np.column_stack((p, p + 3, p + 2))])


def swing_card(particles, frames=36):
    """The body with a card (with_shell(card())) carried 0.4 m sideways in 6 frames, then still: goals carrying
    the rest, Follow 1 on the body and the card's root to 0.37 at its tip (the add-on's Shell Min lifts a painted
    0.1), Fleshy's 3 MPa and 9/s at 24 fps, 10 substeps. Returns (the card tip's largest offset from its goal
    during the motion, 1 s after it, and the card's longest mesh edge over its rest length)."""
    cv, ct = card()
    v, t = with_shell((cv, ct))
    first = len(v) - len(cv)
    s = np.clip((v[:, 2] - 0.3) / 0.28, 0.0, 1.0)
    follow = np.where(np.arange(len(v)) >= first, 1.0 - 0.63 * s, 1.0)
    g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces="own")
    dt, fit, skin = 1.0 / 240.0, opdeform.GoalFit(g, v), opdeform.Skin(g, v)
    sim = opdeform.Simulation(g, opdeform.materials.stiffness_for(g, 3e6), density=1050.0, dt=dt,
                              gravity=(0.0, 0.0, 0.0), damping=opdeform.materials.step_damping(9.0, dt))
    sim.set_goal_strength(np.clip(fit.particle_values(follow), 0.0, 1.0))
    sim.set_goals_carry_rest(True)
    e = np.unique(np.sort(t[t.min(axis=1) >= first][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    rest = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
    tip = len(v) - 1
    swing, after, stretch = 0.0, 0.0, 1.0
    for f in range(frames):
        x = min(f / 6.0, 1.0)
        shift = [0.0, 0.4 * x * x * (3.0 - 2.0 * x), 0.0]
        sim.set_goals(*fit.fit(v + shift))
        sim.step(10)
        p = skin.deform(sim.positions, sim.rotations)
        offset = np.linalg.norm(p[tip] - v[tip] - shift)
        swing = max(swing, offset) if f < 6 + 12 else swing
        after = offset if f == 6 + 24 else after
        stretch = max(stretch, (np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1) / rest).max())
    return swing, after, stretch


@pytest.mark.parametrize("particles", [50, 100, 400])
def test_a_card_on_a_moving_body_swings_without_stretching(particles):
    """A hair card (an open strip of its own reaching out of the body) counts as a long shell: SHELL_PARTICLES
    particles (never more than its voxels: 6 at 50 particles), linked at its root, its own k / E where stiffer
    than the body's (materials._own_cards). Carried 0.4 m sideways its tip swings 24-90 mm behind its goal
    (50-400 particles), is within 0.4 mm of it 1 s after, and no edge of it stretches past 1.02x. Before, 4
    particles skinned rigidly and linked all along: 0.00-0.03 mm (the outside bird's cards, docs/goals.md). An
    open patch inside the body (bpy 5.2's Skin modifier leaves such in gob's) keeps its 4."""
    swing, after, stretch = swing_card(particles)
    assert swing > 0.015, f"the card's tip swung {1e3 * swing:.1f} mm"
    assert after < 2e-3, f"{1e3 * after:.2f} mm 1 s after the motion"
    assert stretch < 1.5, f"a card edge {stretch:.2f}x its rest length"
    v, t = card()
    patch = v[:6] * [2.0, 1.0, 1.0] - [0.0, 0.0, 0.28]  # 8 x 10 cm, at the body's axis
    shells = (np.vstack([v, patch]), np.vstack([t, t[[0, 1, 6, 7]] + len(v)]))
    g = opdeform.Graph.from_mesh(*with_shell(shells), particles=particles, small_pieces="own")
    count, of = mesh.mesh_pieces(g)
    per_piece = np.bincount(of)
    assert count == 3 and per_piece[1] > COMPACT_PARTICLES and per_piece[2] == COMPACT_PARTICLES, per_piece


@pytest.mark.parametrize("particles", [50, 100, 400])
def test_a_card_leaves_its_host_a_body(particles):
    """A card on a head that is a connected piece of the graph of its own (a large piece beside the body: the
    outside bird's crest, docs/goals.md) leaves the head's k / E within 1.25x of the head's alone (3.9-10.3), and
    the card takes its own, stiffer. Before, the head with an open card in its part of the mesh was calibrated
    as a hanging sheet (materials._sheets_floored): 2.8-4.6x softer, the card with it."""
    head = meshes.capsule(radius=0.22, length=0.2)
    head = (head[0] + [1.3, 0.0, 0.0], head[1])
    cv, ct = card()
    alone = with_shell(head)
    both = with_shell((np.vstack([head[0], cv + [1.3, 0.0, -0.08]]), np.vstack([head[1], ct + len(head[0])])))
    k = []
    for v, t in (alone, both):
        g = opdeform.Graph.from_mesh(v, t, particles=particles, small_pieces="own")
        of = mesh.mesh_pieces(g)[1]
        k.append([opdeform.materials.stiffness_for(g, 1e6)[of == p].mean() for p in np.unique(of)])
        assert g.pieces()[0] == 2
    assert 1 / 1.25 < k[1][1] / k[0][1] < 1.25 and k[1][2] > k[1][1], k
