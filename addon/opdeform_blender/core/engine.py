"""The simulation behind one Blender object, free of bpy: rest mesh -> graph -> simulation -> skinned vertices.

The Blender layer reads the object's settings, mesh, vertex groups, handle transforms and, each frame, the
*input*: the object-space vertices that reach opdeform's modifier (the rest mesh deformed by shape keys, an
Armature, ...) and the object's transform. The engine never writes the mesh: it returns ``Engine.offset``
(float32, object space), which opdeform's Geometry Nodes modifier adds to that input, and ``Engine.out`` =
input + offset, which is exactly what the modifier shows (the same float32 addition). Bakes and live
playback both go through ``goto``, so a bake equals playback bit for bit.

The simulation runs in world space. Without a goal the world is the one of the object's transform at Build
and offset = skin(state) - skin(rest frames). With a goal each frame's input, placed by the object's current
transform, is fitted to per-particle goal frames (``GoalFit``) that pull the particles with the goal strength
and carry the rest shape (the animated shape is the equilibrium, docs/goals.md), and offset = skin(state) -
skin(goal frames), times each vertex's lock (0 where it follows fully): secondary motion layered on the
animation, none where the follow value is 1.

Longer than the add-on's 350-line rule, on purpose: it is one class whose configuration, cache, goals and
output all read the same simulation and cache, and every path to a frame (playback, bake, contact groups in
core/contact.py) goes through ``begin``/``simulate``; the bpy-free helpers around it already live in
frames.py, cache.py, checks.py, colliders.py, fields.py and handles.py.
"""

import time

import numpy as np

from . import checks
from . import frames as frame_logic
from . import handles as handle_math
from .cache import StateCache
from .colliders import NOTHING, SceneColliders, blend as blend_surroundings
from .fields import SceneFields
from .frame_report import FrameReports, Stretch, report

GRAPH_MODES = ("auto", "volume", "surface", "chain")
# A vertex shows min(1, LOCK_RAMP (1 - follow)) of its simulated offset: follow 1 is the animation exactly (a
# particle's strength is the least of its vertices', so a core vertex near a soft region would otherwise take
# that region's lag), follow 0.9 and below the whole offset.
LOCK_RAMP = 10.0
LINK_SOFTNESS_MIN = 1e-6  # jiggle_softness's floor: a link softness is > 0
HELD_FOLLOW = 0.9  # the jiggle rule: a particle this held by its goal (a 200 Hz spring) holds the flesh around it
# the jiggle rule: a soft patch is enclosed by held flesh (a belly) when its farthest reach from it is at most this
# share of its extent (its box's diagonal and a link each side); one held at one end (a worm's top) reaches ~0.9
ENCLOSED_REACH = 0.65
# the jiggle rule: a soft patch with more particles than the held flesh has rings higher than the look's frequency,
# by (its particles / the held ones) to this power: a body painted soft nearly all over (Blender's Suzanne with
# Follow 1 -> 0.1 from the chin up, 96 of 100 particles soft, 4 held) keeps its shape (stretched 3.2x at Fleshy;
# 1.22x at power 1). The knight's belly (13 particles, 0.12 of its held) keeps the look's; the outside bear's belly
# and cheeks, 0.78 of its held counted on its body (region_frequency's ``counted``), too (1.37 with its shells').
PATCH_SHARE_POWER = 1.5
# The stretch bound while the jiggle rule softens links (Simulation.set_stretch_limit): a link that would stretch the
# mesh edges between its ends past this by a frame's end stiffens its ends for that frame (docs/goals.md, "Stretch
# bound (stop 48)").
STRETCH_LIMIT = 1.2
# the jiggle rule on a detached shell (docs/goals.md, "Shells (stop 48)"): only one linked to the body, closed or an
# open one linked all along (a cape, "An open cape linked all along (stop 49)"), and long (its particles spread this
# much more along one axis than the next, as the core's od_BeamShell): a ponytail. Cards (the fish's fins) swing far
# below their particles' frequency already, and short ones (the bear's ears) stretched 2.1-3.1x softened (under 1.1x
# left alone).
LONG_SHELL = 1.5
# the jiggle rule on a shell the core moves rigidly (its SMALL_PIECE_PARTICLES: one set of skin weights over them) at
# least this link softness: it cannot bend, and its particles turned apart shear it. The outside dancer's skirt
# cards (4 particles each at 100) stretched 1.51x at the rule's 0.006, 1.39x at 0.01 swinging 85 mm, 1.13x at 0.03
# swinging 27 mm (docs/goals.md, "Cards and ribbons (stop 50)").
RIGID_SHELL_SOFTNESS = 0.01
SHELL_LOAD = 1.0  # shell_frequency: the acceleration (m/s^2) a shell's static deflection is found under
SHELL_ITERATIONS = 100  # shell_frequency: the static solve's iterations (its frequency within 0.1 % of 800's)
# the jiggle rule's damping of a limb (settle_rate): a swing as far as its reach comes within this share of the body's
# size (2 mm on a 2 m body, the aim) by SETTLE_S seconds; a limb swings less than its reach, so the outside
# blob's come within 2 mm by 0.79 s (docs/goals.md, "Loose parts settle within a second (stop 50)")
SETTLE_SHARE = 1e-3
SETTLE_S = 1.0
IDENTITY = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
SAMPLE_STRIDE = 64  # _same_points: rows compared before the whole arrays


class EngineError(ValueError):
    """Bad input from the scene (a mesh without faces, an empty pin group, ...): a message for the user."""


def check_matrix(matrix):
    """The object's 4x4 transform (None: identity) as float64; EngineError when degenerate or not finite. The
    determinant as a triple product of Python floats: LAPACK's took 0.06 ms a frame with cold caches (3.4)."""
    m = np.eye(4) if matrix is None else np.asarray(matrix, dtype=np.float64).reshape(4, 4)
    (a, b, c), (d, e, f), (g, h, i) = m[:3, :3].tolist()
    if not np.all(np.isfinite(m)) or abs(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)) < 1e-12:
        raise EngineError("the object's transform is degenerate or not finite")
    return m


def unturned(m):
    """Whether a 4x4 transform's 3x3 part is the identity (-0.0 as 0.0): one list compare, 0.0005-0.0007 ms warm
    where numpy's array_equal with a new identity took 0.004-0.006 (timeit, the system's python3)."""
    return m[:3, :3].tolist() == IDENTITY


def to_world(local, m, out=None):
    """Object-space points (V, 3) placed by the 4x4 transform m, float64, into ``out`` when given (a kept (V, 3)
    array: a fresh one cost 0.05 ms a frame in page faults for the character). An unturned, unscaled object (a
    rigged character parented to its rig) is only moved: the same values as the product by the identity, in
    0.004 ms where the product took 0.10 (5,752 vertices, Blender 3.4's numpy)."""
    out = np.empty((len(local), 3)) if out is None else out
    if unturned(m):
        np.copyto(out, local)
    else:
        np.dot(np.asarray(local, dtype=np.float64), m[:3, :3].T, out=out)
    if m[:3, 3].any():  # not at the origin (adding zeros would only turn -0.0 into 0.0)
        for axis in range(3):  # a column at a time: the (3,) row broadcast over the rows took 0.03 ms, this 0.01
            out[:, axis] += m[axis, 3]
    return out


def blend_goals(a, b, u):
    """Goal frames between two (positions, rotations) pairs: positions linearly, rotations linearly then made
    proper rotations again (for frames skipped by a jump, like the handle targets)."""
    u_, _, vt = np.linalg.svd((1.0 - u) * a[1] + u * b[1])
    flip = np.linalg.det(u_ @ vt) < 0
    u_[flip, :, -1] *= -1.0
    return (1.0 - u) * a[0] + u * b[0], u_ @ vt


