"""The paper's scenes, built in code: the bar of Figs. 1-2 and a 100-particle, 261-edge body for Fig. 4.

Shared by scripts/demo, scripts/bench and the tests so that all three measure the same thing.
"""

import math
from typing import Any

import numpy as np

from ._arguments import ArrayLike, Floats, Ints, Vector
from . import materials, meshes
from .graph import Graph
from .mesh import Skin
from .simulation import Simulation, frame_from_normal

BAR_LENGTH = 2.0
BAR_WIDTH = 0.2
BAR_PARTICLES = 20
BAR_STIFFNESS = 1e9  # k for the bar (METHOD.md's value): 5.6 % sag, a small deflection


def bar_graph(particles: int = BAR_PARTICLES, length: float = BAR_LENGTH, width: float = BAR_WIDTH) -> Graph:
    """A chain of disc-like ellipsoids filling a length x width x width box along +x (Fig. 2, right)."""
    dx = length / particles
    centers = np.zeros((particles, 3))
    centers[:, 0] = (np.arange(particles) + 0.5) * dx
    radii = np.tile([dx / 2, width / 2, width / 2], (particles, 1))
    edges = np.stack([np.arange(particles - 1), np.arange(1, particles)], axis=1)
    return Graph(centers, radii, edges)


def end_face_points(x: float, width: float = BAR_WIDTH, count: int = 5) -> Floats:
    """The count x count grid of vertices of the bar's end face at x (25 points, as the paper pins)."""
    s = np.linspace(-width / 2, width / 2, count)
    yy, zz = np.meshgrid(s, s, indexing="ij")
    return np.stack([np.full(yy.size, x), yy.ravel(), zz.ravel()], axis=1)


def fig1_bar(stiffness: float | ArrayLike = BAR_STIFFNESS, **sim_args: Any) -> Simulation:
    """Fig. 1: the bar fixed at its x = 0 end face by 25 position constraints, sagging under gravity.
    Returns the simulation; the tip is the rest point (BAR_LENGTH, 0, 0)."""
    sim = Simulation(bar_graph(), stiffness, **sim_args)
    for p in end_face_points(0.0):
        sim.add_position_constraint(p)
    return sim


BAR_TIP = (BAR_LENGTH, 0.0, 0.0)


def tip_sag(sim: Simulation) -> float:
    """How far the bar's tip has dropped below its rest height."""
    return -float(sim.skin_points([BAR_TIP])[0, 2])


class TwistedBar:
    """Fig. 2: the fixed bar whose free end is twisted about the bar's axis and moved by one position
    constraint and three direction constraints (the end frame's axes)."""

    def __init__(self, stiffness: float | ArrayLike = BAR_STIFFNESS, **sim_args: Any) -> None:
        self.sim = fig1_bar(stiffness, **sim_args)
        self.tip = np.array(BAR_TIP)
        self.position_id = self.sim.add_position_constraint(self.tip)
        self.direction_ids = [self.sim.add_direction_constraint(self.tip, axis) for axis in np.eye(3)]

    def pose(self, angle: float, offset: Vector) -> None:
        """Twist the end by ``angle`` radians about +x and move it by ``offset``."""
        c, s = math.cos(angle), math.sin(angle)
        tip = (BAR_LENGTH + offset[0], offset[1], offset[2])
        self.sim.set_constraint_target(self.position_id, tip)
        for cid, axis in zip(self.direction_ids, ((1.0, 0.0, 0.0), (0.0, c, s), (0.0, -s, c))):
            self.sim.set_constraint_target(cid, axis)

    def animate(self, t: float, duration: float = 2.0) -> None:
        """The pose at time t of a clip that twists the end by 180 degrees and lifts it by 0.5."""
        u = min(max(t / duration, 0.0), 1.0)
        self.pose(math.pi * u, (-0.3 * u, 0.0, 0.5 * u))


def body_graph(rows: int = 10, cols: int = 10, spacing: float = 0.1, height: float = 1.0) -> Graph:
    """A 100-particle, 261-edge body (the paper's Fig. 4 graph size): a triangulated 10 x 10 slab of
    flattened ellipsoids, 180 lattice edges and 81 diagonals, tilted and lifted above the floor."""
    ij = np.array([(i, j) for i in range(rows) for j in range(cols)], float)
    centers = np.zeros((rows * cols, 3))
    centers[:, :2] = ij * spacing
    tilt = math.radians(20.0)
    rot = np.array([[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]])
    centers = centers @ rot.T + [0.0, 0.0, height]
    radii = np.tile([spacing * 0.55, spacing * 0.55, spacing * 0.3], (rows * cols, 1))
    axes = np.tile(rot, (rows * cols, 1, 1))

    def node(i: int, j: int) -> int:
        return i * cols + j

    edges = [(node(i, j), node(i, j + 1)) for i in range(rows) for j in range(cols - 1)]
    edges += [(node(i, j), node(i + 1, j)) for i in range(rows - 1) for j in range(cols)]
    edges += [(node(i, j), node(i + 1, j + 1)) for i in range(rows - 1) for j in range(cols - 1)]
    return Graph(centers, radii, np.array(edges), axes)


