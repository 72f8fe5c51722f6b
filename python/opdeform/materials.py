"""Settings an artist can use (issue 14): a stiffness in Pa that looks the same at any size and particle count,
presets, an error tolerance, substeps for a frame rate, and the checks a panel warns with. See docs/settings.md.

**Stiffness.** The solver's k (J/m^5) is not a material constant. ``stiffness_for`` takes it from **bending**,
the deformation an artist sees (a tail drooping and jiggling): bend the rest body to a small curvature kappa
(fibres along its longest principal axis stretched by -kappa t, t the distance from the neutral axis, each
particle turned with the material), and the graph stores

    k/2 kappa^2 G,   G = sum_i sum_(j in N_i) [ v_j (d_a^2 (t_j - t_0)^2 + d_a^4 / 4) + d_a^2 (A_j,aa + A_j,bb) ]

(d = X_j - X_i, a the fibre axis, b the bending direction, A_j the rest moment; t_0 the neutral axis that
minimises it), where a continuum of Young's modulus E stores E/2 kappa^2 J with J the body's second moment
of area integrated along it (of the closed mesh the graph was built from, scaled to the particles' volume,
which is the body's mass: else of the particles themselves). Summed over the two bending directions,

    k = E (J_ab + J_ac) / (G_ab + G_ac)          (``stiffness_for``)

The d_a^4 and moment terms are the graph's own bending stiffness: they vanish against the fibres' term as
particles get small (k then tends to the uniform-strain k = E V / sum_edges (v_i + v_j) d_a^2), but with one to
three particles across a body they are half or more of G, which is why a uniform-strain k
(``calibration="uniform"``, 3 E V / sum_edges (v_i + v_j) |d|^2) made a tail droop 7 % at 50 particles and
18 % at 300. That k (``calibration="bending"``) is one number for the whole body, and the irregular layout of
``Graph.from_mesh`` makes some parts of a body bend more than others under it: a pinned tail drooped 9.1 to
11.3 % from 50 to 400 particles.

**Measured, per particle** (the default, ``calibration="measured"``, for bodies at least three times longer
than thick): hold one end face of the graph and load it across by its own weight (a static solve in each cross
direction), then the other end. Where a part bends more per bending moment than a continuum of its
cross-sections (the particles' second moment of area along the body, smoothed over two particle spacings)
would, its particles' stiffness is raised, and the loads are solved again; the graph then bends everywhere
as a continuum of rigidity c I(s), and k = E J / (c J_particles) makes that the material's (J the closed
mesh's second moment, as above). Only the cross directions in which the body is a beam are measured (a
plate across its thickness); a body in several connected pieces is calibrated piece by piece, a bent one (an
L-bracket) straight part by straight part (its skeleton on a grid fill of the mesh) and then levelled against
the continuum frame along that skeleton, and thin appendages (a
character's ears and tail) each as a cantilever of its own cross-sections (issue 24, docs/settings.md). The
tail then droops 9.5 to 10.3 % (1.08x); the solver takes one stiffness per particle (``Simulation(graph,
stiffness_for(...))``, ``Simulation.set_stiffness_scale``). Cost: eight static solves of the graph, once per
graph (0.19 s at 100 particles, 2.0 s at 1,000; above 1,000 particles the "bending" k). A blob, a
curved body, or a chain whose end particle cannot be held by a face keeps the "bending"
k on every particle.

E itself is not scale-free: a body of size L under gravity sags by a fraction proportional to rho g L / E (and
its frequencies scale as sqrt(E / rho) / L), so a real material looks ten times softer ten times larger. The
artist's ``modulus`` is therefore the modulus the material has at REFERENCE_SIZE (1 m), and the body's size
scales it by one of two rules (``scaling``, ``acting_modulus``):

- "froude" (free bodies, the default): E = modulus * L / 1 m. Then rho g L / E is the same at every size: the
  same relative sag, and periods that scale as sqrt(L / g), the Froude scaling of miniatures (a ten times
  larger tail sways sqrt(10) times slower, as a real one would).
- "goal" (a body that follows an animation, its goals carrying the rest shape: the add-on's objects with
  Goal on in Dynamic mode): E = modulus * L / 1 m * L / GOAL_REFERENCE_SIZE, and gravity times
  L / GOAL_REFERENCE_SIZE (``acting_gravity``). There the rig's accelerations drive the flesh, and a scene
  scaled by s at the same keyframe timing accelerates s times more; with E growing as L^2 the frequencies
  sqrt(E / rho) / L are the same at every size, so the lag and overshoot grow as the accelerations, as s:
  the same motion in units of the size, as Maya's Jiggle gives (issue 24: Froude-scaled, the bird at 19.8 m
  stretched 1.98x where it does 1.13x at 1.98 m). Gravity scaled with L keeps its relative sag
  rho g L / E size-free too. At GOAL_REFERENCE_SIZE (2.43 m, the creature the looks were tuned on) and below
  the two rules agree: the goal rule only stiffens. Below it the looks would be softer than the material (the
  kid rig, 1.26 m, at 0.52x: 2.17x stretch at 50 particles where it has 1.42x, the Floppy kid at 1,000 1.89x
  where it has 1.28x: its ponytail and skirt), and every rig the looks were checked on is that size or less.

**Damping** is a rate per second (``step_damping`` turns it into the solver's per-step c for a dt), so it
does not change with the frame rate.
"""

import math
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ._arguments import ArrayLike, Floats, Ints, Vector
from .graph import Graph
from .mesh import mesh_pieces
from .simulation import Simulation

__all__ = ["CALIBRATIONS", "DEFAULT_MATERIAL", "DEFAULT_TOLERANCE", "GOAL_REFERENCE_SIZE", "Material", "PRESETS",
           "REFERENCE_SIZE", "SCALINGS", "acting_gravity", "acting_modulus", "body_size", "handle_warning",
           "make_simulation", "preset_table", "simulation_settings", "stiffness_for", "step_damping",
           "stretch_warning", "substeps_for", "thin_appendages", "thin_part_warning"]

# The annotations' types: a mesh as given (vertices, triangles; or the arguments Graph.from_mesh kept, the
# mesh first), a calibration's k / E (one for the body or one per particle), an array of the computations
MeshArg = Sequence[Any]
Arr = npt.NDArray[Any]
Ratio = float | Arr

REFERENCE_SIZE = 1.0  # m: the size at which a material's modulus is its modulus
# m: the size at which the "goal" rule gives the "froude" rule's E: the creature the looks were tuned on
# (tests/blender/character_scene.py, 2.43 m), whose figures are then as they were
GOAL_REFERENCE_SIZE = 2.43
SCALINGS = ("froude", "goal")  # how a body's size scales its modulus: free bodies, bodies following an animation
# Residual tolerance of a step (Simulation.set_solver) and the accelerator that reaches it: measured on the
# Fig. 1 and 2 bars (docs/settings.md), the 2-second clip error is 0.13 % (sagging) and 0.17 % (twisted) of
# the bar's length with "auto" at 2e-5, at about 1.6x and 1.0x the cost of plain 10 pairs a step (Chebyshev
# alone: 0.16 % and 0.13 %, at 1.5x and 3.2x).
DEFAULT_TOLERANCE = 2e-5
DEFAULT_ACCELERATOR = "auto"  # plain or Chebyshev, chosen per step (Simulation.set_solver)


@dataclass(frozen=True)
class Material:
    """A preset: ``modulus`` Pa at REFERENCE_SIZE, ``density`` kg/m^3, ``damping`` per second (velocity lost
    per second, 0..), ``tolerance`` the residual of a step (quality: smaller is more accurate and slower)."""
    name: str
    modulus: float
    density: float
    damping: float
    tolerance: float = DEFAULT_TOLERANCE
    description: str = ""


# Droop of the 2 m x 0.2 m tail pinned at its root (100 particles, static, docs/settings.md): Jelly ~ 40 %,
# Flesh ~ 22 %, Rubber ~ 10 % (the default: it droops and jiggles visibly), Stiff ~ 1 %.
PRESETS = {m.name: m for m in (
    Material("Jelly", 3.0e6, 1050.0, 0.5, description="wobbly: the 2 m tail droops about 40 %"),
    Material("Flesh", 6.0e6, 1050.0, 1.0, description="soft and damped: droops about 22 %, settles quickly"),
    Material("Rubber", 1.5e7, 1100.0, 0.3, description="the default: droops about 10 % and jiggles visibly"),
    Material("Stiff", 1.5e8, 1000.0, 0.3, description="nearly rigid: droops about 1 %"),
)}
DEFAULT_MATERIAL = "Rubber"


def preset_table() -> list[dict[str, Any]]:
    """The presets as plain data for a panel: a list of dicts (name, modulus, density, damping, tolerance,
    description), in PRESETS order."""
    return [dict(name=m.name, modulus=m.modulus, density=m.density, damping=m.damping, tolerance=m.tolerance,
                 description=m.description) for m in PRESETS.values()]


def simulation_settings(graph: Graph, modulus: float, density: float, damping: float,
                        tolerance: float = DEFAULT_TOLERANCE, fps: float = 24.0, substeps: int | None = None,
                        size: float | None = None) -> tuple[dict[str, Any], dict[str, Any], int]:
    """The panel's artist values (modulus Pa at REFERENCE_SIZE, density kg/m^3, damping per second, tolerance,
    frame rate, substeps per frame: default ``substeps_for(fps)``) as (Simulation keyword arguments,
    set_solver keyword arguments, substeps per frame)."""
    substeps = substeps_for(fps) if substeps is None else int(substeps)
    if substeps < 1:
        raise ValueError(f"substeps = {substeps} must be >= 1")
    dt = 1.0 / (fps * substeps)
    sim = dict(stiffness=stiffness_for(graph, modulus, size), density=float(density), dt=dt,
               damping=step_damping(damping, dt))
    return sim, dict(accelerator=DEFAULT_ACCELERATOR, tolerance=float(tolerance)), substeps


def body_size(graph: Graph, mesh: MeshArg | None = None) -> float:
    """The largest extent of the rest body, m: of ``mesh`` (vertices, triangles) or the mesh ``Graph.from_mesh``
    was given, else of the particles (centres plus their largest radius). The particles' reach grows with their size: the character measured
    2.60 m at 50 particles and 2.48 m at 400, and E (modulus times size) 5 % apart with it."""
    if mesh is None and graph._made[0] == "from_mesh":
        mesh = graph._made[1]
    if mesh is not None:
        vertices = np.asarray(mesh[0], dtype=np.float64)
        return float((vertices.max(axis=0) - vertices.min(axis=0)).max())
    reach = graph.radii.max(axis=1, keepdims=True)
    c = graph.centers
    return float(((c + reach).max(axis=0) - (c - reach).min(axis=0)).max())


CALIBRATIONS = ("measured", "bending", "uniform")