def original_input(positions, index, n, before=()):
    """The input of the mesh's n vertices from what the evaluated mesh carries: the positions captured at
    opdeform's modifier (L, 3) and each one's vertex index there (L,) (None: not captured). A later modifier
    that keeps the original vertices first (Subdivision) leaves L > n with index[:n] = 0..n-1. EngineError
    when the count differs at the modifier itself (a modifier before it: ``before`` names the candidates, the
    enabled modifiers above it but the Armature) or the originals cannot be found."""
    count = len(positions)
    if count == n:
        return positions
    order = np.arange(count)
    if index is not None and len(index) == count and np.array_equal(index, order):
        which = f"one of the modifiers before OPDeform ({', '.join(before)})" if before else \
            "a modifier before OPDeform (e.g. Subdivision or Mirror)"
        raise EngineError(f"{which} changes the vertex count ({count} vertices reach OPDeform where the mesh has "
                          f"{n}): apply it, or move it after OPDeform")
    if index is not None and count > n and np.array_equal(index[:n], order[:n]):
        return positions[:n]
    raise EngineError(f"a modifier after OPDeform changes the vertex count ({count} where the mesh has {n}) "
                      "without keeping the mesh's vertices first (Subdivision, Mirror and Array keep them): turn "
                      "it off while playing and baking, or apply it before enabling")


def _check_finite(incoming):
    if not np.all(np.isfinite(incoming)):
        raise EngineError("the input (the goal positions) has non-finite (NaN or infinite) vertices")


def _same_points(a, b):
    """Whether two (V, 3) arrays are equal, rows a stride apart compared first (a moving input differs there)."""
    return np.array_equal(a[::SAMPLE_STRIDE], b[::SAMPLE_STRIDE]) and np.array_equal(a, b)


def _same(a, b):
    return a is b or (a is not None and b is not None and np.array_equal(a, b))


def elastic_frequency(graph, stiffness, density):
    """Each particle's elastic frequency (Hz) on its links with its neighbours held: sqrt(K / m) / 2π, K = k Σj
    (vi + vj) the global step's diagonal (METHOD.md, eq. 6), m = ρ vi; ``stiffness`` k a number or one per
    particle."""
    v = graph.volumes
    i, j = np.asarray(graph.edges).T
    links = np.bincount(i, v[i] + v[j], len(v)) + np.bincount(j, v[i] + v[j], len(v))
    return np.sqrt(np.asarray(stiffness) * links / (density * v)) / (2.0 * np.pi)


def _link_lengths(graph):
    """(i, j, length) of each link and each particle's mean link length."""
    c = graph.centers
    i, j = np.asarray(graph.edges).T
    length = np.linalg.norm(c[i] - c[j], axis=1)
    count = np.bincount(i, minlength=len(c)) + np.bincount(j, minlength=len(c))
    mean = (np.bincount(i, length, len(c)) + np.bincount(j, length, len(c))) / np.maximum(count, 1)
    return i, j, length, mean


def _relaxed(values, i, j, step, joined=None):
    """values lowered along the links until they hold: each at most a neighbour's plus ``step`` (per link), over
    the links ``joined`` (a mask; None: all). Bellman-Ford, a pass a link."""
    if joined is not None:
        i, j, step = i[joined], j[joined], np.broadcast_to(step, joined.shape)[joined]
    while True:
        lower = values.copy()
        np.minimum.at(lower, i, values[j] + step)
        np.minimum.at(lower, j, values[i] + step)
        if np.array_equal(lower, values):
            return values
        values = lower


def soft_patches(graph, held):
    """Each particle's soft patch (its least particle index over the links between particles not ``held``; the
    number of particles where held)."""
    i, j = np.asarray(graph.edges).T
    n = len(graph.volumes)
    return _relaxed(np.where(held, n, np.arange(n)), i, j, 0, ~held[i] & ~held[j])


def region_frequency(graph, elastic_hz, held, counted=None):
    """Each particle's elastic frequency as a part of the soft patch it lies in, held where ``held`` (a mask):
    its own (``elastic_frequency``) times l / max(d, l), l its mean link length, d its distance along the links
    to the nearest held particle: a patch rings lower the farther it reaches from what holds it (as 1 / d, alike
    at any particle count, the elastic frequency growing as 1 / l). 0 on a patch that is not enclosed (its
    farthest reach over ENCLOSED_REACH of its extent: a part held at one end, which swings as a beam, far below
    this) and where nothing holds it. With it, each particle's patch's share: its particles over the held ones
    (0 where held), the patch's counted only where ``counted`` (None: everywhere; the engine counts the body's: a
    detached shell's soft particles linked into the patch, a larger part of the graph at fewer particles, gave
    the outside bear's belly a share of 1.69 / 1.37 / 0.79 at 50 / 100 / 400 particles, its body's 0.59 / 0.78 /
    0.65 of its held ones)."""
    _, _, length, mean = _link_lengths(graph)
    c = graph.centers
    far, patch, soft, reach = patch_reach(graph, held)
    extent = _box_diagonal(patch[soft], c[soft], len(c) + 1) + 2.0 * length.mean()
    enclosed = soft & (reach <= ENCLOSED_REACH * extent)[patch]
    counted = np.ones(len(c), bool) if counted is None else counted
    size = np.bincount(patch[soft & counted], minlength=len(c) + 1)
    share = np.where(soft, size[patch] / max(np.count_nonzero(held), 1), 0.0)
    return np.where(enclosed, elastic_hz * mean / np.maximum(np.where(soft, far, 0.0), mean), 0.0), share


def patch_reach(graph, held):
    """Per particle its distance along the links to the nearest held particle (``held`` a mask; inf where nothing
    holds it), its soft patch (``soft_patches``) and whether it is soft (not held, held by something); per patch
    (indexed by ``soft_patches``' number) the farthest distance of its soft particles."""
    i, j, length, _ = _link_lengths(graph)
    far = _relaxed(np.where(held, 0.0, np.inf), i, j, length)
    patch = soft_patches(graph, held)
    soft = ~held & np.isfinite(far)
    reach = np.zeros(len(far) + 1)
    np.maximum.at(reach, patch[soft], far[soft])
    return far, patch, soft, reach


def _box_diagonal(groups, points, count):
    """The diagonal of the box of the ``points`` of each group (``groups``: each point's, 0 .. count - 1; 0 for a
    group without a point)."""
    box = [np.full((count, 3), bound) for bound in (np.inf, -np.inf)]
    np.minimum.at(box[0], groups, points)
    np.maximum.at(box[1], groups, points)
    return np.linalg.norm(np.maximum(box[1] - box[0], 0.0), axis=1)


def rim_width(graph, held, patch, soft):
    """Per patch (``soft_patches``' number) the diagonal of the box of the held particles linked to it: a belly's rim
    spans the patch, a limb's is its root."""
    i, j = np.asarray(graph.edges).T
    rim = [(a[held[a] & soft[b]], b[held[a] & soft[b]]) for a, b in ((i, j), (j, i))]
    return _box_diagonal(np.concatenate([patch[b] for _, b in rim]),
                         np.concatenate([graph.centers[a] for a, _ in rim]), len(held) + 1)


def settle_rate(graph, held, size):
    """Per particle the velocity damping rate (per second) under which its soft patch, when held at one end (a limb:
    the held particles linked to it span less than its reach, ``rim_width``), swinging as far as its reach
    (``patch_reach``), comes within SETTLE_SHARE of ``size`` by SETTLE_S: damping the velocity at a rate g makes a
    swing's envelope decay as exp(-g t / 2) at any frequency, so a long limb, which swings farther, needs more than
    a short one (docs/goals.md, "Loose parts settle within a second (stop 50)"); 0 elsewhere (held, nothing holds
    it, or held all around: a belly swings a small share of its reach)."""
    _, patch, soft, reach = patch_reach(graph, held)
    limb = reach > rim_width(graph, held, patch, soft)
    rate = 2.0 * np.log(np.maximum(reach / (SETTLE_SHARE * size), 1.0)) / SETTLE_S
    return np.where(soft & limb[patch], rate[patch], 0.0)


def settle_damping(painted, rate, params):
    """Each particle's damping per step: ``painted``'s (None: the body's, ``params``' damping), at least a step's
    share of ``rate`` (per second and particle, ``settle_rate``; None: none) at ``params``' dt."""
    if rate is None:
        return painted
    return np.maximum(params["damping"] if painted is None else painted, -np.expm1(-rate * params["dt"]))


