"""The panel's warnings (issue 14), free of bpy, on top of ``opdeform.materials``: a driven handle too fast for
the steps (per frame, from the handle targets), and too few particles across the mesh's thinnest part (at
Build; the stretch beyond twice the rest length is in each frame's Report, core/frame_report.py), the thin
appendages with under three particles along them (at Build), and the detached shells that got no particles of their own (at Build: the core attaches a piece with under a tenth of
the largest piece's volume rigidly to the nearest large piece, opdeform.graph's small_pieces="attach"), and on a
rigged mesh, where each shell has particles of its own (the compact ones while their particles take at most half
of the count, largest first; the others attached), the shells a goal's Follow leaves loose all over (per
frame)."""

import numpy as np

THIN_PART_SPARE = 1.1  # thin_part_text's count asks a tenth more than two across
PARTICLES_OFFERED = 2000  # the Particles slider's soft maximum (blender/properties.py): advice past it reads apart
PARTICLES_NAMED = 10  # ... and past this many times it, names no count (a dancer's ribbon: "about 1079050")
THIN_PART_BUDGET = 2e7  # vertices x triangles: about 2 s of rays on one core; larger meshes are not checked
WELD = 1e-8  # vertices closer than this share of the bounding box are one, as the core welds them
ANCHOR = 0.99  # a detached shell with a vertex at this Follow or more is held there by its goal
# A rig turning faster than this (turns a second) stretches what follows it loosely: the outside bird's 360-degree
# spin of the root at 24 fps (docs/goals.md, "A rig turning fast") over 2 / 3 / 4 / 6 frames (12 / 8 / 6 / 4 turns
# a second) stretched its 2 Hz hair cards 2.36 / 1.61 / 1.37 / 1.18x. It is the speed, not the frames: more
# substeps do not help (the same at 10, 40 and 160 a frame on a bar).
TURN_SPEED_LIMIT = 6.0
SETTLING_DAMPING = 4.0  # /s: a swing falls to e^(-c/2) in a second, 14 % at 4/s (the looks: 9-12/s, 1 % or less)


def handle_motion(before, after, fps):
    """(the fastest handle's speed m/s, its fastest turn rad/s) between two frames' targets (H, 4, 3: a point
    and three axes each)."""
    a, b = np.asarray(before, dtype=np.float64), np.asarray(after, dtype=np.float64)
    speed = np.linalg.norm(b[:, 0] - a[:, 0], axis=1).max() * fps
    cos = ((a[:, 1:] * b[:, 1:]).sum(axis=(1, 2)) - 1.0) / 2.0  # trace of the relative rotation
    return float(speed), float(np.arccos(np.clip(cos, -1.0, 1.0)).max() * fps)


def handle(materials, sim, before, after, substeps, fps):
    """(the fastest handle's travel in one step / the body's size, too fast for the steps); (0, False) without
    handles or a previous frame."""
    if before is None or after is None or len(after) == 0:
        return 0.0, False
    speed, turn = handle_motion(before, after, fps)
    return materials.handle_warning(sim, speed, turn, substeps, fps)


def goal_turn(sim, fps):
    """The fastest goal's turn into the frame just set, degrees (goals carrying the rest: the angular velocities
    they were given from the frame before; 0 without)."""
    motion = sim.goal_motion
    if motion is None:
        return 0.0
    return float(np.degrees(np.sqrt(np.einsum("ij,ij->i", motion[1], motion[1])).max(initial=0.0)) / fps)


def turn_text(degrees, fps):
    """The panel's warning for a goal turn of ``degrees`` a frame at ``fps`` (None up to TURN_SPEED_LIMIT)."""
    turns = degrees * fps / 360.0
    if turns <= TURN_SPEED_LIMIT:
        return None
    way = "; a half turn a frame or more can be seen the other way round" if degrees >= 179.0 else ""
    return (f"The rig turns {degrees:.0f} degrees in a frame ({turns:.1f} turns a second): loosely followed parts "
            f"stretch (over 1.5x beyond {TURN_SPEED_LIMIT:g}){way}. Key the turn over more frames")