def stiffness_for(graph: Graph, modulus: float, size: float | None = None, mesh: MeshArg | None = None,
                  calibration: str = "measured", scaling: str = "froude") -> float | Floats:
    """The solver's stiffness for a material of ``modulus`` Pa at REFERENCE_SIZE on this graph; ``size`` (m) is
    the body's size (default ``body_size(graph)``), which scales the modulus by ``scaling`` (SCALINGS:
    ``acting_modulus``). ``mesh`` (vertices, triangles): the closed body whose
    second moment a continuum would have (default: the mesh ``Graph.from_mesh`` was given, when it is closed;
    else the particles' own). ``calibration``: "measured" (the default: one k per particle, an (n,) array for
    ``Simulation``, from the graph's measured bending; the module's docstring), "bending" (one k from the
    rest graph's bending energy) or "uniform" (the uniform-strain k used before, for comparison)."""
    if not isinstance(graph, Graph):
        raise TypeError("graph must be an opdeform.Graph")
    if not (modulus > 0.0 and math.isfinite(modulus)):
        raise ValueError(f"modulus = {modulus} must be finite and > 0")
    if calibration not in CALIBRATIONS:
        raise ValueError(f"calibration must be one of {CALIBRATIONS}, got {calibration!r}")
    if graph.n_edges == 0:
        raise ValueError("the graph has no edges: a stiffness needs at least one")
    size = body_size(graph, mesh) if size is None else float(size)
    modulus = acting_modulus(modulus, size, scaling)
    ratio = None if calibration == "uniform" else _calibrated_ratio(graph, mesh, calibration)
    k = _uniform_stiffness(graph, modulus) if ratio is None else modulus * ratio
    return np.full(graph.n_particles, k) if calibration == "measured" and np.ndim(k) == 0 else k


def _size_ratio(size: float, scaling: str) -> float:
    """size / GOAL_REFERENCE_SIZE under the "goal" rule, at least 1 (the module's docstring), 1 under "froude";
    ValueError for another rule or size."""
    if scaling not in SCALINGS:
        raise ValueError(f"scaling must be one of {SCALINGS}, got {scaling!r}")
    if not (size > 0.0 and math.isfinite(size)):
        raise ValueError(f"size = {size} must be finite and > 0")
    return max(1.0, size / GOAL_REFERENCE_SIZE) if scaling == "goal" else 1.0


def acting_modulus(modulus: float, size: float, scaling: str = "froude") -> float:
    """The Young's modulus (Pa) a body of ``size`` m acts with for a ``modulus`` at REFERENCE_SIZE: modulus *
    size / REFERENCE_SIZE ("froude": the same relative sag at any size), times size / GOAL_REFERENCE_SIZE when
    larger ("goal": the same frequencies at any size above it; the module's docstring)."""
    return modulus * (size / REFERENCE_SIZE) * _size_ratio(size, scaling)


def acting_gravity(gravity: Vector, size: float, scaling: str = "froude") -> tuple[float, float, float]:
    """The gravity (m/s^2) a body of ``size`` m feels: as given ("froude"), times size / GOAL_REFERENCE_SIZE when
    larger ("goal": the same relative sag under ``acting_modulus`` at any size)."""
    ratio = _size_ratio(size, scaling)
    x, y, z = (float(g) * ratio for g in gravity)
    return x, y, z


def _uniform_stiffness(graph: Graph, modulus: float) -> float:
    """The uniform-strain k, 3 E V / sum_edges (v_i + v_j) |d|^2 (only where no calibration applies: the add-on
    asks for k every frame)."""
    c, v, e = graph.centers, graph.volumes, graph.edges
    arm = ((v[e[:, 0]] + v[e[:, 1]]) * ((c[e[:, 0]] - c[e[:, 1]]) ** 2).sum(axis=1)).sum()
    return 3.0 * modulus * v.sum() / arm


# k / E of a graph for the mesh it was built from, by calibration: the add-on asks for k on every frame (its
# settings may change), and the closed-mesh test alone sorts the mesh's edges (12.6 ms a frame for Suzanne
# subdivided once, 2,012 vertices, about ten times the frame's simulation); the measured one solves. A Graph
# does not change.
_OWN_MESH_RATIOS: weakref.WeakKeyDictionary[Graph, dict[str, Any]] = weakref.WeakKeyDictionary()


def _calibrated_ratio(graph: Graph, mesh: MeshArg | None, calibration: str) -> Ratio | None:
    """k / E: one per particle (measured, a beam-like body), one for the body (bending; measured elsewhere), or
    None where nothing bends (no edge has a length along the longest axis: the uniform k then)."""
    known = _OWN_MESH_RATIOS.setdefault(graph, {}) if mesh is None else {}
    if calibration not in known:
        found: Ratio | None
        if graph.pieces()[0] > 1:
            found = _piece_ratios(graph, mesh, calibration)
        else:
            found = _one_body_ratio(graph, mesh, calibration)
        known[calibration] = _own_cards(graph, mesh, _even_shells(graph, found)) if calibration == "measured" else found
    return known[calibration]


def _one_body_ratio(graph: Graph, mesh: MeshArg | None, calibration: str) -> Ratio | None:
    """_calibrated_ratio of a graph in one connected piece."""
    centre, frame, moments = _principal_frame(graph)
    second = _body_second_moment(graph, centre, frame, moments, mesh)
    points = _clamp_points(graph, mesh) if calibration == "measured" else None
    found = _body_ratio(graph, centre, frame, moments, second, points)
    if calibration == "measured" and found is not None and graph.n_particles <= _MEASURED_MAX:
        closed = _closed_mesh(graph, mesh)
        found = found if closed is None else _with_parts(graph, closed, found)
    return found


def _even_shells(graph: Graph, ratio: Ratio | None) -> Ratio | None:
    """``ratio`` (k / E per particle) with each detached shell linked to the body by edges (a mesh piece joined
    by edges to one with more particles: a hair strand, an ear) given one value, the volume-weighted geometric
    mean of its particles'. Measured with the body, the kid's 0.3 m ponytail (docs/goals.md) took the body's k
    at each particle's height, half of its particles the clamp's floor: neighbours 12x apart, and it stretched
    1.58-1.82x. The measured scales spread over the clamp's [1/4, 4] evenly in log: their geometric mean keeps a
    shell's swing nearest (suite_robustness's trunk 0.63-0.89 of before; the arithmetic mean 0.21-0.64, the
    harmonic 1.03-1.06 but the ponytail at 50 particles 3.1x stretched)."""
    count, label = mesh_pieces(graph)
    if label is None or count < 2 or ratio is None or np.ndim(ratio) == 0:
        return ratio
    e, v, ratio = graph.edges, graph.volumes, np.array(ratio)
    a, b = label[e[:, 0]], label[e[:, 1]]
    size = np.bincount(label[label >= 0], minlength=count)
    for p in np.unique(np.where(size[a] < size[b], a, b)[a != b]):
        chosen = label == p
        ratio[chosen] = _volume_geometric_mean(v[chosen], ratio[chosen])
    return ratio


def _own_cards(graph: Graph, mesh: MeshArg | None, ratio: Ratio | None) -> Ratio | None:
    """``ratio`` (k / E per particle) with each card, an open mesh piece linked to a larger one at its root (a
    hair card, a one-sided wing: not the main piece of its connected piece of the graph, _main_shells; fewer
    links than particles), given its own measured k / E as a body of its own, as thick as its particles are
    wide (_widened; one value, their volume-weighted geometric mean). A card is a single layer of particles, 16
    at any count (docs/mesh.md): at its host's k (7.7) the outside bird's hair cards (docs/goals.md) flipped over
    (crest 322 mm, edges 2.03x at 100 particles); at their own 156-240 mm over 50-1,000 particles, 1.12-1.21x.
    The host's k grows with the count (the bird's body 3.4-28 over 50-1,000), the card's particles do not: at
    the body's k its wings swung 168 mm at 50 particles and 27 mm at 1,000; at their own 104-221 mm. As thin as
    its particles (a voxel, thinner as the count grows) a plate's own k fell to 0.08-1.4 and the wings
    stretched 2.45x at 400."""
    count, shells = mesh_pieces(graph)
    if mesh is None and graph._made[0] == "from_mesh":
        mesh = graph._made[1][:2]
    if shells is None or count < 2 or mesh is None or ratio is None or np.ndim(ratio) == 0:
        return ratio
    vertices, triangles = np.asarray(mesh[0], dtype=np.float64), np.asarray(mesh[1], dtype=np.int64)
    shell = shells[[graph.skin_weights(p, 1)[0][0] for p in vertices]]
    ratio, a, b = np.array(ratio), shells[graph.edges[:, 0]], shells[graph.edges[:, 1]]
    links = np.bincount(np.r_[a[a != b], b[a != b]], minlength=count)
    for piece in np.unique(shells[~_main_shells(graph, graph.pieces()[1])]):
        chosen = np.flatnonzero(shells == piece)
        own_faces = triangles[(shell[triangles] == piece).all(axis=1)]
        if links[piece] >= len(chosen) or not _open_mesh(own_faces):
            continue
        found = _calibrated_ratio(_widened(_subgraph(graph, chosen)), None, "measured")
        if found is not None and np.all(np.isfinite(found)):  # nan: no edge among its particles
            ratio[chosen] = _volume_geometric_mean(graph.volumes[chosen], np.broadcast_to(found, len(chosen)))
    return ratio


def _open_mesh(triangles: Arr) -> bool:
    """Whether a triangle mesh has an edge in one face only (a card), whichever way its faces turn: a closed
    shell turned inside out (a mirrored tail) has no volume for _closed_mesh_moments and was taken for a card
    (the add-on tests' tailed body at 1,000 particles: its tail's k 0.81x, settling 0.107 mm 1.5 s after)."""
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    return bool((np.unique(edges, axis=0, return_counts=True)[1] == 1).any())


def _widened(graph: Graph) -> Graph:
    """The graph with each particle's smallest radius raised to its middle one."""
    radii = np.array(graph.radii)
    thin = np.argmin(radii, axis=1)
    radii[np.arange(len(radii)), thin] = np.sort(radii, axis=1)[:, 1]
    return Graph(graph.centers, radii, graph.edges, graph.axes)


def _volume_geometric_mean(volumes: Arr, ratio: Arr) -> float:
    """The volume-weighted geometric mean of per-particle ratios (k / E): one value for a group of particles."""
    return float(np.exp((volumes * np.log(ratio)).sum() / volumes.sum()))


def _body_ratio(graph: Graph, centre: Arr, frame: Arr, moments: Arr, second: Arr, points: Arr | None) -> Ratio | None:
    """k / E of a body whose continuum has the second moment ``second``: measured where it is a beam (``points``
    on it, whose end faces are held; None: not measured), blended by _beam_weight with the bending k."""
    measured = None if points is None else _measured_bending(graph, centre, frame, moments, second, points)
    found = _compliant_ratio(graph, centre, frame, moments, second)
    if measured is None:
        return found
    w = _beam_weight(second)
    return measured if found is None else w * measured + (1.0 - w) * found