def _static_loads(od, graph, stiffness, density, held, softness):
    """For each axis: the axis and a simulation at rest under SHELL_LOAD along it, its particles ``held`` still,
    its links softened by ``softness`` (None: not)."""
    for axis in np.eye(3):
        sim = od.Simulation(graph, stiffness, density=density, gravity=SHELL_LOAD * axis)
        sim.set_link_softness(softness)
        for point in graph.centers[held]:
            sim.add_position_constraint(point)
        sim.set_solver("chebyshev")
        sim.solve_static(SHELL_ITERATIONS)
        yield axis, sim


def patch_sag_frequency(od, graph, stiffness, density, label, softness, skin):
    """The frequency (Hz) of each patch ``label`` numbers (per particle, 1 ..; 0: held still) as its mesh sags:
    sqrt(a / s) / 2π, s the largest static sag along a uniform acceleration a (each axis) of the vertices its
    particles skin, links softened by ``softness``; 0 where held and where no vertex shows the patch's sag (its
    particles skin none, or only vertices a patch numbered higher skins too). The mesh's, not the particles': one
    soft particle among held ones carries a spot its held neighbours' skin shares, fifteen carry it alone."""
    vertex_label = np.where(skin.weights > 0.0, label[np.maximum(skin.indices, 0)], 0).max(axis=1)
    rest = skin.deform(graph.centers, np.tile(np.eye(3), (len(label), 1, 1)))
    sag = np.zeros(label.max() + 1)
    for axis, sim in _static_loads(od, graph, stiffness, density, label == 0, softness):
        np.maximum.at(sag, vertex_label, (skin.deform_sim(sim, push_out=False) - rest) @ axis)
    sag[0] = 0.0
    shown = sag > 0.0
    hz = np.zeros(len(sag))
    hz[shown] = np.sqrt(SHELL_LOAD / sag[shown]) / (2.0 * np.pi)
    return hz[label]


def shell_frequency(od, graph, stiffness, density, label):
    """The lowest frequency (Hz) of each shell ``label`` numbers (per particle, 1 ..; 0: the body, held still) as it
    hangs from the body: the Rayleigh quotient of its static deflection u under a uniform acceleration a along
    each axis, w^2 = sum m a.u / sum m |u|^2 over its particles, the least of the three axes; 0 on the body."""
    mass = density * graph.volumes
    least = np.full(label.max() + 1, np.inf)
    for axis, sim in _static_loads(od, graph, stiffness, density, label == 0, None):
        u = sim.positions - graph.centers
        work = np.bincount(label, mass * SHELL_LOAD * (u @ axis), len(least))
        square = np.bincount(label, mass * (u * u).sum(axis=1), len(least))
        least = np.minimum(least, work / np.maximum(square, 1e-300))
    least[0] = 0.0
    return np.sqrt(np.maximum(least, 0.0))[label] / (2.0 * np.pi)


def swinging_shells(od, graph, piece, body, open_pieces):
    """Per particle, 1 + its mesh piece where that piece is a detached shell the jiggle rule takes, else 0: linked to
    the body in the graph; closed (not of ``open_pieces``, ``checks.open_pieces``), or open and linked to the body
    all along (``_linked_all_along``: a cape behind a wide body, inside its bounding box, which the core takes for
    a patch on it, not a card linked at its root); long: LONG_SHELL, of three particles or more, as two are always
    "long"). ``od``: the opdeform module (its ``mesh`` constants)."""
    _, linked = graph.pieces()
    label = np.zeros(len(piece), dtype=np.int64)
    for p in np.unique(piece[(piece != body) & (piece >= 0)]):
        mine = piece == p
        c = graph.centers[mine] - graph.centers[mine].mean(axis=0)
        spread = np.sqrt(np.maximum(np.linalg.eigvalsh(c.T @ c), 0.0))
        taken = p not in open_pieces or _linked_all_along(od, graph, mine, piece == body)
        if taken and np.isin(linked[mine], linked[piece == body]).any() and \
                np.count_nonzero(mine) >= 3 and spread[2] > LONG_SHELL * spread[1]:
            label[mine] = p + 1
    return label


def _linked_all_along(od, graph, mine, body):
    """Whether an open shell ``mine`` (a mask) is linked to the body (a mask) all along, as the core links a patch on
    it: more of its particles linked to the body than a card linked at its root (``od.mesh.ROOT_LINKS``). Left
    alone by the jiggle rule, the outside chubby humanoid's open cape, so linked, moved 0.6 / 0.3 mm at 100 / 400
    particles (unlinked at 50, held by its goal alone, 100.8 mm); the outside dancer's skirt cards and hair ribbons,
    inside the bounding box of a body with its arms out and so patches to the core, 4 particles each
    (``od.mesh.SMALL_PIECE_PARTICLES``, taken since stop 50), 0.2 mm at 100 particles and 0.0 at 400
    (docs/goals.md, "Cards and ribbons (stop 50)")."""
    i, j = np.asarray(graph.edges, dtype=np.int64).reshape(-1, 2).T
    ends = np.unique(np.concatenate([i[mine[i] & body[j]], j[mine[j] & body[i]]]))
    return len(ends) > od.mesh.ROOT_LINKS


def jiggle_softness(elastic_hz, follow, jiggle_hz):
    """Per-particle link softness (``Simulation.set_link_softness``) that brings a particle of Follow f from its
    elastic frequency toward ``jiggle_hz``: (jiggle_hz / elastic)^(2 (1 - f)), the frequency interpolated in log
    by Follow (f = 1: unchanged), never stiffer (at most 1)."""
    with np.errstate(divide="ignore"):
        ratio = np.minimum(jiggle_hz / elastic_hz, 1.0)  # 1 where elastic_hz is 0 (nothing to soften)
    return np.maximum(ratio ** (2.0 * (1.0 - np.asarray(follow))), LINK_SOFTNESS_MIN)


def skin_gradient(indices, weights, edges, rest, links):
    """Per link (i, j) of ``links`` (L, 2), the most half the difference of its ends' skin weights,
    (w_j - w_i) / 2, changes per metre along a mesh edge (``edges``: its two (E,) end arrays, edges of nonzero
    length at ``rest``; ``indices``, ``weights``: the skin's (V, m)): a gap δ at the link's middle between the
    skin its ends carry stretches such an edge by about |δ| times it (Simulation.set_stretch_limit)."""
    a, b = edges
    out = np.zeros(len(links))
    if len(links) == 0 or len(a) == 0:
        return out
    length = np.linalg.norm(rest[a] - rest[b], axis=1)
    near = np.concatenate([indices[a], indices[b]], axis=1)  # the particles either end's skin names

    def weight(rows, c):
        return np.where(indices[rows] == near[:, c, None], weights[rows], 0.0).sum(axis=1)

    change = np.array([weight(a, c) - weight(b, c) for c in range(near.shape[1])]) / length
    n = int(max(indices.max(), links.max())) + 1
    key = np.sort(links, axis=1) @ [n, 1]
    order = np.argsort(key)
    for c, d in zip(*np.triu_indices(near.shape[1], 1)):
        lo, hi = np.minimum(near[:, c], near[:, d]), np.maximum(near[:, c], near[:, d])
        at = np.minimum(np.searchsorted(key, lo * n + hi, sorter=order), len(key) - 1)
        linked = (key[order[at]] == lo * n + hi) & (lo != hi)
        np.maximum.at(out, order[at[linked]], 0.5 * np.abs(change[d] - change[c])[linked])
    return out


def _same_params(a, b):
    """Whether two Simulation parameter dicts are equal (a stiffness may be one per particle)."""
    return b is not None and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)


class FrameRun:
    """One engine's way to a frame (``Engine.begin``): the frame's inputs and the plan (core/frames.py)."""

    def __init__(self, engine, frame, targets, incoming, matrix, goals, surroundings):
        self.engine, self.frame, self.targets, self.incoming, self.matrix = engine, frame, targets, incoming, matrix
        self.goals, self.surroundings = goals, surroundings
        self.plan = engine.plan(frame)
        self.last = self.before = self.inputs = None
        self.blended = False  # simulated past a jump (_restore_for)