def thin_part(od, graph, vertices, triangles):
    """(the thinnest part, the particle spacing, too few particles across), or None for a mesh too large to
    check in about two seconds. Only the pieces whose particles grow with Particles are measured (_growing), as
    the warning's advice is to raise it: a detached shell attached to another piece (attached_pieces) stays
    rigid at any count, and one with a few particles of its own keeps them (an outside tester's fish: its 1.2 cm
    dorsal fin, 16 particles at 100, 200 and 400, was named "Thinnest part 1.04 cm ... raise Particles")."""
    triangles = _growing(od, graph, vertices, triangles)
    if len(vertices) * len(triangles) > THIN_PART_BUDGET or len(triangles) == 0:
        return None
    return od.materials.thin_part_warning(graph, vertices, triangles)


def thin_appendages(od, graph, vertices, triangles):
    """The thin appendages with under three particles along them (opdeform.materials.thin_appendages:
    (centre, length, particles), longest first), of the pieces with particles; any mesh size (a grid fill)."""
    return od.materials.thin_appendages(graph, vertices, _with_particles(od, graph, vertices, triangles))


def thin_part_text(thin, particles, length=None):
    """The panel's warning for thin_part (None when there are enough particles across): what to raise Particles
    to for two across its thinnest part with a tenth to spare (the spacing falls about as the cube root of the
    count: a 0.15 m slab at 100 particles asked 700 for two across and had 1.01 of the spacing two need; an
    outside tester's knight still read "raise Particles" at 400, where it takes about 5,000)."""
    if thin is None or not thin[2]:
        return None
    length = length or (lambda x: f"{_metres(x)} m")
    enough = _round_up(particles * (THIN_PART_SPARE * 2.0 * thin[1] / thin[0]) ** 3)
    return (f"Thinnest part {length(thin[0])}, particles {length(thin[1])} apart: fewer than two across; "
            f"{_raise_to(enough, 'two across')}")


