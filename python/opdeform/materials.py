"""Settings an artist can use (issue 14): a stiffness in Pa that looks the same at any size and particle count,
presets, an error tolerance, substeps for a frame rate, and the checks a panel warns with. See docs/settings.md.

**Stiffness.** The solver's k (J/m^5) is not a material constant: the elastic energy k sum v_j |R d - d'|^2
of a uniform strain e is k e^2 sum_edges (v_i + v_j) |d|^2 / 3 (averaged over directions), which a continuum
of Young's modulus E stores as E e^2 V / 2 (V the body's volume), so

    k = 3 E V / sum_edges (v_i + v_j) |d_ij|^2          (``stiffness_for``)

and k falls as 1/spacing^2 as particles are added. E itself is not scale-free: a body of size L under
gravity sags by a fraction proportional to rho g L / E (and its frequencies scale as sqrt(E / rho) / L), so a
real material looks ten times softer ten times larger. The artist's ``modulus`` is therefore the modulus the
material has at REFERENCE_SIZE (1 m); a body of size L acts with E = modulus * L / 1 m. Then rho g L / E is the
same at every size: the same relative sag, and periods that scale as sqrt(L / g), the Froude scaling of
miniatures (a ten times larger tail sways sqrt(10) times slower, as a real one would). Measured in
docs/settings.md.

**Damping** is a rate per second (``step_damping`` turns it into the solver's per-step c for a dt), so it
does not change with the frame rate.
"""

import math
from dataclasses import dataclass

import numpy as np

from .graph import Graph
from .simulation import Simulation

__all__ = ["DEFAULT_MATERIAL", "DEFAULT_TOLERANCE", "Material", "PRESETS", "REFERENCE_SIZE", "body_size",
           "handle_warning", "make_simulation", "preset_table", "simulation_settings", "stiffness_for",
           "step_damping", "stretch_warning", "substeps_for", "thin_part_warning"]

REFERENCE_SIZE = 1.0  # m: the size at which a material's modulus is its modulus
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


# Droop of the 2 m x 0.2 m tail pinned at its root (100 particles, static, docs/settings.md): Jelly ~ 45 %,
# Flesh ~ 25 %, Rubber ~ 10 % (the default: it droops and jiggles visibly), Stiff ~ 1 %.
PRESETS = {m.name: m for m in (
    Material("Jelly", 1.0e6, 1050.0, 0.5, description="wobbly: the 2 m tail droops about 45 %"),
    Material("Flesh", 2.0e6, 1050.0, 1.0, description="soft and damped: droops about 25 %, settles quickly"),
    Material("Rubber", 5.0e6, 1100.0, 0.3, description="the default: droops about 10 % and jiggles visibly"),
    Material("Stiff", 5.0e7, 1000.0, 0.3, description="nearly rigid: droops about 1 %"),
)}
DEFAULT_MATERIAL = "Rubber"


def preset_table():
    """The presets as plain data for a panel: a list of dicts (name, modulus, density, damping, tolerance,
    description), in PRESETS order."""
    return [dict(name=m.name, modulus=m.modulus, density=m.density, damping=m.damping, tolerance=m.tolerance,
                 description=m.description) for m in PRESETS.values()]


def simulation_settings(graph, modulus, density, damping, tolerance=DEFAULT_TOLERANCE, fps=24.0, substeps=None,
                        size=None):
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


def body_size(graph):
    """The largest extent of the rest body (particle centres plus their largest radius), m."""
    reach = graph.radii.max(axis=1, keepdims=True)
    c = graph.centers
    return float(((c + reach).max(axis=0) - (c - reach).min(axis=0)).max())