def _piece_ratios(graph: Graph, mesh: MeshArg | None, calibration: str) -> Arr:
    """k / E per particle of a graph in several connected pieces, each calibrated as a body of its own with its
    part of the mesh (the vertices a piece's particles skin, and the triangles of those). Held as one body, a
    piece the end faces missed had no constraint and the static solve raised (issue 24: two boxes joined into
    one object); and two parallel bars drooped half as much as one. A piece with no edge has no elastic term:
    it takes the pieces' mean k (by volume); one with no bending edge the uniform-strain k. A piece that is an
    open sheet but the body is as soft as a membrane hung from its edge nearest the body (_sheets_floored)."""
    count, label = graph.pieces()
    if mesh is None and graph._made[0] == "from_mesh":
        mesh = graph._made[1][:2]
    vertices: Arr | None = None
    triangles: Any = None  # an array wherever vertices is one
    if mesh is not None:
        vertices = np.asarray(mesh[0], dtype=np.float64)
        triangles = np.asarray(mesh[1], dtype=np.int64)
        top = np.array([graph.skin_weights(p, 1)[0][0] for p in vertices])
        owner, shell = label[top], _main_shells(graph, label)[top]
    c, r, a, e = graph.centers, graph.radii, graph.axes, graph.edges
    ratio = np.full(graph.n_particles, np.nan)
    sheets = np.full(count, np.nan)  # per piece: an open sheet's hanging k / E (_hanging_ratio), else nan
    body = np.argmax(np.bincount(label, minlength=count))
    for piece in range(count):
        chosen = np.flatnonzero(label == piece)
        index = np.full(graph.n_particles, -1)
        index[chosen] = np.arange(len(chosen))
        edges = index[e[label[e[:, 0]] == piece]]
        if len(edges) == 0:
            continue
        part = Graph(c[chosen], r[chosen], edges, a[chosen])
        own = None
        if vertices is not None:
            mine = np.flatnonzero(owner == piece)
            number = np.full(len(vertices), -1)
            number[mine] = np.arange(len(mine))
            faces = number[triangles[(owner[triangles] == piece).all(axis=1)]]
            own = (vertices[mine], faces) if len(faces) else None
            if own is not None and piece != body and _closed_mesh_moments(*_main_shell(own, shell[mine])) is None:
                sheets[piece] = _hanging_ratio(part, own, c[label == body])
        found = _calibrated_ratio(part, own, calibration)
        ratio[chosen] = _uniform_stiffness(part, 1.0) if found is None else found
    v, known = graph.volumes, np.isfinite(ratio)
    ratio[~known] = (v * ratio)[known].sum() / v[known].sum()
    return _sheets_floored(label, sheets, ratio)


def _main_shells(graph: Graph, label: Ints) -> Ints:
    """Per particle, whether its mesh piece is the main one of its connected piece of the graph (``label``): the
    piece with most particle volume (a head, not the hair cards linked to it); all True for a graph not built
    from a mesh."""
    count, shells = mesh_pieces(graph)
    if shells is None:
        return np.ones(graph.n_particles, dtype=bool)
    volume = np.zeros((label.max() + 1, count))
    np.add.at(volume, (label, shells), graph.volumes)
    return shells == np.argmax(volume, axis=1)[label]


def _main_shell(mesh: tuple[Arr, Arr], main: Arr) -> tuple[Arr, Arr]:
    """The triangles of ``mesh`` (vertices, triangles) whose vertices are all skinned by its main mesh piece
    (``main``: per vertex, _main_shells of its particle), with the mesh's vertices."""
    vertices, triangles = mesh
    return vertices, triangles[main[triangles].all(axis=1)]


def _sheets_floored(label: Ints, sheets: Arr, ratio: Arr) -> Arr:
    """``ratio`` (k / E per particle) with each open sheet but the body (``sheets``: per piece of ``label``, the
    graph's connected pieces, its _hanging_ratio, nan for any other piece) at most that ratio / _SHEET_SOFTEST:
    a membrane of the body's modulus / _SHEET_SOFTEST, whatever rows its particles fall in (the cap is what
    holds: the spun skirt of tests/test_loose_parts.py's own k is 16-33x it at 50-400 particles). Calibrated
    as a body of its own, the kid's skirt (a cone of cloth held at its waistband, docs/goals.md) was a tube of the
    particles' 54 mm thickness at 0.7x the body's k, and its hem, painted Follow 0.1, swung 1.2 mm in a
    180-degree spin and a jump; at the body's k / _SOFTEST (stop 43) 14.6-45.9 mm over 50-1,000 particles:
    one k gives a sheet's 2 rows at 100 particles and its 9 at 1,000 stiffnesses 11x apart (held at its
    waistband and loaded along it)."""
    thin = np.isfinite(sheets)[label]
    ratio[thin] = np.minimum(ratio[thin], sheets[label[thin]] / _SHEET_SOFTEST)
    return ratio


def _hanging_ratio(sheet: Graph, mesh: tuple[Arr, Arr], body: Arr) -> float:
    """k / E of an open sheet (its graph and its part of the mesh) that swings as a membrane of modulus E does:
    held at its boundary loop nearest the ``body`` (its particles' centres) and loaded across the way from there
    to its centroid (the mean over two loads square to it and to each other: a skirt's sides take one as the
    shear a spin puts on them, a cape's face one as a turn does), at k = 1 its particles' displacements u along
    the load weighted by v s^2 (s: how far each is along the way, the parts that swing most), 9 / 20 L^2 of a
    continuum strip's of length L held at one end and loaded along it (u(s) = rho a (L s - s^2 / 2) / E; L the
    sheet's reach that way). nan where it has no boundary. Loaded along the way (hanging), the spun skirt of
    tests/test_loose_parts.py lagged 8.1 / 6.5 / 5.4 / 4.1 mm at 50 / 100 / 200 / 400 particles (1.98x apart):
    for one k the sheet in tension gives 5.4x more at 400 particles than at 50, loaded across 3.7x. Hanging and
    weighted by v alone, the kid's skirt (docs/goals.md) swung 1.53x apart over 50-1,000 particles, 1.46x so."""
    vertices, triangles = mesh
    held = _nearest_loop(vertices, triangles, body)
    if held is None:
        return math.nan
    top = vertices[held].mean(axis=0)
    way = vertices.mean(axis=0) - top
    if not np.linalg.norm(way) > 0.0:
        return math.nan
    way /= np.linalg.norm(way)
    s = (sheet.centers - top) @ way
    w = sheet.volumes * s ** 2
    reach = float(((vertices - top) @ way).max())
    across = np.linalg.svd(np.eye(3) - np.outer(way, way))[0][:, :2].T
    u = np.mean([(w * _static_displacement(sheet, vertices[held], load)).sum() for load in across]) / w.sum()
    return 20.0 / 9.0 * float(u) / reach ** 2


def _static_displacement(sheet: Graph, held: Arr, load: Arr) -> Arr:
    """The displacement along the unit ``load`` of each particle of the sheet at k = 1 and density 1 under that
    gravity, held at the points ``held``."""
    sim = Simulation(sheet, 1.0, density=1.0, gravity=load)
    for p in held:
        sim.add_position_constraint(p)
    sim.set_solver("chebyshev")
    sim.solve_static(_ITERATIONS[0])
    return (sim.positions - sheet.centers) @ load