def falling_body(stiffness: float | ArrayLike = 2e5, friction: float = 0.5, **sim_args: Any) -> Simulation:
    """Fig. 4's set-up: the 100-particle body dropped on a floor at z = 0 with friction."""
    sim = Simulation(body_graph(), stiffness, **sim_args)
    sim.set_floor(0.0, friction)
    return sim


def lowest_point(sim: Simulation) -> float:
    """The lowest point of any ellipsoid (support distance along -z)."""
    g = sim.graph
    frames = sim.rotations @ g.axes
    s = np.sqrt(((g.radii * frames[:, 2, :]) ** 2).sum(axis=1))
    return float((sim.positions[:, 2] - s).min())


class RampCube:
    """Issue 27's box on a ramp: a 0.3 m Rubber cube (64 particles) set 1 cm above a 30-degree plane collider of
    friction ``mu`` (it lands flat), stepping 1/``fps`` s; with ``skin`` its mesh, not its ellipsoids, meets the
    plane. Used by tests/test_contact.py, tests/test_skin_contact.py and scripts/contact_figures.py /
    contact_pictures.py."""

    DEGREES = 30.0

    def __init__(self, mu: float, fps: float, skin: bool = False, graph: Graph | None = None) -> None:
        vertices, self.triangles = meshes.bar(length=0.3, width=0.3, segments=4, cross=4)
        self.vertices = vertices - vertices.mean(axis=0)
        self.graph = Graph.from_mesh(self.vertices, self.triangles, particles=64) if graph is None else graph
        theta = math.radians(self.DEGREES)
        self.normal = np.array([0.0, -math.sin(theta), math.cos(theta)])
        self.frame = frame_from_normal(self.normal)
        self.sim = materials.make_simulation(self.graph, "Rubber", dt=1 / fps)
        self.skin = Skin(self.graph, self.vertices)
        g = self.graph
        lowest = self.vertices[:, 2].min() if skin else \
            (g.centers[:, 2] - np.sqrt(((g.radii * g.axes[:, 2, :]) ** 2).sum(axis=1))).min()
        self.start = (g.centers + (0.0, 0.0, 0.01 - lowest)) @ self.frame.T
        self.sim.set_state(self.start, np.tile(self.frame, (g.n_particles, 1, 1)))
        if skin:
            self.sim.set_contact_skin(self.skin)
        self.sim.add_collider("plane", normal=tuple(self.normal), friction=mu)

    def moved(self) -> tuple[float, float]:
        """(distance its centre travelled, degrees it turned) since the start."""
        u, _, vt = np.linalg.svd(self.sim.rotations.mean(axis=0))
        turned = math.degrees(math.acos(np.clip((np.trace(u @ vt @ self.frame.T) - 1.0) / 2.0, -1.0, 1.0)))
        return float(np.linalg.norm(self.sim.positions.mean(axis=0) - self.start.mean(axis=0))), turned


def bent_rod(self_contact: bool, sweep: float = 1.0,
             steps: int = 120) -> tuple[Simulation, Floats, Ints, int, list[tuple[float, float, float]]]:
    """A 1.2 m rod along x (a capsule mesh, 60 particles) held at its root end by two pins, and the targets
    of the pin on its tip, one a step: a half circle about the middle through ``sweep`` half turns in 90 of
    ``steps`` steps (1: onto the root; more: past it). Returns (sim, vertices, triangles, tip's constraint id,
    targets). Used by tests/test_body_contact.py and scripts/contact_pictures.py."""
    vertices, triangles = meshes.capsule(radius=0.06, length=1.2)
    graph = Graph.from_mesh(vertices, triangles, particles=60)
    sim = Simulation(graph, 1e5, dt=1 / 60, gravity=(0, 0, 0), damping=0.05)
    if self_contact:
        sim.set_self_contact()
    x = graph.centers[:, 0]
    lo, hi = x.min(), x.max()
    sim.add_position_constraint((lo, 0.0, 0.0))
    sim.add_position_constraint((lo + 0.15, 0.0, 0.0))
    tip = sim.add_position_constraint((hi, 0.0, 0.0))
    r, middle = (hi - lo) / 2, (lo + hi) / 2
    angles = [math.pi * sweep * min(1.0, (k + 1) / 90) for k in range(steps)]
    return sim, vertices, triangles, tip, [(middle + r * math.cos(a), 0.0, r * math.sin(a)) for a in angles]