def simulate(runs, step, budget=None):
    """The outputs of runs whose plans simulate the same frames (or of any runs with nothing to simulate):
    before each frame every engine takes its inputs, ``step()`` advances them all (one simulation's ``step``, or
    a contact group's), then each stores its state. With a ``budget`` (seconds) all stop at the same frame."""
    if runs[0].plan.kind != "simulate":
        return [r.engine._shown(r) for r in runs]
    for r in runs:
        r.engine._restore_for(r)
    plan, t0 = runs[0].plan, time.perf_counter()
    shown = plan.frame
    for k in plan.steps:
        for r in runs:
            r.engine._prepare(r, k)
        step()
        for r in runs:
            r.engine._stepped(r, k)
        if budget is not None and k < plan.frame and time.perf_counter() - t0 > budget:
            shown = k
            break
    seconds = time.perf_counter() - t0
    return [r.engine._reached(r, shown, seconds) for r in runs]


def canonical_triangles(triangles):
    """The triangles in one order whatever order they came in, each turned to start at its smallest vertex (its
    winding kept), sorted by its largest vertex, then the middle, the smallest and the one after the smallest: the
    order of a mesh made vertex by vertex. The graph follows the triangles' order (opdeform.Graph.from_mesh:
    pieces numbered by their first triangle, sums in that order), and Blender's bmesh lists a mesh's faces in
    another order from run to run: one 3.4.1 run of ellie in four built another graph (2.66 against 6.47 mm 1 s
    after the motion; docs/goals.md, "Run to run")."""
    t = np.asarray(triangles, dtype=np.int32).reshape(-1, 3)
    first = np.argmin(t, axis=1)
    turned = np.take_along_axis(t, (first[:, None] + np.arange(3)) % 3, axis=1)
    by_size = np.sort(t, axis=1)
    return np.ascontiguousarray(turned[np.lexsort((turned[:, 1], by_size[:, 0], by_size[:, 1], by_size[:, 2]))])


def triangle_edges(triangles):
    """The distinct edges (E, 2) of triangles (T, 3)."""
    t = np.asarray(triangles).reshape(-1, 3)
    pairs = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    return np.unique(pairs, axis=0)