def _nearest_loop(vertices: Arr, triangles: Arr, body: Arr) -> Ints | None:
    """The vertices of the mesh's boundary loop (edges in one triangle, joined) nearest ``body`` (points; the
    mean distance to the nearest of them of at most about _LOOP_POINTS of the loop's vertices, evenly), or None
    without a boundary."""
    e = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    edges, uses = np.unique(e, axis=0, return_counts=True)
    edges = edges[uses == 1]
    if len(edges) == 0 or len(body) == 0:
        return None
    loop = np.arange(len(vertices))
    while True:  # each boundary vertex takes the least index joined to it
        low = np.minimum(loop[edges[:, 0]], loop[edges[:, 1]])
        moved = loop.copy()
        np.minimum.at(moved, edges[:, 0], low)
        np.minimum.at(moved, edges[:, 1], low)
        if np.array_equal(moved, loop):
            break
        loop = moved[moved]
    ends = np.unique(edges)
    gap = np.array([np.sqrt(((body[None] - vertices[p[::max(1, len(p) // _LOOP_POINTS)], None]) ** 2).sum(axis=2))
                    .min(axis=1).mean() for p in (ends[loop[ends] == k] for k in np.unique(loop[ends]))])
    return ends[loop[ends] == np.unique(loop[ends])[np.argmin(gap)]]


def _compliant_ratio(graph: Graph, centre: Arr, frame: Arr, moments: Arr, second: Arr) -> float | None:
    """The bending k / E that gives the graph the continuum's compliance summed over the two cross axes,
    (1 / G_ab + 1 / G_ac) / (1 / J_ab + 1 / J_ac), or None where nothing bends. The softer direction rules, as it
    does the look: k = (J_ab + J_ac) / (G_ab + G_ac), the stiffer one's, left a 1 x 0.5 x 0.08 m plate clamped
    at a short end 2.6-8 times stiffer than beam theory over 50-400 particles (3.16x between them); this k
    1.29x (scripts/bench calibration, docs/settings.md). A square section: the same k within 3 %."""
    bend = [_bending_energy(graph, centre, frame, moments, b) for b in (1, 2)]
    if not all(g > 0.0 for g in bend) or not all(second[b, b] > 0.0 for b in (1, 2)):
        return (second[1, 1] + second[2, 2]) / sum(bend) if sum(bend) > 0.0 else None
    return (1.0 / bend[0] + 1.0 / bend[1]) / (1.0 / second[1, 1] + 1.0 / second[2, 2])


def _moments(graph: Graph) -> Arr:
    """(n, 3, 3) rest moments in rest space, Ē A Ēᵀ with A = 0.2 v diag(r^2) (METHOD.md)."""
    v, r, axes = graph.volumes, graph.radii, graph.axes
    return np.einsum("nij,nj,nkj->nik", axes, 0.2 * v[:, None] * r ** 2, axes)


def _principal_frame(graph: Graph) -> tuple[Arr, Arr, Arr]:
    """(centroid, frame whose columns are the principal axes, longest first, moments) of the particles'
    volume (centres and ellipsoids)."""
    v, x = graph.volumes, graph.centers
    moments = _moments(graph)
    centre = (v[:, None] * x).sum(axis=0) / v.sum()
    y = x - centre
    covariance = np.einsum("n,ni,nj->ij", v, y, y) + moments.sum(axis=0)
    _, frame = np.linalg.eigh(covariance)
    return centre, frame[:, ::-1], moments


def _bending_energy(graph: Graph, centre: Arr, frame: Arr, moments: Arr, b: int) -> float:
    """G of the module's docstring for fibres along frame[:, 0] bending towards frame[:, b]."""
    x = (graph.centers - centre) @ frame
    v, e = graph.volumes, graph.edges
    i = np.concatenate([e[:, 0], e[:, 1]])
    j = np.concatenate([e[:, 1], e[:, 0]])
    da2 = (x[j, 0] - x[i, 0]) ** 2
    fibre = v[j] * da2
    t = x[j, b]
    t0 = (fibre * t).sum() / fibre.sum() if fibre.sum() > 0.0 else 0.0
    ea, eb = frame[:, 0], frame[:, b]
    turn = np.einsum("i,nij,j->n", ea, moments, ea) + np.einsum("i,nij,j->n", eb, moments, eb)
    return float((fibre * (t - t0) ** 2).sum() + (v[j] * da2 ** 2).sum() / 4.0 + (da2 * turn[j]).sum())


# The measured calibration (docs/settings.md): hold one end face of the body, load it across (its own weight),
# and compare how much each part of it bends with what a continuum of its cross-sections would; then the
# other end. Each part's stiffness is scaled by that ratio, and the loads are solved again with the scale.
_ELONGATED = 3.0  # length over thickness from which a body is calibrated as a beam (a blob keeps "bending")
# ... fully from this one; in between the measured and the bending k are blended (_beam_weight). Switched at 3
# alone, a 0.2 m square Jelly bar of 150 particles drooped 3.75 % at 0.60 m and 6.08 % at 0.62 m (an outside
# review): a short beam's measured k, where shear is not negligible, is 0.73-0.81 of the bending one.
_BEAM = 5.0
# A curved body's bending moments do not follow its principal axis, so it must be nearly straight: about its
# local neutral axis it holds this share of its second moment about the axis (_Kernel.straightness). The tail
# bent along an arc of 20 / 40 / 90 / 120 degrees: 0.86 / 0.62 / 0.33 / 0.27, and measured anyway its mean k
# came out 1.01 / 1.03 / 1.34 / 1.98 times the bending k
_STRAIGHT = 0.7
_END = 0.01  # the held end face: the points within this share of the length of an end
_SAG = 1e-3  # the load's tip deflection (beam theory, the "bending" rigidity) as a share of the length: linear
_ITERATIONS = (800, 300)  # of each static solve, from rest and then from the last round's pose: the tail's,
# the capsule's and the thick bar's droops the same to 3-4 digits as with 1,500 and 500 (0.5 % off at 400 and
# 150), at 2.0 s instead of 3.5 s for 1,000 particles
_ROUNDS = 1  # corrections of the scale before the solves that measure the level (2: 1.080x against 1.082x)
_SMOOTHING = 2.0  # the kernel along the body, in particle spacings (1 and 3 spread the tail's droops the same)
# The calibration costs about 2.5 ms a particle (2.0 s at 1,000, 10 s at 4,000: 26 s an artist would wait at
# 10,000); above this count the bending k, which droops within 1-2 % of the measured one there (the tail at
# 600 and 1,000 particles: 10.74 and 10.70 % against 10.52 and 10.58 %)
_MEASURED_MAX = 1000
_LIMIT = 4.0  # the scale stays within [1/_LIMIT, _LIMIT] (a guard: 0.52-1.75 on the bodies of docs/settings.md)


def _measured_bending(graph: Graph, centre: Arr, frame: Arr, moments: Arr, second: Arr, points: Arr) -> Arr | None:
    """The measured k per Pa of each particle, or None where the body is no straight beam (length under
    _ELONGATED thicknesses, or curved) or cannot be held by an end face (an end's points on a line: a chain's
    end particle), and for more than _MEASURED_MAX particles. An end face: the ``points`` within _END of the
    length of an end."""
    if graph.n_particles > _MEASURED_MAX:
        return None
    along = (points - centre) @ frame[:, 0]
    lo, hi = along.min(), along.max()
    ends = (along <= lo + _END * (hi - lo), along >= hi - _END * (hi - lo))
    rigidity = 0.5 * sum(_bending_energy(graph, centre, frame, moments, b) for b in (1, 2)) / (hi - lo)
    across = [d for d in (0, 1) if second[0, 0] >= _ELONGATED ** 2 * second[d + 1, d + 1]]  # beam-like this way
    if not (rigidity > 0.0) or not across or any(
            np.linalg.matrix_rank(points[e] - points[e].mean(axis=0), tol=1e-9 * (hi - lo)) < 2 for e in ends):
        return None
    v = graph.volumes
    s = (graph.centers - centre) @ frame[:, 0]
    kernel = _Kernel(s, lo, hi, _SMOOTHING * float(np.cbrt(v.mean())))
    if kernel.straightness(graph, centre, frame, moments) < _STRAIGHT:
        return None
    sections = {d: kernel.section_moment(graph, frame, moments, d + 1) for d in across}
    turning = _turning(s, v)
    both = turning[0] ** 2 + turning[1] ** 2
    load = _SAG * 8.0 * rigidity / (v.sum() * (hi - lo) ** 2)  # g of a tip deflection _SAG (hi - lo) at k = 1
    scale = np.ones(graph.n_particles)
    poses: dict[tuple[int, int], tuple[Arr, Arr]] = {}  # the last round's static pose per (end, direction)
    for r in range(_ROUNDS + 1):
        curvature = {d: [None, None] for d in across}  # [direction][end]
        for e, held in enumerate(ends):
            for d in across:  # a load across each direction apart: one diagonal load gave 1.10x, not 1.08x
                sim = Simulation(graph, scale, density=1.0, gravity=load * frame[:, d + 1])
                for p in points[held]:
                    sim.add_position_constraint(p)
                if (e, d) in poses:
                    sim.set_state(*poses[e, d])
                sim.set_solver("chebyshev")
                sim.solve_static(_ITERATIONS[r > 0])
                poses[e, d] = sim.positions, sim.rotations
                fibre = sim.rotations @ frame[:, 0]
                turn = np.arctan2(fibre @ frame[:, d + 1], fibre @ frame[:, 0])
                curvature[d][e] = np.abs(kernel.slope(v, turn)) / load
        # per direction: compliance (curvature per moment, least squares over both ends), its level c (the graph
        # bends as a continuum of rigidity c I) and the ratio to it (> 1: softer than the rest)
        ratio, level = 0.0, {}
        for d, section in sections.items():
            compliance = (turning[0] * curvature[d][0] + turning[1] * curvature[d][1]) / both
            level[d] = (both * v).sum() / (both * v * compliance * section).sum()
            ratio = ratio + level[d] * compliance * section / len(across)
        if r == _ROUNDS:
            break
        scale = np.clip(scale * ratio, 1.0 / _LIMIT, _LIMIT)
        scale /= (v * scale).sum() / v.sum()
    # rigidity k c I(s) against the continuum's E I(s) J / J_particles (the body's second moment, of the mesh)
    own = _particle_second_moment(graph, centre, frame, moments)
    return scale * sum(second[d + 1, d + 1] / (own[d + 1, d + 1] * level[d]) for d in across) / len(across)


def _beam_weight(second: Arr) -> float:
    """How much of the measured k a body takes (0 to 1): by its length over its least thickness, sqrt(J_aa /
    J_cc) of its second moments, from _ELONGATED (none) to _BEAM (all)."""
    elongation = math.sqrt(second[0, 0] / second[2, 2]) if second[2, 2] > 0.0 else math.inf
    return min(max((elongation - _ELONGATED) / (_BEAM - _ELONGATED), 0.0), 1.0)


def _turning(s: Arr, v: Arr) -> tuple[Arr, Arr]:
    """The bending moment at each particle's section under a unit weight per volume, the body held at its low
    end (sum over s_j > s_i of v_j (s_j - s_i)) and at its high end: cumulative sums in the order of s."""
    order = np.argsort(s)
    s, v = s[order], v[order]
    low, high = np.empty_like(s), np.empty_like(s)
    low[order] = np.cumsum((v * s)[::-1])[::-1] - s * np.cumsum(v[::-1])[::-1]
    high[order] = s * np.cumsum(v) - np.cumsum(v * s)
    return low, high


def _clamp_points(graph: Graph, mesh: MeshArg | None) -> Arr:
    """Rest points on the body: the mesh's vertices (given or remembered), else each ellipsoid's centre and
    the ends of its axes."""
    if mesh is None and graph._made[0] == "from_mesh":
        mesh = graph._made[1][:2]
    if mesh is not None:
        return np.asarray(mesh[0], dtype=np.float64)
    tips = np.einsum("nij,nj->nji", graph.axes, graph.radii)
    c = graph.centers[:, None, :]
    return np.concatenate([c, c + tips, c - tips], axis=1).reshape(-1, 3)


class _Kernel:
    """Gaussian sums along the body: sum_j K(s_j - s_i) f_j at every particle, K of width sigma, the f binned
    on a grid of sigma / 4 over [lo, hi] (bins x bins, not particles x particles)."""

    def __init__(self, s: Arr, lo: float, hi: float, sigma: float) -> None:
        bins = max(1, int(np.ceil(4.0 * (hi - lo) / sigma)))
        self.width = (hi - lo) / bins
        self.s, self.bins = s, bins
        self.bin = np.clip(((s - lo) / self.width).astype(np.int64), 0, bins - 1)
        middle = lo + (np.arange(bins) + 0.5) * self.width
        self.weights = np.exp(-0.5 * ((middle[:, None] - middle[None, :]) / sigma) ** 2)
        self.cover = self.weights.sum(axis=1)[self.bin] * self.width  # the kernel's length on the body

    def sum(self, f: Arr) -> Arr:
        return (self.weights @ np.bincount(self.bin, f, self.bins))[self.bin]

    def slope(self, v: Arr, y: Arr) -> Arr:
        """The local least-squares slope of y along s, the particles weighted by volume v."""
        s = self.s
        w, ws, wy = self.sum(v), self.sum(v * s), self.sum(v * y)
        return (self.sum(v * s * y) - ws * wy / w) / (self.sum(v * s * s) - ws * ws / w)

    def straightness(self, graph: Graph, centre: Arr, frame: Arr, moments: Arr) -> float:
        """The least, over the cross axes, of the particles' second moment about the local neutral axis (their
        mean across the body near each) over that about the body's axis: 1 for a straight body."""
        v = graph.volumes
        ratios = []
        for b in (1, 2):
            t = (graph.centers - centre) @ frame[:, b]
            own = (frame[:, b] @ moments @ frame[:, b]).sum()
            near = self.sum(v * t) / self.sum(v)
            ratios.append(((v * (t - near) ** 2).sum() + own) / ((v * t * t).sum() + own))
        return float(min(ratios))

    def section_moment(self, graph: Graph, frame: Arr, moments: Arr, b: int) -> Arr:
        """The particles' second moment of area for bending towards frame[:, b] about the local neutral axis:
        per unit length, so that its integral along the body is theirs."""
        v = graph.volumes
        t = graph.centers @ frame[:, b]
        own = np.einsum("i,nij,j->n", frame[:, b], moments, frame[:, b])
        w, wt = self.sum(v), self.sum(v * t)
        return (self.sum(v * t * t) - wt * wt / w + self.sum(own)) / self.cover


def _body_second_moment(graph: Graph, centre: Arr, frame: Arr, moments: Arr, mesh: MeshArg | None) -> Arr:
    """The continuum's second moment (3, 3) about its centroid in ``frame``: of the closed mesh scaled to the
    particles' volume (their mass), else of the particles (centres and ellipsoids)."""
    if mesh is None and graph._made[0] == "from_mesh":
        mesh = graph._made[1][:2]
    if mesh is not None:
        vertices = np.asarray(mesh[0], dtype=np.float64)
        triangles = np.asarray(mesh[1], dtype=np.int64)
        found = _closed_mesh_moments(vertices, triangles)
        if found is not None:
            volume, second = found
            return frame.T @ second @ frame * (graph.volumes.sum() / volume)
    return _particle_second_moment(graph, centre, frame, moments)


def _particle_second_moment(graph: Graph, centre: Arr, frame: Arr, moments: Arr) -> Arr:
    """The particles' second moment (3, 3) about the centre in ``frame`` (centres and ellipsoids)."""
    y = (graph.centers - centre) @ frame
    return np.einsum("n,ni,nj->ij", graph.volumes, y, y) + frame.T @ moments.sum(axis=0) @ frame


def _closed_mesh_moments(vertices: Arr, triangles: Arr) -> tuple[float, Arr] | None:
    """(volume, second moment about the centroid) of a closed triangle mesh (every edge in two faces; the
    divergence theorem over the tetrahedra from the vertices' mean, each piece turned outward: faces turned both
    ways are made consistent first), else None (an open or non-orientable mesh, or no volume)."""
    if len(triangles) == 0:
        return None
    p = vertices[triangles] - vertices.mean(axis=0)
    det = np.einsum("ti,ti->t", p[:, 0], np.cross(p[:, 1], p[:, 2]))
    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    if len(np.unique(directed, axis=0)) != len(directed):
        turned = _outward_signs(triangles, det)  # faces turned both ways (the add-on's test tail, a box)
        if turned is None:
            return None
        det = det * turned
    elif len(np.unique(np.sort(directed, axis=1), axis=0)) * 2 != len(directed):
        return None  # an edge in one face or more than two: open
    volume = det.sum() / 6.0
    if not (volume > 0.0):
        return None
    s = p.sum(axis=1)
    centroid = (det[:, None] * s).sum(axis=0) / (24.0 * volume)
    second = np.einsum("t,tij->ij", det / 120.0, np.einsum("tki,tkj->tij", p, p) + s[:, :, None] * s[:, None, :])
    return volume, second - volume * np.outer(centroid, centroid)


def _outward_signs(triangles: Arr, det: Arr) -> Arr | None:
    """+1 or -1 per face that turns every piece of a closed, orientable mesh outward (each edge then runs once
    each way; a piece's signed volume positive), from the faces' signed tetrahedron volumes ``det``; None for
    an open or non-orientable mesh. Measured on the add-on's test tail (a 2 x 0.2 m box, 704 faces, 320 of
    them turned): the particles' own J stood in for the mesh's and its droop spread 1.19x over 50-300
    particles under the measured k; 1.03x with the mesh's."""
    count = len(triangles)
    corners = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    face = np.tile(np.arange(count), 3)
    key = np.sort(corners, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, corners, face = key[order], corners[order], face[order]
    if len(key) % 2 or not (np.all(key[0::2] == key[1::2]) and (len(key) < 4 or np.all(
            np.any(key[2::2] != key[1:-1:2], axis=1)))):
        return None  # an edge not in exactly two faces
    a, b = face[0::2], face[1::2]
    same = np.all(corners[0::2] == corners[1::2], axis=1)  # both faces run the edge the same way: one turns
    neighbours: list[list[tuple[int, bool]]] = [[] for _ in range(count)]
    for f, g, flip in zip(a.tolist(), b.tolist(), same.tolist()):
        neighbours[f].append((g, flip))
        neighbours[g].append((f, flip))
    sign, piece = np.zeros(count, np.int64), np.full(count, -1)
    for seed in range(count):
        if piece[seed] >= 0:
            continue
        piece[seed], sign[seed], todo = seed, 1, [seed]
        while todo:
            f = todo.pop()
            for g, flip in neighbours[f]:
                want = -sign[f] if flip else sign[f]
                if piece[g] < 0:
                    piece[g], sign[g] = seed, want
                    todo.append(g)
                elif sign[g] != want:
                    return None  # non-orientable
    volume = np.bincount(piece, weights=det * sign, minlength=count)
    return np.where(volume[piece] < 0.0, -sign, sign)


def step_damping(rate: float, dt: float) -> float:
    """The solver's per-step velocity damping c for a rate per second: 1 - exp(-rate dt)."""
    if not (rate >= 0.0 and math.isfinite(rate)):
        raise ValueError(f"damping = {rate} must be finite and >= 0 (per second)")
    return 1.0 - math.exp(-rate * dt)


def make_simulation(graph: Graph, material: str | Material = DEFAULT_MATERIAL, dt: float = 1 / 24,
                    gravity: Vector = (0.0, 0.0, -9.81), size: float | None = None,
                    scaling: str = "froude") -> Simulation:
    """A Simulation of ``material`` (a PRESETS name or a Material) stepping ``dt``, iterating each step to the
    material's tolerance with the measured best accelerator; its modulus and ``gravity`` scaled with the body's
    ``size`` (default ``body_size(graph)``) by ``scaling`` (SCALINGS: "goal" for a body that will follow goals
    carrying the rest shape)."""
    m = PRESETS[material] if isinstance(material, str) else material
    size = body_size(graph) if size is None else float(size)
    sim = Simulation(graph, stiffness_for(graph, m.modulus, size, scaling=scaling), density=m.density, dt=dt,
                     gravity=acting_gravity(gravity, size, scaling), damping=step_damping(m.damping, dt))
    sim.set_solver(DEFAULT_ACCELERATOR, tolerance=m.tolerance)
    return sim


def substeps_for(fps: float, max_dt: float = 1 / 240) -> int:
    """Substeps per frame so that a step is at most ``max_dt``: implicit Euler takes out energy at a rate
    proportional to dt, so equal steps give the same jiggle: 1/240 s is a whole number of steps at 24, 30, 48
    and 60 fps (measured: frequency within 0.1 %, amplitude within 1 % on the 2 m tail, 1.7 % on a capsule tail;
    docs/settings.md); at rates it does not
    divide (25, 50, 100 fps) the steps are shorter and the amplitude drifts 3-9 %."""
    if not (fps > 0.0):
        raise ValueError(f"fps = {fps} must be > 0")
    return max(1, math.ceil(1.0 / (fps * max_dt) - 1e-9))


# -- warnings the panel shows ----------------------------------------------------------------------------

def stretch_warning(graph: Graph, positions: ArrayLike, limit: float = 2.0) -> tuple[float, Ints]:
    """(largest edge length / rest length, the edges stretched beyond ``limit``): the graph tearing apart."""
    x = np.asarray(positions, dtype=np.float64)
    e, c = graph.edges, graph.centers
    ratio = np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1) / np.linalg.norm(c[e[:, 0]] - c[e[:, 1]], axis=1)
    return float(ratio.max(initial=0.0)), e[ratio > limit]


def thin_part_warning(graph: Graph, vertices: ArrayLike, triangles: ArrayLike,
                      across: float = 2) -> tuple[float, float, bool]:
    """(thinnest part of the mesh, particle spacing, whether the spacing is too coarse): a part thinner than
    ``across`` particle spacings has a particle or less across and bends like a chain, not like the body.
    The thickness at a vertex is the distance along its inward normal to the opposite side (rays against
    the triangles; the 5th percentile over vertices, so that a crease does not decide); infinite where no ray
    meets an opposite side (an open sheet: before, NaN and numpy's "invalid value" warning at every Build)."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    depths = _thickness(v, t)
    thickness = np.percentile(depths, 5) if len(depths) else math.inf
    spacing = float(np.cbrt(graph.volumes.mean()) * 1.2)
    return float(thickness), spacing, bool(thickness < across * spacing)


def thin_appendages(graph: Graph, vertices: ArrayLike, triangles: ArrayLike,
                    along: int = 3) -> list[tuple[tuple[float, float, float], float, int]]:
    """The thin appendages of a closed mesh (ears, a tail, antennas: the parts a ball of 0.35 times the body's
    greatest depth cannot enter, as the stiffness calibration finds them) with fewer than ``along`` particles:
    (centre, length m, particles), longest first; [] for an open mesh. With one or two particles such a part
    turns nearly rigidly: the character's ears (1-2 particles at 50-200) swung 31-34 mm in the hops, 52 mm at
    400 particles (4 each) and 47 mm at 1,000 (docs/settings.md). About 0.06 s for 11,500 triangles."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    if len(t) == 0 or _closed_mesh_moments(v, t) is None:
        return []
    grid = _Grid(v, t)
    label = grid.appendages()
    part = label[grid.cell_of(graph.centers)]
    out: list[tuple[tuple[float, float, float], float, int]] = []
    for p in np.unique(label[label >= 0]):
        cells = grid.centres(np.flatnonzero(label == p))
        centre = cells.mean(axis=0)
        axis = _cell_axes(cells)[:, 0]
        s = (cells - centre) @ axis
        count = int((part == p).sum())
        if count < along:
            x, y, z = (float(c) for c in centre)
            out.append(((x, y, z), float(s.max() - s.min() + grid.h), count))
    return sorted(out, key=lambda x: -x[1])


def _thickness(v: Arr, t: Arr) -> Arr:
    """The distance along each vertex's inward normal to the nearest other triangle, of the vertices whose
    normal meets one (Moller-Trumbore)."""
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    fn = np.cross(b - a, c - a)
    normal = np.zeros_like(v)
    for k in range(3):
        np.add.at(normal, t[:, k], fn)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    e1, e2 = b - a, c - a
    out = np.full(len(v), np.inf)
    for i, (p, d) in enumerate(zip(v, -normal)):
        h = np.cross(d, e2)
        det = (e1 * h).sum(axis=1)
        ok = np.abs(det) > 1e-14
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = p - a
        u = (s * h).sum(axis=1) * inv
        q = np.cross(s, e1)
        w = (d * q).sum(axis=1) * inv
        dist = (e2 * q).sum(axis=1) * inv
        hit = ok & (u >= 0) & (w >= 0) & (u + w <= 1) & (dist > 1e-9 * (1 + np.abs(p).max()))
        if hit.any():
            out[i] = dist[hit].min()
    return out[np.isfinite(out)]


def handle_warning(sim: Simulation, speed: float, angular_speed: float = 0.0, substeps: int = 1,
                   fps: float = 24.0) -> tuple[float, bool]:
    """(motion of a driven handle per step / the body's size, whether it is too fast): a handle that moves
    more than 5 % of the body's size (or turns more than 10 degrees) in one step needs more substeps or a
    looser tolerance cap; measured in docs/settings.md. ``speed`` m/s, ``angular_speed`` rad/s."""
    dt = 1.0 / (fps * substeps)
    per_step = speed * dt / body_size(sim.graph)
    turn = math.degrees(angular_speed * dt)
    return per_step, bool(per_step > 0.05 or turn > 10.0)


# -- appendages: thin parts off a thick core, calibrated one by one (issue 24) ------------------------------
# A creature's ears and tail hold 1-8 of its 50-400 particles: too few for the measured calibration's end
# faces, and under the body's one bending k its tail, the torso held, drooped 5.4x more at 400 particles than
# at 50. Each thin part is cut from the closed mesh's volume on a grid (a morphological opening: the cells that
# no ball of _THIN times the body's greatest depth inside it reaches), held at its root (the core particles with
# an edge to it) and loaded across by its weight; its k is set so that its tip deflects as the continuum
# cantilever of its own cross-sections would.
_THIN = 0.35  # the opening ball's radius over the greatest depth (the creature's ears and tail: 0.12-0.2)
_GRID_CELLS = 200_000  # grid cells over the mesh's bounding box
_MARGIN = 2  # cells of the core's rim left to it: two ears met through the rim of the head between them
_SECTION = 4.0  # cells per cell of length, at least, of a part (the creature's ears 16, a plate's edges 1-2)
_TIP = 0.1  # the tip region: the last share of an appendage's length
_BENT = 0.2  # a body whose skeleton leaves its chord by this share of it is split there (the L-bracket: 0.45)
_SKELETON_CELLS = 20_000  # grid cells over the bounding box for the skeleton
_TIP_POINTS = 40  # at most this many of the tip region's cells skinned
_FIT_ROUNDS = 3  # solves of an appendage's k after the first
# An appendage's k stays above the body's over this. A thin plate (an ear) fitted to its bending across its
# thickness wants less, but its one k also holds its particles' edges against stretching: at 1/64 the dog's ears
# at 1,000 particles (the fit at its floor) stretched 1.86x their length at Floppy, 1.41x at the default look;
# at 1/20 1.40x and 1.27x, and the ears' swing at 100 and 1,000 particles 1.18x apart instead of 1.49x
# (docs/goals.md, "Edges that stretch").
_SOFTEST = 20.0
# An open sheet of its own (_sheets_floored) swings as a membrane of the body's modulus / this. The kid's skirt
# (docs/goals.md) at the defaults, 50 / 100 / 400 / 1,000 particles: 16 hem 26.3 / 31.8 / 47.0 / 36.4 mm, Floppy
# 1,000 its edges 1.44x; 15 the hem at 50 particles 24.1 mm; 17 Floppy 1,000 1.47x; 19 32.1 / 36.0 / 58.9 / 44.0.
_SHEET_SOFTEST = 16.0
_LOOP_POINTS = 256  # of a sheet's boundary loop, to tell how near the body it is
_RINGS = 3  # rings of particles round an appendage in the graph that fits its k: its root, one more, one held
_CORE_CELLS = 1000  # at most this many of the core's grid cells, evenly by index, to hold appendages at
_LEVEL_ROUNDS = 2  # of a straight beam's tip levelling


def _closed_mesh(graph: Graph, mesh: MeshArg | None) -> tuple[Arr, Arr] | None:
    """(vertices, triangles) of the closed mesh given or remembered, else None."""
    if mesh is None and graph._made[0] == "from_mesh":
        mesh = graph._made[1][:2]
    if mesh is None:
        return None
    vertices, triangles = np.asarray(mesh[0], dtype=np.float64), np.asarray(mesh[1], dtype=np.int64)
    return (vertices, triangles) if _closed_mesh_moments(vertices, triangles) is not None else None


def _with_parts(graph: Graph, mesh: tuple[Arr, Arr], ratio: Ratio) -> Ratio:
    """``ratio`` (k / E per particle, or one for the body) with each thin appendage's particles given their own
    k / E, or, on a bent body with none, each straight part's; ``ratio`` itself where the body has neither."""
    grid = _Grid(*mesh)
    label = grid.appendages()
    part = label[grid.cell_of(graph.centers)]
    if not (part >= 0).any():
        return _with_straight_parts(graph, mesh, grid, ratio)
    ratio = np.full(graph.n_particles, ratio) if np.ndim(ratio) == 0 else np.array(ratio)
    core = grid.centres(np.flatnonzero(grid.inside.ravel() & (label < 0)))
    core = core[np.linspace(0, len(core) - 1, min(len(core), _CORE_CELLS)).astype(np.int64)]
    nearest = _nearest_particle(graph, core)
    for p in np.unique(part[part >= 0]):
        chosen = np.flatnonzero(part == p)
        found = _appendage_ratio(graph, chosen, grid.centres(np.flatnonzero(label == p)), grid.h, ratio,
                                 (core, nearest))
        if found is not None:
            ratio[found[0]] = found[1]
    return ratio


def _with_straight_parts(graph: Graph, mesh: tuple[Arr, Arr], grid: "_Grid", ratio: Ratio) -> Ratio:
    """k / E per particle of a bent body, each straight part (the cells and particles nearest a segment of its
    skeleton, _Grid.skeleton) calibrated as a body of its own, its second moment and end faces the grid cells'
    (``grid``, of the closed ``mesh``): the particles' own J left the L-bracket 1.39x apart over 50-400
    particles (docs/settings.md). ``ratio`` where the body is straight or a part cannot be calibrated."""
    corners = _Grid(*mesh, cells=_SKELETON_CELLS).skeleton()
    if corners is not None and len(corners) == 2 and np.ndim(ratio) == 1:
        samples = grid.centres(np.flatnonzero(grid.inside.ravel()))
        return _tip_levelled(graph, samples, grid.h, _clamp_points(graph, mesh), ratio)
    if corners is None or len(corners) < 3:
        return ratio
    parts = _straight_parts(graph, grid, corners, ratio)
    return parts if np.ndim(parts) == 0 else _frame_levelled(graph, _clamp_points(graph, mesh), corners, parts,
                                                               _Grid(*mesh, cells=_SKELETON_CELLS))


def _straight_parts(graph: Graph, grid: "_Grid", corners: Arr, ratio: Ratio) -> Ratio:
    """k / E per particle of a bent body whose skeleton has the ``corners``, each straight part calibrated as a
    body of its own (_with_straight_parts); ``ratio`` where no part can be."""
    centres = grid.centres(np.flatnonzero(grid.inside.ravel()))
    owner = _nearest_segment(centres, corners)
    part = _nearest_segment(graph.centers, corners)
    found = np.full(graph.n_particles, np.nan)
    for p in range(len(corners) - 1):
        chosen = np.flatnonzero(part == p)
        mine = owner == p
        if len(chosen) < 2 or not mine.any():
            continue
        chosen = _largest_piece(graph, chosen)
        sub = _subgraph(graph, chosen)
        if sub.n_edges == 0:
            continue
        centre, frame, moments = _principal_frame(sub)
        y = (centres[mine] - centre) @ frame
        second = (y.T @ y + mine.sum() * grid.h ** 2 / 12.0 * np.eye(3)) * (sub.volumes.sum() / mine.sum())
        own = _body_ratio(sub, centre, frame, moments, second, centres[mine])
        if own is not None:
            found[chosen] = own
    return ratio if np.isnan(found).all() else np.where(np.isnan(found), ratio, found)


def _tip_levelled(graph: Graph, samples: Arr, h: float, points: Arr, ratio: Ratio) -> Ratio:
    """``ratio`` (k / E per particle of a straight beam, measured) scaled, linearly along the body, so that the
    graph held at either end face (the rest ``points`` within _END of the length of an end) and loaded across
    each direction in which it is a beam deflects at its tip region as the continuum of the grid cells
    ``samples`` of side h does (_cantilever_tip), blended in as the measured k is (_beam_weight). The measured curvature level alone left
    a 1 x 0.5 x 0.08 m plate at 50 particles 13 % too stiff held at one end and 14 % too soft at the other (its
    slope, from a particle or two across, is coarse), and 1.15x softer than at 100-400 where the bench holds
    it; the tip is what the look is. _LEVEL_ROUNDS rounds: the ends' errors move each other's."""
    centre, frame, _ = _principal_frame(graph)
    y = (samples - centre) @ frame
    second = y.T @ y
    across = [d for d in (1, 2) if second[0, 0] >= _ELONGATED ** 2 * second[d, d]]
    along = (points - centre) @ frame[:, 0]
    lo, hi = along.min(), along.max()
    share = np.clip(((graph.centers - centre) @ frame[:, 0] - lo) / (hi - lo), 0.0, 1.0)
    if not across:
        return ratio
    ends = []
    for sign in (1.0, -1.0):
        s = sign * y[:, 0]
        held = points[sign * along <= (sign * along).min() + _END * (hi - lo)]
        tip = _tip_cells(s)
        ends.append((held, samples[tip], [(frame[:, d], _cantilever_tip(s, y[:, d], h, tip)) for d in across]))
    return _levelled(graph, ratio, share, hi - lo, ends, _beam_weight(second))


def _levelled(graph: Graph, ratio: Ratio, share: Arr, length: float,
              ends: list[tuple[Arr, Arr, list[tuple[Arr, float]]]], weight: float) -> Ratio:
    """``ratio`` (k / E per particle) scaled, linearly in ``share`` (0 at the first end, 1 at the other), so that
    the graph held at each end deflects at the tip region as the continuum does, by ``weight`` (0 to 1).
    ``ends``: for the body held at its first and then its other end, (the rest points held, the tip's rest
    points, [(a load's direction, the continuum's tip compliance under it)]); the body's ``length``.
    _LEVEL_ROUNDS rounds: the ends' errors move each other's. Unchanged where a continuum's compliance is not a
    positive number (a load along the body), and from a round whose level is not."""
    if not all(continuum > 0.0 and math.isfinite(continuum) for _, _, loads in ends for _, continuum in loads):
        return ratio
    for _ in range(_LEVEL_ROUNDS):
        found = []
        for held, tip, loads in ends:
            level = []
            for direction, continuum in loads:
                load = _SAG * length / continuum
                level.append(_tip_compliance(graph, ratio, held, tip, direction, load) / continuum)
            found.append(float(np.mean(level)))
        if not all(f > 0.0 and math.isfinite(f) for f in found):
            break
        ratio = ratio * (1.0 + weight * (found[0] * (1.0 - share) + found[1] * share - 1.0))
    return ratio


def _frame_levelled(graph: Graph, points: Arr, corners: Arr, ratio: Ratio, grid: "_Grid") -> Ratio:
    """``ratio`` (k / E per particle of a bent body) levelled as a straight beam's is (_levelled), against the
    continuum frame of the ``grid``'s cells along the skeleton ``corners`` (_frame_tip), loaded across the
    least principal axis of the cells (across the plane of an L); held at the rest ``points`` within _END of
    the skeleton's length of either end. The straight parts calibrated one by one left the L-bracket 1.26x
    apart over seven counts from 50 to 400 particles (its corner and the torsion of its long arm under the
    short one's weight, which no part's calibration sees); levelled, 1.07x (docs/settings.md)."""
    cells = grid.centres(np.flatnonzero(grid.inside.ravel()))
    direction = np.linalg.eigh(np.cov((cells - cells.mean(axis=0)).T))[1][:, 0]
    arc, length = _arc_length(cells, corners), _arc_length(corners[-1:], corners)[0]
    along = _arc_length(points, corners)
    ends = []
    for s, way, held in ((arc, corners, along <= along.min() + _END * length),
                         (length - arc, corners[::-1], along >= along.max() - _END * length)):
        tip = _tip_cells(s)
        ends.append((points[held], cells[tip], [(direction, _frame_tip(cells, grid.h, way, direction, tip))]))
    share = np.clip(_arc_length(graph.centers, corners) / length, 0.0, 1.0)
    return _levelled(graph, ratio, share, length, ends, 1.0)


def _arc_length(points: Arr, corners: Arr) -> Arr:
    """The distance along the polyline ``corners`` from its first corner of each point's projection on the
    segment nearest it."""
    segment = _nearest_segment(points, corners)
    step = np.diff(corners, axis=0)
    lengths = np.linalg.norm(step, axis=1)
    start = np.concatenate([[0.0], np.cumsum(lengths)])
    return start[segment] + ((points - corners[segment]) * step[segment]).sum(axis=1) / lengths[segment]


def _frame_tip(cells: Arr, h: float, corners: Arr, direction: Arr, tip: Arr) -> float:
    """The mean deflection along ``direction`` of the ``tip`` cells of a continuum frame (E = 1, G = E / 2: the
    graph's energy has no volume term, Poisson's ratio 0; unit weight per volume along ``direction``) of the
    cells of side h along the skeleton ``corners``, clamped at the first corner: the unit-load method over
    slices of width h along it, each bending about its section's principal axes and twisting about the
    skeleton (Saint-Venant's torsion constant A^4 / (4 pi^2 I_p) of the section). A straight 1 m cantilever:
    0.986 of q L^4 / 8 E I."""
    arc = _arc_length(cells, corners)
    axes = np.diff(corners, axis=0) / np.linalg.norm(np.diff(corners, axis=0), axis=1)[:, None]
    segment = _nearest_segment(cells, corners)
    slices = (arc / h).astype(np.int64)
    unit = cells[tip].mean(axis=0)  # the tip's mean point, where the unit load acts
    total = 0.0
    for b in np.unique(slices):
        here = slices == b
        if here.sum() < 2:
            continue
        p = cells[here].mean(axis=0)
        axis = axes[np.bincount(segment[here]).argmax()]
        across = np.eye(3) - np.outer(axis, axis)
        y = (cells[here] - p) @ across
        second, frame = np.linalg.eigh((y.T @ y + here.sum() * h * h / 12.0 * across) * h * h)
        moment = np.cross(cells[arc > (b + 0.5) * h] - p, direction).sum(axis=0) * h ** 3
        lever = np.cross(unit - p, direction)
        area = here.sum() * h * h
        twist = area ** 4 / (4.0 * np.pi ** 2 * (second[1] + second[2]))
        total += h * ((moment @ axis) * (lever @ axis) / (0.5 * twist)
                      + (moment @ frame[:, 1]) * (lever @ frame[:, 1]) / second[2]
                      + (moment @ frame[:, 2]) * (lever @ frame[:, 2]) / second[1])
    return total


def _tip_cells(s: Arr) -> Arr:
    """Up to _TIP_POINTS of the cells at s in the last _TIP share of the length (the tip region)."""
    tip = np.flatnonzero(s >= s.max() - _TIP * (s.max() - s.min()))
    return tip[np.linspace(0, len(tip) - 1, min(len(tip), _TIP_POINTS)).astype(np.int64)]


def _tip_compliance(graph: Graph, k: Ratio, held: Arr, tip: Arr, direction: Arr, load: float,
                    poses: dict[int, tuple[Arr, Arr]] | None = None, key: int = 0) -> float:
    """The mean static deflection along ``direction`` per unit load of the rest points ``tip`` (skinned) of the
    graph of stiffness ``k``, held at the rest points ``held``, under a weight ``load`` per volume along it.
    ``poses``: the static poses found so far by ``key``; the solve starts from the one under ``key`` (with
    fewer iterations) and leaves its own there."""
    sim = Simulation(graph, k, density=1.0, gravity=load * direction)
    for p in held:
        sim.add_position_constraint(p)
    sim.set_solver("chebyshev")
    start = poses.get(key) if poses is not None else None
    if start is not None:
        sim.set_state(*start)
    sim.solve_static(_ITERATIONS[start is not None])
    if poses is not None:
        poses[key] = sim.positions, sim.rotations
    return float(((sim.skin_points(tip) - tip) @ direction).mean()) / load


def _subgraph(graph: Graph, chosen: Arr) -> Graph:
    """The graph of the particles ``chosen`` and the edges between them."""
    index = np.full(graph.n_particles, -1)
    index[chosen] = np.arange(len(chosen))
    e = index[graph.edges]
    return Graph(graph.centers[chosen], graph.radii[chosen], e[(e >= 0).all(axis=1)], graph.axes[chosen])


def _largest_piece(graph: Graph, chosen: Arr) -> Arr:
    """The particles ``chosen`` that make the largest connected piece of their subgraph (the first on a tie): a
    straight part of a bent body can fall apart where the part nearest each segment cuts a link (the L bracket
    at 1.5 and 3 times its size, 200 particles: a piece held at neither end made solve_static refuse the
    calibration)."""
    count, label = _subgraph(graph, chosen).pieces()
    return chosen if count < 2 else chosen[label == np.argmax(np.bincount(label))]


def _nearest_particle(graph: Graph, points: Arr) -> Arr:
    """The index of the particle whose centre is nearest each point (1,000 points at a time)."""
    c = graph.centers
    found = [np.argmin(((chunk[:, None, :] - c[None]) ** 2).sum(axis=2), axis=1)
             for chunk in np.array_split(points, len(points) // 1000 + 1)]
    return np.concatenate(found)


def _nearest_segment(points: Arr, corners: Arr) -> Arr:
    """For each point, the segment of the polyline ``corners`` (m, 3) nearest it (0 .. m - 2)."""
    distance = []
    for a, b in zip(corners[:-1], corners[1:]):
        h = np.clip(((points - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
        distance.append(np.linalg.norm(points - (a + h[:, None] * (b - a)), axis=1))
    return np.argmin(np.stack(distance, axis=1), axis=1)


def _straightened(points: Arr, corners: Sequence[int]) -> Arr:
    """The polyline through ``points`` at the indices ``corners`` refitted: a line through each run of points
    between two corners (its middle half: the level sets round a corner off), each inner corner where the
    lines on either side come closest, the ends the end points on their lines."""
    lines = []
    for a, b in zip(corners[:-1], corners[1:]):
        run = points[a + (b - a) // 4:b - (b - a) // 4 + 1]
        middle = run.mean(axis=0)
        lines.append((middle, np.linalg.svd(run - middle)[2][0]))
    fitted = [lines[0][0] + (points[0] - lines[0][0]) @ lines[0][1] * lines[0][1]]
    for (p, u), (q, w) in zip(lines[:-1], lines[1:]):
        # closest points p + a u, q + b w of two lines: a - b (u.w) = (q - p).u, a (u.w) - b = (q - p).w
        c, d = u @ w, q - p
        a, b = np.linalg.lstsq([[1.0, -c], [c, -1.0]], [d @ u, d @ w], rcond=None)[0]
        fitted.append(0.5 * (p + a * u + q + b * w))
    fitted.append(lines[-1][0] + (points[-1] - lines[-1][0]) @ lines[-1][1] * lines[-1][1])
    return np.array(fitted)


def _polyline(points: Arr, bent: float) -> list[int]:
    """Indices of the corners of a polyline through ``points`` (m, 3), in order (Douglas-Peucker): a point
    further than ``bent`` times the chord from it becomes a corner, and each side is split again."""
    a, b = points[0], points[-1]
    chord = np.linalg.norm(b - a)
    if len(points) < 3 or chord == 0.0:
        return [0, len(points) - 1]
    off = np.linalg.norm(np.cross(points - a, b - a), axis=1) / chord
    far = int(np.argmax(off))
    if off[far] <= bent * chord:
        return [0, len(points) - 1]
    left, right = _polyline(points[:far + 1], bent), _polyline(points[far:], bent)
    return left + [far + i for i in right[1:]]


def _appendage_ratio(graph: Graph, chosen: Arr, samples: Arr, h: float, ratio: Arr,
                     core: tuple[Arr, Arr]) -> tuple[Arr, float] | None:
    """k / E of the particles ``chosen`` (an appendage, whose volume is the grid cells ``samples`` of side h):
    loaded across each of its cross axes, the k at which its tip region's compliance (summed over both) is the
    continuum cantilever's; None where nothing holds it. It is held as the body holds it: the graph of it and
    _RINGS rings of particles round it (the first its root, the particles with an edge to it), the core's grid
    cells nearest the outermost ring held (``core``: (core cells, the particle nearest each)). Held instead at
    its root's neighbours (their centres and axis ends), the character's tail was fitted 25 % stiffer at 150
    particles than the whole graph held at its torso is (16 % softer at 75), and its droop spread 1.37x over
    seven counts from 50 to 400 particles; held so, 1.10x (docs/settings.md)."""
    e = graph.edges
    layers = [chosen, np.setdiff1d(e[np.isin(e, chosen).any(axis=1)], chosen)]
    root = layers[1]
    if len(root) == 0:
        return None
    for _ in range(_RINGS - 1):
        inner = np.concatenate(layers)
        layers.append(np.setdiff1d(e[np.isin(e, layers[-1]).any(axis=1)], inner))
    cells, nearest = core
    outer = [layer for layer in layers[2:] if len(layer)]  # the outermost ring that has particles
    held = cells[np.isin(nearest, outer[-1])] if outer else cells[:0]
    if len(held) == 0:
        return None
    axes = _cell_axes(samples)
    s = (samples - graph.centers[root].mean(axis=0)) @ axes[:, 0]
    if s.mean() < 0.0:
        s, axes = -s, -axes
    tip = _tip_cells(s)
    continuum = sum(_cantilever_tip(s, samples @ axes[:, b], h, tip) for b in (1, 2))
    members = np.concatenate(layers)
    part = _subgraph(graph, members)
    guess = float(np.mean(ratio[chosen]))
    own = len(chosen)
    k = ratio[members].copy()
    poses: dict[int, tuple[Arr, Arr]] = {}  # the last static pose per cross axis: the next k's solve starts there

    def compliance(own_k: float) -> float:
        k[:own] = own_k
        loads = [_SAG * (s.max() - s.min()) * (own_k / guess) / _cantilever_tip(s, samples @ axes[:, b], h, tip)
                 for b in (1, 2)]
        return sum(_tip_compliance(part, k, held, samples[tip], axes[:, b], load, poses, b)
                   for b, load in zip((1, 2), loads))
    return chosen, _series_fit(compliance, guess, continuum, guess / _SOFTEST)


def _series_fit(compliance: Callable[[float], float], k: float, target: float, least: float) -> float:
    """The k (at least ``least``) at which ``compliance(k)`` is ``target``, for a compliance a + b / k: the
    part's own springs in series with what holds it (the root's, fixed). Scaling k by compliance / target
    alone converges as (a / target)^n: the character's tail was still 10-20 % off after three rounds."""
    found = [(k, compliance(k))]
    for _ in range(_FIT_ROUNDS):
        (k0, c0), (k1, c1) = found[-2:] if len(found) > 1 else (found[0], (None, None))
        if k1 is None or c1 is None or k0 == k1 or c0 == c1:
            k = k0 * c0 / target
        else:
            b = (c0 - c1) / (1.0 / k0 - 1.0 / k1)
            a = c0 - b / k0
            k = b / (target - a) if b > 0.0 and target > a else k1 * c1 / target
        found.append((max(k, least), compliance(max(k, least))))
    return found[-1][0]


def _cell_axes(cells: Arr) -> Arr:
    """The principal axes of grid cells' centres (columns), longest first."""
    return np.linalg.eigh(np.cov((cells - cells.mean(axis=0)).T))[1][:, ::-1]


def _cantilever_tip(s: Arr, t: Arr, h: float, tip: Arr) -> float:
    """The mean deflection of the ``tip`` cells of a continuum cantilever (E = 1, unit weight per volume)
    whose cells of side h lie at s along it and t across, clamped at its least s: slices of width h, each
    with its weight and second moment of area, curvature M / I integrated twice from the root."""
    bins = np.minimum(((s - s.min()) / h).astype(np.int64), int((s.max() - s.min()) / h))
    count = np.bincount(bins).astype(np.float64)
    middle = s.min() + (np.arange(len(count)) + 0.5) * h
    mean = np.bincount(bins, t) / np.maximum(count, 1.0)
    second = (np.bincount(bins, t * t) - count * mean ** 2 + count * h * h / 12.0) * h * h  # per unit length
    weight = count * h ** 3
    moment = np.array([(weight[j + 1:] * (middle[j + 1:] - middle[j])).sum() for j in range(len(count))])
    curvature = moment / np.maximum(second, second.max() * 1e-6)
    deflection = np.cumsum(np.cumsum(curvature) * h) * h
    return float(deflection[bins[tip]].mean())


class _Grid:
    """A closed mesh's volume on a grid of cubes of side ``h`` from ``lo``: ``inside`` (nx, ny, nz), the cells
    whose centres the mesh encloses (its crossings along z at each column's centre, paired)."""

    def __init__(self, vertices: Arr, triangles: Arr, cells: int = _GRID_CELLS) -> None:
        self.lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        a, b, c = np.sort(hi - self.lo)[::-1]
        # at least a side at which the two largest extents take ``cells``: a closed capsule 1.2 x 0.2 m squashed
        # to 2e-8 m wanted 1.2e9 columns (8.8 GiB) and Build raised MemoryError (scripts/calibration_sweep.py)
        self.h = float(max(np.cbrt(a * b * c / cells), np.sqrt(a * b / cells), a / cells))
        self.shape = tuple(int(x) for x in np.ceil((hi - self.lo) / self.h))
        self.inside = self._fill((vertices[triangles] - self.lo) / self.h - 0.5)

    def _fill(self, p: Arr) -> Arr:
        """The inside cells from the triangles p (t, 3, 3) in cell units (cell i's centre at i)."""
        nx, ny, nz = self.shape
        p = p[_area(p[:, 0], p[:, 1], p[:, 2, :2]) != 0.0]  # a face seen edge-on from above crosses no column
        lo = np.maximum(np.ceil(p[:, :, :2].min(axis=1)), 0).astype(np.int64)
        span = np.maximum(np.minimum(np.floor(p[:, :, :2].max(axis=1)), [nx - 1, ny - 1]) - lo + 1, 0).astype(np.int64)
        count = span[:, 0] * span[:, 1]
        tri = np.repeat(np.arange(len(p)), count)
        k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        q = lo[tri] + np.stack([k % span[tri, 0], k // span[tri, 0]], axis=1)
        a, b, c = p[tri, 0], p[tri, 1], p[tri, 2]
        w = np.stack([_area(b, c, q), _area(c, a, q), _area(a, b, q)], axis=1) / _area(a, b, c[:, :2])[:, None]
        hit = (w >= 0.0).all(axis=1)
        column = q[hit, 0] * ny + q[hit, 1]
        z = (w[hit] * np.stack([a[hit, 2], b[hit, 2], c[hit, 2]], axis=1)).sum(axis=1)
        # a column through an edge or a corner meets each face there: one crossing (a flat face on a grid of
        # vertices, the plate's, else left holes through the body)
        crossing = np.unique(np.stack([column, np.round(z, 9)], axis=1), axis=0)
        column, z = crossing[:, 0].astype(np.int64), crossing[:, 1]
        starts = np.searchsorted(column, column, side="left")
        rank = np.arange(len(column)) - starts
        even = np.bincount(column, minlength=nx * ny)[column] % 2 == 0
        enter = np.flatnonzero((rank % 2 == 0) & even)
        first = np.clip(np.ceil(z[enter]), 0, nz).astype(np.int64)
        last = np.clip(np.floor(z[enter + 1]) + 1, 0, nz).astype(np.int64)
        change = np.zeros((nx * ny, nz + 1), np.int64)
        np.add.at(change, (column[enter], first), 1)
        np.add.at(change, (column[enter], last), -1)
        return (np.cumsum(change, axis=1)[:, :nz] > 0).reshape(nx, ny, nz)

    def centres(self, flat: Arr) -> Arr:
        return self.lo + (np.stack(np.unravel_index(flat, self.shape), axis=1) + 0.5) * self.h

    def cell_of(self, points: Arr) -> Arr:
        """The flat cell index of each point (clipped to the grid)."""
        i = np.clip(((points - self.lo) / self.h).astype(np.int64), 0, np.array(self.shape) - 1)
        return np.ravel_multi_index(tuple(i.T), self.shape)

    def skeleton(self) -> Arr | None:
        """The corners (m, 3) of the body's skeleton, a polyline: the centroids of the level sets of the
        geodesic distance (in steps to the 26 neighbours) from one end face, the cells furthest from a cell,
        cut at the corners of _polyline at _BENT; None where the inside is not one connected body."""
        cells = np.flatnonzero(self.inside.ravel())
        first = self.geodesic(cells[:1])[cells]
        if len(cells) == 0 or (first < 0).any():
            return None
        level = self.geodesic(cells[first == first.max()])[cells]
        count = np.bincount(level)
        xyz = self.centres(cells)
        skeleton = np.stack([np.bincount(level, xyz[:, i]) for i in range(3)], axis=1) / count[:, None]
        return _straightened(skeleton, _polyline(skeleton, _BENT))

    def geodesic(self, seeds: Arr) -> Arr:
        """Per flat cell, its distance in steps (26 neighbours) through the inside from the flat cells
        ``seeds``; -1 where none reaches."""
        shape = np.array(self.shape) + 2
        inside = np.pad(self.inside, 1).ravel()
        step = _steps(shape)
        distance = np.full(inside.size, -1)
        front = np.ravel_multi_index(tuple((np.stack(np.unravel_index(seeds, self.shape)) + 1)), shape)
        distance[front], d = 0, 0
        while len(front):
            d += 1
            near = np.unique((front[:, None] + step).ravel())
            front = near[inside[near] & (distance[near] < 0)]
            distance[front] = d
        return distance.reshape(shape)[1:-1, 1:-1, 1:-1].ravel()

    def appendages(self) -> Arr:
        """A flat label per cell: the connected thin part it is in (0, 1, ...), -1 for the core and outside."""
        inside = np.pad(self.inside, 1)  # outside all round: a fill touching the grid's side erodes there too
        depth = 0
        eroded = inside
        while eroded.any():  # ends: a padded grid loses its outer layer at every step
            eroded, depth = _erode(eroded, depth), depth + 1
        radius = max(1, int(round(_THIN * depth)))
        core = inside
        for r in range(radius):
            core = _erode(core, r)
        for r in range(radius + _MARGIN):
            core = _dilate(core, r)
        core = core[1:-1, 1:-1, 1:-1]
        label = _components(self.inside & ~core).ravel()
        index = np.stack(np.unravel_index(np.arange(label.size), self.shape), axis=1)
        for p in range(label.max() + 1):
            cells = np.flatnonzero(label == p)
            length = np.linalg.norm(index[cells].max(axis=0) - index[cells].min(axis=0)) + 1.0
            if len(cells) < _SECTION * length:  # slivers along a box's edges and creases, not parts
                label[cells] = -1
        return label


def _steps(shape: Arr) -> Arr:
    """The flat offsets of the 26 neighbours of a cell in a grid of ``shape``."""
    o = np.stack(np.meshgrid(*[np.arange(-1, 2)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    o = o[np.any(o != 0, axis=1)]
    return o @ np.array([shape[1] * shape[2], shape[2], 1])


def _area(a: Arr, b: Arr, q: Arr) -> Arr:
    """Twice the signed area of the triangles (a, b, q) in xy."""
    return (b[:, 0] - a[:, 0]) * (q[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (q[:, 0] - a[:, 0])


def _dilate(mask: Arr, step: int) -> Arr:
    """One step of a ball's dilation: the 6 face neighbours on even steps, the 26 on odd (an octagon-like
    ball, closer to round than either)."""
    out = mask.copy()
    for axis in range(3):
        grown = out if step % 2 else mask
        shifted = np.zeros_like(grown)
        for lo, hi in ((slice(1, None), slice(None, -1)), (slice(None, -1), slice(1, None))):
            a, b = [slice(None)] * 3, [slice(None)] * 3
            a[axis], b[axis] = lo, hi
            shifted[tuple(a)] |= grown[tuple(b)]
        out = out | shifted
    return out


def _erode(mask: Arr, step: int) -> Arr:
    return ~_dilate(~mask, step)


def _components(mask: Arr) -> Arr:
    """Labels 0, 1, ... of the face-connected components of ``mask``, -1 elsewhere: each cell takes the least
    flat index among its neighbours' and then its label's label (pointer jumping), until nothing changes."""
    big = mask.size
    label = np.where(mask, np.arange(big).reshape(mask.shape), big)
    while True:
        spread = label.copy()
        for axis in range(3):
            for lo, hi in ((slice(1, None), slice(None, -1)), (slice(None, -1), slice(1, None))):
                a, b = [slice(None)] * 3, [slice(None)] * 3
                a[axis], b[axis] = lo, hi
                spread[tuple(a)] = np.minimum(spread[tuple(a)], label[tuple(b)])
        spread = np.where(mask, spread, big)
        flat = np.append(spread.ravel(), big)
        spread = flat[flat[spread]]
        if np.array_equal(spread, label):
            break
        label = spread
    _, number = np.unique(label, return_inverse=True)
    return np.where(mask, number.reshape(mask.shape), -1)