def stiffness_for(graph, modulus, size=None):
    """The solver's k for a material of ``modulus`` Pa at REFERENCE_SIZE on this graph; ``size`` (m) is the
    body's size (default ``body_size(graph)``)."""
    if not isinstance(graph, Graph):
        raise TypeError("graph must be an opdeform.Graph")
    if not (modulus > 0.0 and math.isfinite(modulus)):
        raise ValueError(f"modulus = {modulus} must be finite and > 0")
    size = body_size(graph) if size is None else float(size)
    c, v, e = graph.centers, graph.volumes, graph.edges
    if len(e) == 0:
        raise ValueError("the graph has no edges: a stiffness needs at least one")
    arm = ((v[e[:, 0]] + v[e[:, 1]]) * ((c[e[:, 0]] - c[e[:, 1]]) ** 2).sum(axis=1)).sum()
    return 3.0 * modulus * (size / REFERENCE_SIZE) * v.sum() / arm


def step_damping(rate, dt):
    """The solver's per-step velocity damping c for a rate per second: 1 - exp(-rate dt)."""
    if not (rate >= 0.0 and math.isfinite(rate)):
        raise ValueError(f"damping = {rate} must be finite and >= 0 (per second)")
    return 1.0 - math.exp(-rate * dt)


def make_simulation(graph, material=DEFAULT_MATERIAL, dt=1 / 24, gravity=(0.0, 0.0, -9.81), size=None):
    """A Simulation of ``material`` (a PRESETS name or a Material) stepping ``dt``, iterating each step to the
    material's tolerance with the measured best accelerator."""
    m = PRESETS[material] if isinstance(material, str) else material
    sim = Simulation(graph, stiffness_for(graph, m.modulus, size), density=m.density, dt=dt, gravity=gravity,
                     damping=step_damping(m.damping, dt))
    sim.set_solver(DEFAULT_ACCELERATOR, tolerance=m.tolerance)
    return sim


def substeps_for(fps, max_dt=1 / 240):
    """Substeps per frame so that a step is at most ``max_dt``: implicit Euler takes out energy at a rate
    proportional to dt, so equal steps give the same jiggle at any frame rate: 1/240 s is a whole number of
    steps at 24, 30, 48 and 60 fps (measured: frequency within 2 %, amplitude within 1 %, docs/settings.md)."""
    if not (fps > 0.0):
        raise ValueError(f"fps = {fps} must be > 0")
    return max(1, math.ceil(1.0 / (fps * max_dt) - 1e-9))


# -- warnings the panel shows ----------------------------------------------------------------------------

def stretch_warning(graph, positions, limit=2.0):
    """(largest edge length / rest length, the edges stretched beyond ``limit``): the graph tearing apart."""
    x = np.asarray(positions, dtype=np.float64)
    e, c = graph.edges, graph.centers
    ratio = np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1) / np.linalg.norm(c[e[:, 0]] - c[e[:, 1]], axis=1)
    return float(ratio.max(initial=0.0)), e[ratio > limit]


def thin_part_warning(graph, vertices, triangles, across=2):
    """(thinnest part of the mesh, particle spacing, whether the spacing is too coarse): a part thinner than
    ``across`` particle spacings has a particle or less across and bends like a chain, not like the body.
    The thickness at a vertex is the distance along its inward normal to the opposite side (rays against
    the triangles; the 5th percentile over vertices, so that a crease does not decide)."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    thickness = np.percentile(_thickness(v, t), 5)
    spacing = float(np.cbrt(graph.volumes.mean()) * 1.2)
    return float(thickness), spacing, bool(thickness < across * spacing)


def _thickness(v, t):
    """Per vertex, the distance along its inward normal to the nearest other triangle (Moller-Trumbore)."""
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
    return out[np.isfinite(out)] if np.isfinite(out).any() else np.array([np.inf])


def handle_warning(sim, speed, angular_speed=0.0, substeps=1, fps=24.0):
    """(motion of a driven handle per step / the body's size, whether it is too fast): a handle that moves
    more than 5 % of the body's size (or turns more than 10 degrees) in one step needs more substeps or a
    looser tolerance cap; measured in docs/settings.md. ``speed`` m/s, ``angular_speed`` rad/s."""
    dt = 1.0 / (fps * substeps)
    per_step = speed * dt / body_size(sim.graph)
    turn = math.degrees(angular_speed * dt)
    return per_step, bool(per_step > 0.05 or turn > 10.0)