class Engine:
    def __init__(self, od, rest_local, triangles, matrix_world=None, particles=100, mode="auto",
                 neighbors=4, small_pieces="attach", edges=None):
        self.od = od
        rest_local = np.asarray(rest_local, dtype=np.float32).reshape(-1, 3)
        triangles = canonical_triangles(triangles)
        if len(rest_local) == 0:
            raise EngineError("the mesh has no vertices")
        if len(triangles) == 0:
            raise EngineError("the mesh has no faces: oriented particles need a surface or a volume")
        if not np.all(np.isfinite(rest_local)):
            raise EngineError("the mesh has non-finite vertex coordinates")
        if mode not in GRAPH_MODES:
            raise EngineError(f"graph mode must be one of {', '.join(GRAPH_MODES)}, got {mode!r}")
        m = check_matrix(matrix_world)
        self.rest_local = np.ascontiguousarray(rest_local)
        self.rest = to_world(self.rest_local, m)
        self.matrix_world = m
        self.triangles = triangles
        # a low-poly mesh (the default cube) cannot hold more particles than it has distinct vertices
        distinct = len(np.unique(self.rest_local, axis=0))
        self.particles_clamped = int(particles) > distinct
        particles = min(int(particles), distinct)
        try:
            self.graph = od.Graph.from_mesh(self.rest, triangles, particles=int(particles), mode=mode,
                                            small_pieces=small_pieces)
            self.skin = od.Skin(self.graph, self.rest, neighbors=int(neighbors))
        except ValueError as exc:
            raise EngineError(f"building the particle graph failed: {exc}") from None
        self.neighbors = int(neighbors)
        n = self.graph.n_particles
        self._rest_state = (self.graph.centers, np.tile(np.eye(3), (n, 1, 1)), np.zeros((n, 3)), np.zeros((n, 3)))
        self.out = np.empty((len(self.rest), 3), dtype=np.float32)
        self.offset = np.zeros((len(self.rest), 3), dtype=np.float32)
        self._rest_skin = self.skin.deform(*self._rest_state[:2])
        self.fit = None
        self.goal_strength = None  # per-particle goal strengths, None: no goal
        self.follow = None  # per-vertex follow values of the goal, None: no goal
        # (V, 3) share of the simulated offset each vertex shows, 0 where follow is 1: one value a vertex repeated
        # on its three axes, as a (V, 1) column broadcast costs 5x a plain product (0.018 -> 0.004 ms, 5.2)
        self._lock = None
        self._softness = None  # set_regions' per-particle stiffness scale (None: 1)
        self._damping = None  # set_regions' per-particle damping per step (None: the body's)
        self._links = None  # set_regions' per-particle link softness of the jiggle rule (None: 1)
        self._painted = None  # set_goal's per-particle Follow before Shell Min
        self._jiggle_key, self._jiggle = None, None  # _jiggle_links' inputs and answer, found again when they change
        self._given = None  # configure's last parameters, before the softness map
        self.sim = None
        self.colliders = None  # the scene's colliders in the simulation (core/colliders.py)
        self.fields = None  # the scene's force fields in the simulation (core/fields.py)
        self.self_contact = None  # set_self_contact's arguments (None: off)
        self.skin_between = False  # whether the skin meets the other bodies too (set_contact)
        self.body_contact = (0.005, 0.5)  # (gap m, friction) with other engines' bodies (core/contact.py)
        self.partners = None  # the contact group this engine's cache was simulated in (None: alone)
        self._params = None
        self._substeps = 1
        self._floor = None
        self._constraint_key = None
        self._constraint_args = None  # set_constraints' last arguments, re-applied when the stiffness changes
        self._handle_ids = []
        self._pin_ids = []
        self.cache = StateCache()
        self.reports = FrameReports()
        self.stretch = Stretch(self.graph.edges, self.graph.centers)  # the reports' largest particle edge stretch
        # the mesh's (edges: the mesh's own, (E, 2); None: its triangles'), added to the report of the frame shown
        # when asked (report)
        self.mesh_stretch = Stretch(triangle_edges(triangles) if edges is None else edges, self.rest_local)
        self._gradient = None  # the stretch bound's skin gradient (_skin_gradient)
        self.shown_frame = None  # the cached frame whose output ``out`` holds (None: the rest, a pose, none yet)
        self.behind = 0  # frames a time-budgeted goto still has to simulate to reach the frame asked for
        self.thin_part = checks.thin_part(od, self.graph, self.rest, triangles)
        self.thin_appendages = checks.thin_appendages(od, self.graph, self.rest, triangles)
        self._pieces = None  # pieces()'s answer, found once: the graph never changes
        self._open_pieces = None  # the mesh pieces with an open edge (checks.open_pieces), found once
        self._solver = None
        self.solver_frame = None
        self.start, self.end = 1, 250
        self.timing = {"solver": 0.0, "skin": 0.0}
        self.shown_state = self._rest_state[:2]
        self._last_pushed = None  # (frame, its positions array, its pushed-out skin): _push_out's last
        self._buffers = {}  # name -> (V, 3) array (_buffer)
        self._fitted = None  # (its input, the goal frames) of the last fit (goal_frames)
        self._fitted_shift = np.zeros(3)  # the translation of the last float32 fit (goal_frames)
        self._referenced = None  # the goal frames whose skin the "reference" buffer holds (_reference)
        self._last_goals = None  # the goal frames of the last C pass's offset (_shown_reference)

    # -- configuration ---------------------------------------------------------------------------------
    @property
    def n_vertices(self):
        return len(self.rest)

    @property
    def timestep(self):
        """(dt per substep, substeps per frame): what engines stepping together must share."""
        return self._params["dt"], self._substeps

    def set_contact(self, self_contact=None, body_contact=(0.005, 0.5, False)):
        """Self-contact (``Simulation.set_self_contact``'s arguments, None: off) and the (gap, friction, skin) with
        other bodies: skin, this body's skin meets them (else its particles' ellipsoids do; its skin meets the floor
        and colliders either way). A change of self-contact or of the shape outdates the cache (of the bodies'
        contact: core/contact.py)."""
        gap, friction, skin = body_contact
        self.body_contact = (float(gap), float(friction))
        changed = False
        if self_contact != self.self_contact:
            try:
                self.sim.set_self_contact(self_contact is not None, **(self_contact or {}))
            except ValueError as exc:
                raise EngineError(f"self collision: {exc}") from None
            self.self_contact = self_contact
            changed = True
        if bool(skin) != self.skin_between:
            self.sim.set_contact_skin(self.skin, bodies=bool(skin))
            self.skin_between = bool(skin)
            changed = True
        if changed:
            self.invalidate()
        return changed

    def configure(self, params, substeps=1, floor=None, start=1, end=250, solver=None):
        """params: stiffness, density, dt (per substep), iterations, gravity, damping. floor: (height, friction)
        or None. solver: ``set_solver`` arguments (None: the default solver). A change clears the in-memory
        cache (it is outdated). Returns True when something changed."""
        error = frame_logic.range_error(int(start), int(end))
        if error:
            raise EngineError(error)
        self._given = params = dict(params, skin_neighbors=self.neighbors)
        if self._softness is not None:  # the softness map: a per-particle stiffness is the core's stiffness scale
            params = dict(params, stiffness=params["stiffness"] * self._softness)
        changed = False
        if self.sim is None:
            self.sim = self.od.Simulation(self.graph, **params)
            # the skin meets the floor and colliders; in a group the other bodies meet the ellipsoids unless
            # set_contact says skin (core/contact.py)
            self.sim.set_contact_skin(self.skin, bodies=self.skin_between)
            self.colliders = SceneColliders(self.sim)
            self.fields = SceneFields(self.sim)
            changed = True
        elif not _same_params(params, self._params):
            self.sim.set_params(**params)
            changed = True
            if self._constraint_args is not None:  # weights relative to the new stiffness
                self.set_constraints(*self._constraint_args)
        self._params = params
        solver = solver or dict(accelerator="none", tolerance=0.0)
        if solver != self._solver:
            self.sim.set_solver(**solver)
            self._solver = solver
            changed = True
        if floor != self._floor:
            if floor is None:
                self.sim.clear_floor()
            else:
                self.sim.set_floor(*floor)
            self._floor = floor
            changed = True
        if int(substeps) != self._substeps or (int(start), int(end)) != (self.start, self.end):
            self._substeps = max(1, int(substeps))
            self.start, self.end = int(start), max(int(end), int(start))
            self.cache.keep = self.start
            changed = True
        if changed:
            self.invalidate()
        return changed

    def invalidate(self, keep_until=None):
        """Marks the cache outdated: all of it, or the frames after keep_until."""
        self.reports.truncate(keep_until)
        if keep_until is None:
            self.cache.clear()
            self.solver_frame = None
        else:
            self.cache.truncate(keep_until)
            if self.solver_frame is not None and self.solver_frame > keep_until:
                self.solver_frame = None

    def set_constraints(self, pin_indices=(), pin_weights=None, pin_strength=1.0, handles=()):
        """Pins (vertex indices and weights, as a vertex group gives them; strength scales the solver's default
        weight) and handles (sequence of (vertex index, use_rotation, strength)). Re-adds the constraints only
        when they changed or the default weights did (``configure`` with another stiffness re-adds them);
        then the cache is outdated."""
        pin_indices = np.asarray(pin_indices, dtype=np.int64).ravel()
        pin_weights = (np.ones(len(pin_indices)) if pin_weights is None
                       else np.asarray(pin_weights, dtype=np.float64).ravel())
        handles = tuple((int(v), bool(r), float(s)) for v, r, s in handles)
        # the default weights follow the stiffness (1000 k v): constraints added under another k (the solver
        # units an object is built with before its material applies) would hold 4000x too loosely
        key = (pin_indices.tobytes(), pin_weights.tobytes(), float(pin_strength), handles,
               self.sim.default_weight("position"), self.sim.default_weight("direction"))
        self._constraint_args = (pin_indices, pin_weights, pin_strength, handles)
        if key == self._constraint_key:
            return False
        for h in self._handle_ids:
            for cid in h:
                self.sim.remove_constraint(cid)
        for cid in self._pin_ids:
            self.sim.remove_constraint(cid)
        self._pin_ids, self._handle_ids = [], []
        self._constraint_key = None
        if len(pin_indices):
            if pin_indices.min() < 0 or pin_indices.max() >= self.n_vertices:
                raise EngineError("pin vertex index out of range")
            base = float(pin_strength) * self.sim.default_weight("position")
            self._pin_ids = list(self.od.pin_vertices(self.sim, self.rest, pin_indices, weights=pin_weights,
                                                      weight=base))
        for vertex, use_rotation, strength in handles:
            if not 0 <= vertex < self.n_vertices:
                raise EngineError(f"handle vertex {vertex} out of range")
            ids = list(self.od.pin_vertices(self.sim, self.rest, [vertex],
                                            weight=strength * self.sim.default_weight("position")))
            if use_rotation:
                wd = strength * self.sim.default_weight("direction")
                ids += [self.od.add_vertex_direction(self.sim, self.rest, vertex, axis, weight=wd)
                        for axis in np.eye(3)]
            self._handle_ids.append(ids)
        self._constraint_key = key
        self.invalidate()
        return True

    @property
    def n_constraints(self):
        return len(self._pin_ids) + sum(len(h) for h in self._handle_ids)

    def _apply_targets(self, targets):
        if targets is None:
            return
        for ids, t in zip(self._handle_ids, targets):
            self.sim.set_constraint_target(ids[0], t[0])
            for cid, direction in zip(ids[1:], t[1:]):
                self.sim.set_constraint_target(cid, direction)

    def set_goal(self, strength, vertex_weights=None, follow_range=(0.0, 1.0), shell_min=0.0):
        """The goal (docs/goals.md): None (off), or how closely each vertex follows the animated input, in [0, 1]:
        ``strength`` everywhere, or with a painted group's per-vertex weights w the value lo + w (hi - lo) of
        ``follow_range`` (Soft Body's Goal Min and Max; by default the weight itself), and then, with weights, on
        the particles of a detached shell (every mesh piece but the one with most particles) that value mapped into
        [shell_min, 1] (the add-on's Shell Min, SHELL_FOLLOW_MIN by default). 1 locks a vertex to the animation, 0
        leaves it free, values between are springs (``opdeform.goal_frequency``). The goals carry the rest shape:
        the animated shape is the equilibrium. A change outdates the cache."""
        follow = None
        if strength is not None:
            follow = self._follow(strength, vertex_weights, (*follow_range, shell_min))
            if self.fit is None:
                self.fit = self.od.GoalFit(self.graph, self.rest)
        values = None if follow is None else self._particle_values(follow, lowest=True)
        self._painted = values  # the jiggle rule reads a shell's Follow as painted, before Shell Min
        if vertex_weights is not None and shell_min > 0.0:  # a painted Follow: a shell's held above shell_min
            values = self._shells_held(values, shell_min)
        if _same(values, self.goal_strength) and _same(follow, self.follow):
            return False
        self.sim.set_goal_strength(values)
        self.sim.set_goals_carry_rest(values is not None)
        self.goal_strength, self.follow = values, follow
        self._lock = None if follow is None else np.repeat(np.clip(LOCK_RAMP * (1.0 - follow), 0.0, 1.0)[:, None], 3,
                                                           axis=1)
        self.invalidate()
        return True

    def _shells_held(self, values, shell_min):
        """Per-particle Follow values with those of the detached shells, every mesh piece but the body, mapped
        into [shell_min, 1]."""
        count, piece, body = self.pieces()
        if count < 2:
            return values
        return np.where(piece != body, shell_min + (1.0 - shell_min) * values, values)

    def _particle_values(self, vertex_values, lowest=False):
        """Per-vertex values (a painted map) as per-particle values over each particle's goal-fit vertices (its 16
        nearest, or all if fewer, of its own mesh piece and the pieces it carries: GoalFit): their weighted mean
        (``GoalFit.particle_values``), or with ``lowest`` the least of them, so that a spot painted low (a soft
        belly among Follow 1) reaches the particles over it (their mean gave the outside knight's belly 0.45-0.94
        where 0.15 was painted, docs/goals.md) and a particle whose vertices are all 1 stays 1."""
        values = np.asarray(vertex_values, dtype=np.float64)
        if values.shape != (self.n_vertices,):
            raise EngineError(f"a map must have one value per vertex ({self.n_vertices}), got shape {values.shape}")
        return values[self.fit.indices].min(axis=1) if lowest else self.fit.particle_values(values)

    def pieces(self):
        """(the number of mesh pieces, each particle's piece, the body: the piece with most particles), pieces
        numbered as checks.vertex_pieces numbers them; found once (the panel asks at every redraw)."""
        if self._pieces is None:
            count, piece = self.od.mesh.mesh_pieces(self.graph)
            self._pieces = count, piece, int(np.argmax(np.bincount(piece[piece >= 0], minlength=count)))
        return self._pieces

    def _follow(self, strength, vertex_weights, limits):
        """The per-vertex follow values of ``set_goal`` (``limits``: its follow range and shell minimum);
        EngineError naming a value out of [0, 1]."""
        values = (strength, *limits)
        if not all(np.isfinite(v) and 0.0 <= v <= 1.0 for v in values):
            raise EngineError(f"the goal strength, its range and shell minimum must be in 0..1, got {strength}, "
                              f"{limits}")
        if vertex_weights is None:
            return np.full(self.n_vertices, float(strength))
        w = np.asarray(vertex_weights, dtype=np.float64)
        if len(w) != self.n_vertices or not np.all((w >= 0.0) & (w <= 1.0)):
            raise EngineError("goal weights must be one per vertex, in 0..1")
        lo, hi = limits[:2]
        return lo + w * (hi - lo)

    def set_regions(self, stiffness_scale=None, damping=None, jiggle_hz=None):
        """Per-vertex maps (a painted softness and damping; None: uniform) as per-particle values: the stiffness
        of each particle times ``stiffness_scale`` (> 0), and its damping per step in [0, 1] in place of the
        body's (relative to the goals' motion while a goal is on). ``jiggle_hz`` (None: off; needs a goal): each
        particle's links softened by its Follow toward that frequency (``jiggle_softness``) and its damping raised
        so that its soft patch settles (``settle_rate``). Call after
        ``configure`` and ``set_goal``. A change outdates the cache; a new softness refactors once."""
        if all(x is None for x in (stiffness_scale, damping, jiggle_hz, self._softness, self._damping, self._links)):
            return False
        if self.fit is None:
            self.fit = self.od.GoalFit(self.graph, self.rest)
        softness = None if stiffness_scale is None else self._particle_values(stiffness_scale, lowest=True)
        painted = None if damping is None else np.clip(self._particle_values(damping), 0.0, 1.0)
        links, rate = self._jiggle_links(jiggle_hz)
        per_particle = settle_damping(painted, rate, self._given)
        if _same(softness, self._softness) and _same(per_particle, self._damping) and _same(links, self._links):
            return False
        if softness is not None and not np.all(np.isfinite(softness) & (softness > 0.0)):
            raise EngineError("the softness map must be finite and > 0")
        try:
            self.sim.set_particle_damping(per_particle)
            self.sim.set_link_softness(links)
            self.sim.set_stretch_limit(0.0, None) if links is None else \
                self.sim.set_stretch_limit(STRETCH_LIMIT, self._skin_gradient())
        except ValueError as exc:
            raise EngineError(f"the damping map or the jiggle rule: {exc}") from None
        self._softness, self._damping, self._links = softness, per_particle, links
        given, self._params = self._given, None  # the stiffness with the new softness
        self.configure(given, self._substeps, self._floor, self.start, self.end, self._solver)
        self.invalidate()
        return True

    def _jiggle_links(self, jiggle_hz):
        """The jiggle rule's link softness and damping rate (``settle_rate``; (None, None): off, or no goal). The
        softness: on the body's particles, the mesh piece with most, by each one's Follow and patch frequency; on a
        long shell linked to the body (closed, or open and linked all along: ``swinging_shells``), one softness by
        its own frequency (``_shells_jiggle``); other shells keep 1
        (a slender card swings far below the elastic frequency of its particles: softened by it the outside fish's
        tail fin stretched 2.5x; docs/goals.md, "Jiggle", "Shells (stop 48)")."""
        if jiggle_hz is None or self.goal_strength is None:
            return None, None
        if not (np.isfinite(jiggle_hz) and jiggle_hz > 0.0):
            raise EngineError(f"the jiggle frequency must be > 0 Hz, got {jiggle_hz}")
        kept = self._jiggle_key
        if kept is None or not (_same(self.goal_strength, kept[0]) and _same_params(self._given, kept[1])
                                and jiggle_hz == kept[2] and _same(self._painted, kept[3])):
            given, (_, piece, body) = self._given, self.pieces()
            follow = self.goal_strength
            hz, share = region_frequency(self.graph, elastic_frequency(self.graph, given["stiffness"],
                                                                        given["density"]), follow >= HELD_FOLLOW,
                                         piece == body)
            target = jiggle_hz * np.maximum(share, 1.0) ** PATCH_SHARE_POWER
            softness = np.where(piece == body, jiggle_softness(hz, follow, target),
                                self._shells_jiggle(given, piece, body, jiggle_hz))
            self._jiggle = (self._patches_jiggle(given, np.where(piece == body, hz, 0.0), softness),
                            settle_rate(self.graph, follow >= HELD_FOLLOW, self.od.materials.body_size(self.graph)))
            # keyed once found (a failed solve finds it again), a shell's Follow as painted too
            self._jiggle_key = (follow, given, jiggle_hz, self._painted)
        return self._jiggle

    def _patches_jiggle(self, given, hz, softness):
        """``softness`` with each soft patch of the body (its particles of patch frequency ``hz`` > 0 linked
        without a held one between) scaled as one, so that the patch, hanging from the held flesh around it,
        sags as its softest particle is meant to ring (sqrt(r) hz, the rule's frequency for it): per particle the
        rule gives the same softness at any count, but the painted spot is one particle at 50 and fifteen at 400,
        and a patch of many soft particles sags and turns more (docs/goals.md, "Jiggle over the counts"). The
        patch's frequency is its mesh's static sag on the softened links (``patch_sag_frequency``); r scales as
        f^2, so one correction brings it within 1 % (a second moved the outside pig's, bear's and knight's r under
        0.5 %)."""
        taken = hz > 0.0
        if not taken.any():
            return softness
        patch = soft_patches(self.graph, self.goal_strength >= HELD_FOLLOW)
        label = np.zeros(len(hz), dtype=np.int64)
        label[taken] = np.unique(patch[taken], return_inverse=True)[1] + 1
        meant = np.full(label.max() + 1, np.inf)
        np.minimum.at(meant, label[taken], np.sqrt(softness[taken]) * hz[taken])
        rings = patch_sag_frequency(self.od, self.graph, given["stiffness"], given["density"], label, softness,
                                    self.skin)
        scaled = taken & (rings > 0.0)  # a patch whose sag no vertex shows keeps the rule's softness
        scale = (meant[label] / np.where(scaled, rings, 1.0)) ** 2
        return np.where(scaled, np.clip(softness * scale, LINK_SOFTNESS_MIN, 1.0), softness)

    def _skin_gradient(self):
        """``skin_gradient`` of the skin and the mesh's edges, found once."""
        if self._gradient is None:
            self._gradient = skin_gradient(self.skin.indices, self.skin.weights, self.mesh_stretch.ends, self.rest,
                                           np.asarray(self.graph.edges))
        return self._gradient

    def _shells_jiggle(self, given, piece, body, jiggle_hz):
        """The jiggle rule's link softness on the shells ``swinging_shells`` takes (1 elsewhere): each shell's links
        softened as one, from its lowest frequency (``shell_frequency``) toward ``jiggle_hz`` by the least Follow
        painted on it (before Shell Min): a ponytail painted 1 -> 0.1 rings near the look's frequency, one painted
        1 keeps its links."""
        if self._open_pieces is None:  # the mesh's, found once: it never changes
            self._open_pieces = checks.open_pieces(self.rest, self.triangles)
        label = swinging_shells(self.od, self.graph, piece, body, self._open_pieces)
        if not label.any():
            return 1.0
        hz = shell_frequency(self.od, self.graph, given["stiffness"], given["density"], label)
        least = np.ones(label.max() + 1)
        np.minimum.at(least, label, self._painted)
        rigid = (label > 0) & (np.bincount(label)[label] <= self.od.mesh.SMALL_PIECE_PARTICLES)
        softness = jiggle_softness(hz, least[label], jiggle_hz)
        return np.where(rigid, np.maximum(softness, RIGID_SHELL_SOFTNESS), softness)

    def goal_frames(self, incoming, matrix):
        """The goal frames fitted to this frame's input (object-space vertices placed by matrix). An input placed
        as the last fit's gives its goal frames again, the same objects, so their skin is kept too
        (``_reference``): a held pose skips both (a fit depends on its input alone: the same bits). An unturned,
        unscaled object with a float32 input (Blender's): ``_followed``; another placed in float64 (``to_world``),
        compared by that, kept by swapping two buffers."""
        if self._follows(incoming, matrix):
            return self._followed(incoming, matrix)
        kept = self._fitted
        world = to_world(incoming, matrix, self._buffer("world_input"))
        if kept is not None and kept[0] is self._buffers.get("fitted_world") and _same_points(kept[0], world):
            return kept[1]
        goals = self.fit.fit(world)
        self._buffers["world_input"] = self._buffer("fitted_world")
        self._buffers["fitted_world"] = world
        self._fitted = (world, goals)
        return goals

    def _follows(self, incoming, matrix):
        """Whether a frame's goal frames come from ``_followed``, which checks the input finite itself."""
        return (self.goal_strength is not None and incoming.dtype == np.float32 and incoming.flags.c_contiguous
                and unturned(matrix))

    def _followed(self, incoming, matrix):
        """The goal frames of an unturned object's float32 input in one C call (``GoalFit.follow``: the input
        checked finite, compared with the last fit's and its translation, fitted from it and the translation
        with no float64 world copy, and kept), where numpy checked, compared and copied before."""
        kept = self._fitted
        given = self._buffer("fitted_input", np.float32)
        valid = kept is not None and kept[0] is given
        try:
            goals = self.fit.follow(incoming, matrix[:3, 3].copy(), given, self._fitted_shift, valid)
        except ValueError:
            _check_finite(incoming)
            raise
        if goals is None:
            return kept[1]
        self._fitted = (given, goals)
        return goals

    # -- state ----------------------------------------------------------------------------------------
    def _state(self):
        """What a cached frame continues from: the state, the goals' motion while they carry the rest (their
        velocities damp the step: a frame simulated again after a jump back needs them for the same bits) and the
        floor's and colliders' normal forces the next step starts from (``Simulation.surface_forces``)."""
        s = self.sim
        return (s.positions, s.rotations, s.velocities, s.angular_velocities, s.goal_motion, s.surface_forces)

    def reset(self, targets=None, goals=None, surroundings=NOTHING):
        """The start frame: the rest state, or the goal frames at rest (velocity 0) with a goal, the colliders
        placed where they are at the start; the cache's start entry is (re)written."""
        state = self._rest_state if goals is None else (goals[0], goals[1], *self._rest_state[2:])
        self.colliders.place(surroundings.colliders)
        self.colliders.remember(self.start, surroundings)
        self.sim.set_state(*state)
        self._apply_targets(targets)
        self._apply_goals(goals)
        if goals is not None:  # the goals start still, whatever was simulated before
            n = self.graph.n_particles
            self.sim.set_goal_motion((np.zeros((n, 3)), np.zeros((n, 3)), -1))
        state = (*state, self.sim.goal_motion, self.sim.surface_forces)
        self.solver_frame = self.start
        self.cache.store(self.start, state, targets, goals)
        self._push_out(self.start)

    def _restore(self, frame):
        self.colliders.place(self.colliders.at(frame, NOTHING).colliders)
        state = self.cache.state(frame)
        self.sim._core.restore_state(*state[:4])  # as kept: set_state's re-orthonormalising moves a contact's replay
        self._apply_goals(self.cache.goals(frame))
        self.sim.set_goal_motion(state[4])
        self.sim.set_surface_forces(state[5])
        self.solver_frame = frame

    def _apply_goals(self, goals):
        if goals is not None:
            self.sim.set_goals(*goals)

    # -- output ---------------------------------------------------------------------------------------
    def _push_out(self, frame):
        """Keeps with the cached frame the simulation has just reached its skinned vertices that its colliders
        and floor (placed for this frame only now) push out to their surface: the frame shows them so whenever
        it is shown (docs/contact.md, "What the mesh shows"). The whole skin is kept for the frame's own
        showing, which usually follows. Part of the solver's time (it runs between steps)."""
        if self.sim.n_colliders == 0 and self._floor is None:
            return
        state = self.cache.state(frame)
        skinned, out, differs = self._buffer("skinned"), self._buffer("pushed"), self._buffer("differs", bool)
        self.skin.deform(state[0], state[1], out=skinned)
        self.sim.push_out(skinned, out=out)
        np.not_equal(out, skinned, out=differs)
        moved = np.flatnonzero(differs[:, 0] | differs[:, 1] | differs[:, 2])  # any(axis=1): 1.3 ms at 100k
        self.cache.store_pushed(frame, (moved, out[moved]))
        self._last_pushed = (frame, state[0], out)

    def _buffer(self, name, dtype=np.float64):
        """A (V, 3) array kept for one use per frame: a 100k-vertex mesh's fresh arrays cost 1.4 ms of page faults
        each (measured)."""
        if name not in self._buffers:
            self._buffers[name] = np.empty((len(self.rest), 3), dtype=dtype)
        return self._buffers[name]

    def _skinned(self, positions, rotations, frame):
        """skin(state) (world), in a kept buffer; of a cached frame, with the vertices its colliders and floor
        pushed out."""
        last = self._last_pushed
        if frame is not None and last is not None and last[0] == frame and last[1] is positions:
            return last[2]
        out = self.skin.deform(positions, rotations, out=self._buffer("offset"))
        pushed = None if frame is None else self.cache.pushed(frame)
        if pushed is not None:
            out[pushed[0]] = pushed[1]
        return out

    def _emit(self, positions, rotations, goals, incoming, matrix, frame=None):
        """offset = (skin(state) - skin(goals)) times the goal's lock (world), in object space (goals None: the rest
        frames); out = incoming + offset. ``frame``: the cached frame whose state it is (its pushed-out vertices
        shown). An unturned, unscaled object with a float32 input (Blender's) in one C pass (``Skin.shown_offset``,
        the same bits as the numpy passes below: 0.10-0.12 -> 0.06-0.07 ms a frame in place during the hops at
        1,000 particles, bpy 5.2), the goals' skin made in that pass too while they move (``_shown_reference``)."""
        t = time.perf_counter()
        skinned = self._skinned(positions, rotations, frame)
        plain = unturned(matrix)
        if plain and incoming.dtype == np.float32 and incoming.flags.c_contiguous:
            self.skin.shown_offset(skinned, self._shown_reference(goals), self._lock, incoming, self.offset, self.out)
        else:
            moved = np.subtract(skinned, self._reference(goals), out=self._buffer("offset"))
            if self._lock is not None:
                moved *= self._lock
            if not plain:
                moved = np.matmul(moved, np.linalg.inv(matrix[:3, :3]).T, out=self._buffer("object_offset"))
            self.offset[:] = moved
            np.add(incoming, self.offset, out=self.out)
        self.timing["skin"] += time.perf_counter() - t
        self.shown_frame = frame
        self.shown_state = (positions, rotations)
        return self.out

    def _shown_reference(self, goals):
        """``Skin.shown_offset``'s reference: the goal frames themselves while they move (their skin made in the
        offset's pass, never stored: the goals' skin and the offset 0.20-0.23 -> 0.16-0.17 ms in place during the
        hops at 1,000 particles, bpy 5.2), else their skin kept (``_reference``: a held pose, the last frame's
        goals again, skins them once)."""
        moving = goals is not None and goals is not self._referenced and goals is not self._last_goals
        self._last_goals = goals
        return goals if moving else self._reference(goals)

    def _reference(self, goals):
        """The skin of the goal frames (the rest's without a goal), made again only for other goal frames."""
        if goals is None:
            return self._rest_skin
        if goals is not self._referenced:
            self.skin.deform(*goals, out=self._buffer("reference"))
            self._referenced = goals
        return self._buffer("reference")

    def report(self, frame):
        """The frame's Report (None: not simulated), with the mesh's edge stretch added while ``out`` shows that
        frame: measured when asked (the panel), not on every frame (0.15 ms for the 9,900 edges of a 4,902-vertex
        sphere, where reading the maps takes 0.04)."""
        if frame == self.shown_frame:
            self.reports.note_mesh(frame, self.mesh_stretch, self.out)
        return self.reports.get(frame)

    def overlay_matrix(self, matrix):
        """What carries the simulation's world to where the object shows it now (its transform matrix): the
        identity with a goal (the simulation follows the object), else the motion since Build."""
        return np.eye(4) if self.goal_strength is not None else np.asarray(matrix) @ np.linalg.inv(self.matrix_world)

    def rest_output(self, incoming=None):
        self.shown_frame = None
        self.shown_state = self._rest_state[:2]
        self.offset[:] = 0.0
        self.out[:] = self.rest_local if incoming is None else incoming
        return self.out

    # -- frames ---------------------------------------------------------------------------------------
    def goto(self, frame, targets=None, incoming=None, matrix=None, surroundings=NOTHING, budget=None):
        """The object-space vertices (float32 (V, 3), ``self.out``; ``self.offset`` is what was added to the
        input) of ``frame`` with handle targets (H, 4, 3) and the input (V, 3) and transform (4, 4) at that
        frame (None: the rest mesh and the transform at Build), and the scene's colliders and force fields at
        that frame (core/colliders.py ``Surroundings``, world space). Simulates what the cache lacks (see
        core/frames.py); frames skipped by a jump get blended handle targets, goals and colliders; a cached
        frame whose surroundings changed since is simulated again. ``budget`` (seconds, None: no limit): stop
        simulating once it is spent and show the last frame reached; ``self.behind`` says how many frames are
        still missing (a later call goes on from there). ``begin`` and ``simulate`` are its two halves, which
        core/contact.py runs for several engines stepping together."""
        run = self.begin(frame, targets, incoming, matrix, surroundings)
        return simulate([run], lambda: self.sim.step(self._substeps), budget)[0]

    def begin(self, frame, targets=None, incoming=None, matrix=None, surroundings=NOTHING):
        """A frame's inputs checked (EngineError on bad ones) and its plan (a ``FrameRun``); nothing simulated."""
        self.timing = {"solver": 0.0, "skin": 0.0}
        self.behind = 0
        incoming = self.rest_local if incoming is None else incoming
        matrix = self._frame_matrix(matrix, incoming)
        if not self._follows(incoming, matrix):  # else GoalFit.follow checks it
            _check_finite(incoming)
        goals = None if self.goal_strength is None else self.goal_frames(incoming, matrix)
        last = min(int(frame), self.end)  # the frame the plan reaches
        if self.colliders.outdated(last, surroundings) or self._reached_in_order(last):
            self.invalidate(keep_until=last - 1)
        return FrameRun(self, int(frame), targets, incoming, matrix, goals, surroundings)

    def _reached_in_order(self, frame):
        """Whether ``frame`` was simulated past a jump (from blended inputs) while the frame before it was not:
        playback reaching it in order simulates it again from its own inputs. Kept, a jump's frames replaced the
        animation between its ends (the knight's jump, Build at frame 96 and the frame shown, then played from 1:
        the flesh did not move)."""
        blended = self.cache.blended
        return frame in blended and frame - 1 in self.cache and frame - 1 not in blended

    def _frame_matrix(self, matrix, incoming):
        """The frame's transform checked (with a goal; without one the simulation keeps Build's); a non-finite
        input is named before a degenerate transform."""
        if self.goal_strength is None:
            return self.matrix_world
        try:
            return check_matrix(matrix)
        except EngineError:
            _check_finite(incoming)
            raise

    def plan(self, frame):
        return frame_logic.plan(frame, self.start, self.end, self.cache.last, self.solver_frame, self.cache.first)

    def _shown(self, run):
        """The output of a run with nothing to simulate (rest, reset or a cached frame)."""
        plan = run.plan
        if plan.kind == "reset":
            self.reset(run.targets, run.goals, run.surroundings)
        if plan.kind != "show":
            return self.rest_output(run.incoming)
        state, cached = self.cache.state(plan.frame), self.cache.goals(plan.frame)
        return self._emit(state[0], state[1], cached, run.incoming, run.matrix, plan.frame)

    def _restore_for(self, run):
        """Loads the state a run simulates from; what the frames it skips are blended from."""
        if run.plan.restore == "reset":
            self.cache.truncate(self.start)
            self.reset(run.targets, run.goals, self.colliders.at(self.start, run.surroundings))
        elif run.plan.restore is not None:
            self._restore(run.plan.restore)
        run.last = last = self.solver_frame
        run.blended = len(run.plan.steps) > 1 or last in self.cache.blended
        run.before = (self.cache.targets(last), self.cache.goals(last), self.colliders.at(last, run.surroundings))

    def _prepare(self, run, k):
        """The handle targets, goals and surroundings of step k (blended over the frames a jump skips)."""
        before, before_goals, before_surroundings = run.before
        u = (k - run.last) / (run.plan.frame - run.last)
        last = k == run.plan.frame
        tk = run.targets if last or run.targets is None or before is None else \
            handle_math.blend(before, run.targets, u)
        gk = run.goals if last or run.goals is None or before_goals is None else \
            blend_goals(before_goals, run.goals, u)
        sk = run.surroundings if last else blend_surroundings(before_surroundings, run.surroundings, u)
        self._apply_targets(tk)
        self._apply_goals(gk)
        self._surround(sk)
        run.inputs = (tk, gk, sk)

    def _stepped(self, run, k):
        """Stores step k's state (the simulation has just made it) with the inputs that made it."""
        tk, gk, sk = run.inputs
        fps = 1.0 / (self._params["dt"] * self._substeps)
        handle = checks.handle(self.od.materials, self.sim, self.cache.targets(k - 1) if k - 1 in self.cache
                               else None, tk, self._substeps, fps)
        self.solver_frame = k
        self.cache.store(k, self._state(), tk, gk, blended=run.blended)
        self._push_out(k)
        self.colliders.remember(k, sk)
        self.reports.store(k, report(self.stretch, self.sim, handle, checks.goal_turn(self.sim, fps)))

    def _reached(self, run, shown, seconds):
        self.timing["solver"] += seconds
        self.behind = run.plan.frame - shown
        pos, rot = self.cache.state(shown)[:2]
        goals = run.goals if shown == run.plan.frame else self.cache.goals(shown)
        return self._emit(pos, rot, goals, run.incoming, run.matrix, shown)

    def _surround(self, surroundings):
        """The colliders' frames at the end of the next step, and the force fields acting during it."""
        self.colliders.move(surroundings.colliders)
        self.fields.set(surroundings.fields)

    def pose(self, targets, iterations, incoming=None):
        """Posing mode: the static ARAP pose for the targets, warm-started from the current state."""
        self.timing = {"solver": 0.0, "skin": 0.0}
        if self.n_constraints == 0:
            raise EngineError("posing needs a pin group or a handle: a static pose without constraints is not "
                              "defined")
        self._apply_targets(targets)
        t0 = time.perf_counter()
        self.sim.solve_static(int(iterations))
        self.timing["solver"] += time.perf_counter() - t0
        self.cache.clear()
        self.solver_frame = None
        incoming = self.rest_local if incoming is None else incoming
        return self._emit(self.sim.positions, self.sim.rotations, None, incoming, self.matrix_world)