def appendages_text(parts, particles, length=None, shown=3, along=3):
    """The panel's warning for thin_appendages (None when there are none): what to raise Particles to for
    ``along`` particles in each (particles scale with the count); ``length`` writes a length with its unit
    (default: metres; the panel's follows the scene's units)."""
    if not parts:
        return None
    length = length or (lambda x: f"{_metres(x)} m")
    named = ", ".join(f"{length(size)} at {_place(c)}: {n}" for c, size, n in parts[:shown])
    more = f" and {len(parts) - shown} more" if len(parts) > shown else ""
    enough = _round_up(-(-particles * along // max(1, min(n for _, _, n in parts))))
    return (f"{len(parts)} thin part{'s' if len(parts) > 1 else ''} with under {along} particles along "
            f"({named}{more}): each turns nearly rigidly and hardly jiggles; {_raise_to(enough, f'{along} along')}")


def _raise_to(enough, what):
    """The advice of a thin-part warning: the count to raise Particles to, or, past the slider's PARTICLES_OFFERED
    (an outside tester's pig, a 6 cm tail on a 1.8 m body, was told "raise Particles to about 15350"), what it
    would take and what the part does meanwhile; past PARTICLES_NAMED times it (an outside tester's dancer read
    "about 1079050 particles"), that no count offered will, and what would."""
    if enough <= PARTICLES_OFFERED:
        return f"raise Particles to about {enough:.0f}"
    if enough > PARTICLES_NAMED * PARTICLES_OFFERED:
        return (f"{what} would take far more particles than the {PARTICLES_OFFERED} offered: it moves with the "
                f"particles around it; to make it bend on its own, thicken it (Solidify) or give it an OPDeform "
                f"object of its own")
    return (f"{what} would take about {enough:.0f} particles, past the {PARTICLES_OFFERED} offered: it moves "
            f"with the particles around it")


def _growing(od, graph, vertices, triangles):
    """The triangles of the mesh's pieces whose particles grow with the count: not a detached shell with under
    SMALL_PIECE_RATIO of the largest piece's particle volume (the core's small pieces, by voxels: attached
    with none, or of their own with a fixed few, opdeform.graph); all of them where the core counts its pieces
    otherwise."""
    count, of_particle = od.mesh.mesh_pieces(graph)
    if count < 2:
        return triangles
    piece, found = vertex_pieces(vertices, triangles)
    if found != count:
        return triangles
    volume = np.bincount(of_particle, weights=graph.volumes, minlength=count)
    grows = volume >= od.mesh.SMALL_PIECE_RATIO * volume.max()
    return triangles[grows[piece[triangles[:, 0]]]]


def _with_particles(od, graph, vertices, triangles):
    """The triangles of the mesh's pieces that have particles of their own (all of them when every piece has)."""
    without = _pieces_without_particles(od, graph, vertices, triangles)
    if without is None:
        return triangles
    piece, missing = without
    return triangles[~np.isin(piece[triangles[:, 0]], missing)]


def vertex_pieces(vertices, triangles):
    """(the connected piece of each vertex, -1 for a vertex of no triangle; the number of pieces), the pieces
    as the core finds them: vertices closer than WELD of the bounding box welded first, pieces numbered by
    their first triangle."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    weld = welded(v)
    tri = weld[t]
    label = np.arange(weld.max() + 1)
    while True:  # each welded vertex takes the lowest label of its triangles' vertices, then its label's label
        low = label[tri].min(axis=1)
        new = label.copy()
        for k in range(3):
            np.minimum.at(new, tri[:, k], low)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    roots, first = np.unique(label[tri[:, 0]], return_index=True)
    number = np.full(len(label), -1)
    number[roots[np.argsort(first)]] = np.arange(len(roots))
    piece = np.full(len(v), -1)
    used = np.unique(t)
    piece[used] = number[label[weld[used]]]
    return piece, len(roots)


def open_pieces(vertices, triangles):
    """The mesh pieces (numbered as vertex_pieces numbers them) with an edge not shared by two triangles once the
    vertices are welded: a shell split along its seams is closed."""
    weld = welded(vertices)
    t = weld[np.asarray(triangles, dtype=np.int64).reshape(-1, 3)]
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    found, count = np.unique(edges, axis=0, return_counts=True)
    piece_of = np.full(weld.max() + 1, -1)
    piece_of[weld] = vertex_pieces(vertices, triangles)[0]
    return np.unique(piece_of[found[count != 2, 0]])


def welded(vertices):
    """Each vertex's index among the welded ones: vertices closer than WELD of the bounding box are one, as the core
    welds them (a mesh split along its seams is whole again)."""
    v = np.asarray(vertices, dtype=np.float64)
    tolerance = max(float(np.ptp(v, axis=0).max()), 1e-30) * WELD
    return np.unique(np.round(v / tolerance), axis=0, return_inverse=True)[1].reshape(-1)


def attached_pieces(od, graph, vertices, triangles, shown=None):
    """The mesh's pieces with no particles of their own, each skinned rigidly by the nearest large piece:
    ((vertex count, centre), ...), largest first; the centre is the mean of ``shown`` (the vertices by
    default). () when every piece has particles, or when the core counts its pieces otherwise."""
    without = _pieces_without_particles(od, graph, vertices, triangles)
    if without is None:
        return ()
    piece, missing = without
    shown = np.asarray(vertices if shown is None else shown, dtype=np.float64)
    out = [(int((piece == p).sum()), tuple(float(c) for c in shown[piece == p].mean(axis=0))) for p in missing]
    return tuple(sorted(out, key=lambda x: -x[0]))


def shells_enough(od, graph, vertices, triangles):
    """The Particles (rounded up to 50) from which the core gives every detached shell of its own particles (its
    small_pieces="own") that it left without (attached_pieces), None when none was left out: the small ones that
    take SMALL_PIECE_PARTICLES each (not the long shells given theirs beyond the count: those have SHELL_PARTICLES or
    more) take them from at most SMALL_PIECE_SHARE of the count, largest first, the next ones theirs beyond the
    count up to SMALL_PIECE_EXTRA of it, the rest left out: all of them given from SMALL_PIECE_PARTICLES x their
    number / (SMALL_PIECE_SHARE + SMALL_PIECE_EXTRA) (the outside dancer's 12 skirt cards and 10 hair ribbons: 88
    to give, the 10 ribbons left out at 50, none from 88, named 100)."""
    without = _pieces_without_particles(od, graph, vertices, triangles)
    if without is None:
        return None
    count, of_particle = od.mesh.mesh_pieces(graph)
    per_piece = np.bincount(of_particle, minlength=count)
    volume = np.bincount(of_particle, weights=graph.volumes, minlength=count)
    small = volume < od.mesh.SMALL_PIECE_RATIO * volume.max()
    floored = (per_piece > 0) & (per_piece < od.mesh.SHELL_PARTICLES) & small
    taking = len(without[1]) + int(np.count_nonzero(floored))
    share = od.mesh.SMALL_PIECE_SHARE + od.mesh.SMALL_PIECE_EXTRA
    return _round_up(int(np.ceil(od.mesh.SMALL_PIECE_PARTICLES * taking / share)))


def _pieces_without_particles(od, graph, vertices, triangles):
    """(each vertex's piece, the pieces with no particle of their own), or None when every piece has particles
    or the core counts its pieces otherwise."""
    count, of_particle = od.mesh.mesh_pieces(graph)
    if count < 2:
        return None
    piece, found = vertex_pieces(vertices, triangles)
    missing = np.setdiff1d(np.arange(count), of_particle)
    return (piece, missing) if found == count and len(missing) else None


def hanging_pieces(piece, follow, shown, body, anchor=ANCHOR):
    """The mesh's pieces but the body (``body``: Engine.pieces, the piece with most particles, which Shell Min
    leaves as painted) that a goal's Follow leaves loose all over (no vertex at ``anchor`` or
    more): each holds to the body only by the edges from its particles (a long one's from its root) to the nearest
    body particle (opdeform.graph's small_pieces="own") and its goal spring alone turns it back, slowly (a
    humanoid's hulls painted 0.25: 24-145 mm off 1 s after the motion, docs/goals.md).
    ((vertex count, centre of ``shown``), ...), largest first; () without pieces or a goal."""
    if piece is None or follow is None:
        return ()
    count = piece.max() + 1
    sizes = np.bincount(piece[piece >= 0], minlength=count)
    top = np.zeros(count)
    np.maximum.at(top, piece[piece >= 0], np.asarray(follow)[piece >= 0])
    return _named(piece, [p for p in range(count) if p != body and sizes[p] and top[p] < anchor], shown)


def unrigged_pieces(piece, moved, shown):
    """The mesh's pieces of which no vertex is moved by a bone (``moved``: per vertex, mesh_data.bone_moved): the
    Armature leaves them where they are, so they neither follow the rig nor have its motion to lag behind (the
    audit's dog, docs/goals.md: automatic weights left its ears unweighted, floating where they were modelled
    while the head nods). ((vertex count, centre of ``shown``), ...), largest first; () without pieces or
    ``moved`` (None: not known)."""
    if piece is None or moved is None:
        return ()
    count = piece.max() + 1
    sizes = np.bincount(piece[piece >= 0], minlength=count)
    rigged = np.bincount(piece[piece >= 0], weights=np.asarray(moved)[piece >= 0], minlength=count)
    return _named(piece, [p for p in range(count) if sizes[p] and not rigged[p]], shown)


def _named(piece, chosen, shown):
    """((vertex count, centre of ``shown``), ...) of the pieces ``chosen``, largest first."""
    shown = np.asarray(shown, dtype=np.float64)
    out = [(int((piece == p).sum()), tuple(float(c) for c in shown[piece == p].mean(axis=0))) for p in chosen]
    return tuple(sorted(out, key=lambda x: -x[0]))


def hanging_text(pieces):
    """The panel's warning for hanging_pieces (None when there are none)."""
    return _shells_text(pieces, "with Follow under 1 all over", "each is held to the body only by links from its "
                        "particles (a long one's from its root) to the nearest body particle and comes back after the "
                        "motion only as fast as its Follow (Shell Min at least) pulls it; paint Follow 1 where it "
                        "meets the body")


def undamped_goal_text(use_goal, damping, region_damping=None):
    """The panel's warning for a Goal with too little damping to settle (None when it settles): a material preset
    (Jelly 28-154 mm off 1 s after the motion on the outside rigs, docs/goals.md) keeps its own damping, where the
    looks set 9-12/s. ``region_damping``: the Damping group's, where one is picked (None: none)."""
    settling = max(damping, region_damping or 0.0)
    if not use_goal or settling >= SETTLING_DAMPING:
        return None
    return (f"Damping {settling:g}/s with Goal: a swing falls only to {100 * np.exp(-settling / 2):.0f} % in a second, "
            "so loose parts swing on after the motion; the looks (Subtle, Fleshy, Floppy) use 9-12/s")


def unrigged_text(pieces):
    """The panel's warning for unrigged_pieces (None when there are none)."""
    return _shells_text(pieces, "that no bone moves", "the Armature leaves each where it was modelled, so it "
                        "neither follows the rig nor jiggles; give its vertices a weight in a bone's vertex group "
                        "(Weight Paint, or Assign to the group of the bone it hangs from)")


def attached_text(pieces, enough=None):
    """The panel's warning for attached_pieces (None when there are none); ``enough``: the Particles that gives
    them particles of their own (shells_enough; None: no count does, small_pieces="attach"), named when offered."""
    join = "join it to the body (Merge by Distance, Bridge) or give it an OPDeform object of its own"
    if enough is None or enough > PARTICLES_OFFERED:
        advice = f"each moves rigidly with the nearest large piece, whatever the particle count; to make one jiggle, " \
                 f"{join}"
    else:
        advice = (f"each moves rigidly with the nearest large piece; at Particles {enough} or more each gets particles "
                  f"of its own, or {join}")
    return _shells_text(pieces, "without particles", advice)


def particles_text(n_particles, n_edges, pieces):
    """The panel's lines on the graph: "N particles, E edges", and with more than one mesh piece how many are on
    the largest one (Particles asks for the body's; the detached shells' are added: an outside tester's fish,
    Particles 100, read 193 with no word why). ``pieces``: Engine.pieces."""
    count, piece, body = pieces
    lines = [f"{n_particles} particles, {n_edges} edges"]
    if count > 1:
        on_body = int(np.count_nonzero(piece == body))
        others = len(np.unique(piece[(piece >= 0) & (piece != body)]))
        lines.append(f"{on_body} on the body, {n_particles - on_body} on {others} shell{'s' if others != 1 else ''}")
    return lines


def overlap_text(names):
    """The panel's warning for objects stepping with this one that overlap it at rest without a Goal on both
    (core/contact.py ``overlapping``; None when there are none)."""
    if not names:
        return None
    named = ", ".join(f"'{n}'" for n in names)
    return (f"Overlaps {named} at rest and Goal is not on both: their contact pushes them apart from the first "
            "frame and can tear them; tick Goal on both (an overlap of their animations is no contact) or move "
            "them apart")


def _decimals(largest):
    """Decimals that show two significant digits of ``largest`` (m), at least 2: a 1 cm creature's shells
    are told apart as a 2 m one's are."""
    largest = abs(float(largest))
    return 2 if largest == 0.0 or not np.isfinite(largest) else max(2, 1 - int(np.floor(np.log10(largest))))


def _round_up(count, step=50):
    """A particle count the panel names: ``count`` rounded up to a multiple of ``step``."""
    return -(-count // step) * step


def _metres(x):
    return f"{x:.{_decimals(x)}f}"


def _place(c):
    """"(x, y, z)" in metres, all with the decimals of the largest coordinate."""
    d = _decimals(max(abs(float(x)) for x in c))
    return "(" + ", ".join(f"{float(x):.{d}f}" for x in c) + ")"


def _shells_text(pieces, what, advice, shown=3):
    """"N detached shells <what> (the first ``shown`` by size and centre): <advice>", None without pieces."""
    if not pieces:
        return None
    named = ", ".join(f"{n} vertices at {_place(c)}" for n, c in pieces[:shown])
    more = f" and {len(pieces) - shown} more" if len(pieces) > shown else ""
    return f"{len(pieces)} detached shell{'s' if len(pieces) > 1 else ''} {what} ({named}{more}): {advice}"
