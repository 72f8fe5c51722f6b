"""The stability cases of issue 5, shared by tests/test_stability.py and `scripts/bench stability`.

Every case runs a scene to its end and returns an Outcome with:
- finite: no step raised SolverError (the core rejects any NaN or infinity) and the final state is finite;
- rise: the worst rise of the objective inside one step (sim.energy_trace: the objective after the first
  global solve and after every local and global step), relative to the allowance below, so rise <= 1 passes;
- figure: the case's stated result, compared with its bound (figure <= bound passes).

The allowance for a rise is round-off: 1e-11 of the largest magnitude in that step's trace (assert_monotone
of tests/test_core.py) plus the round-off of the objective itself (Body.roundoff): a term s|r|²/2
whose residual r is a difference of coordinates of size L is known only to about s|r| eps L, and a state
stored to an ulp of L cannot resolve the objective below ~D (eps L)² (D the stiffness, the global matrix's
diagonal). The second part matters only where a step's objective is tiny next to its terms: a body at rest
(the collapsed start ends at 1e-17 J, the yanked lattice at 30 m from the origin at 1e-20 J) and the
1e12-weight pins, whose residuals of 1e-12 m carry 1e18 N/m (a 1-ulp change of the state moves their
energy by ~5e-12 J).

Direction constraints hold l = |Σ w_j R_j n̄| fixed during a local step (eq. 10), so a local step can raise
the true objective; for a case with direction constraints only the global steps (exact minimisations over
the centres, which direction constraints do not depend on) are held to the allowance. The local steps do
rise there: by 4e4 J on 3.8e7 J in the first frame of the half-turn yank (twist case).

`quick=True` shortens the 10,000-frame jiggle to 1,500 frames for the test; the bench runs it in full.
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np

import opdeform
from opdeform import scenes
from test_core import lattice_graph, rigid_residual

ROUND_OFF = 1e-11
EPS = np.finfo(float).eps


@dataclass
class Outcome:
    figure: float
    bound: float
    what: str  # what the figure is
    finite: bool = True
    rise: float = 0.0  # worst rise / allowance (<= 1 passes)
    steps: int = 0
    ms: float = 0.0
    notes: str = ""
    extra: list = field(default_factory=list)  # further (what, figure, bound) that must hold too

    @property
    def passed(self):
        return (self.finite and self.rise <= 1.0 and self.figure <= self.bound
                and all(f <= b for _, f, b in self.extra))


@dataclass
class Case:
    name: str
    params: str
    run: object  # run(quick) -> Outcome
    slow: bool = False  # takes more than a few seconds in full


class Monitor:
    """Steps a simulation one step at a time, checking every step's energy trace. ``pins``: the position
    constraints (a Pins), for the round-off of their terms."""

    def __init__(self, sim, directions=False, pins=None):
        self.sim = sim
        self.body = Body(sim)
        self.directions = directions
        self.pins = pins
        sim.trace_energy = True
        self.rises = []  # per step: worst rise / allowance
        self.finite = True
        self.steps = 0
        self.seconds = 0.0

    def step(self, count=1, before_each=None):
        for _ in range(count):
            if not self.finite:
                return
            if before_each:
                before_each(self.steps)
            s = self.sim
            before = s.positions, s.rotations, s.velocities, s.angular_velocities
            t = time.process_time()  # CPU time: other work on a shared machine does not inflate it
            try:
                s.step()
            except opdeform.SolverError:
                self.finite = False
                return
            self.seconds += time.process_time() - t
            self.steps += 1
            tr = s.energy_trace
            d = np.diff(tr)
            if self.directions:  # global steps only: the odd differences
                d = d[1::2]
            allowance = ROUND_OFF * np.abs(tr).max() + self.body.roundoff(before, self.pins)
            self.rises.append(d.max() / allowance)

    def outcome(self, figure, bound, what, notes=""):
        s = self.sim
        finite = self.finite and all(np.isfinite(a).all() for a in (s.positions, s.rotations, s.velocities))
        return Outcome(float(figure), bound, what, finite, float(max(self.rises, default=0.0)), self.steps,
                       1e3 * self.seconds / max(self.steps, 1), notes)


# -- energy of the motion ---------------------------------------------------------------------------------

def moments(graph):
    """Ā_i = Ē_i A_i Ē_iᵀ, A_i = 0.2 v_i diag(a², b², c²)."""
    a = 0.2 * graph.volumes[:, None] * graph.radii ** 2
    e = graph.axes
    return np.einsum("nab,nb,ncb->nac", e, a, e)


def skew(w):
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    return out


class Pins:
    """Position constraints (rest points, targets, weights) with their skinning, for mechanical_energy."""

    def __init__(self, sim, points, targets, weights):
        self.points = np.asarray(points, float).reshape(-1, 3)
        self.targets = np.asarray(targets, float).reshape(-1, 3)
        self.weights = np.broadcast_to(np.asarray(weights, float), len(self.points))
        m = sim.params["skin_neighbors"]
        skin = [sim.graph.skin_weights(p, m) for p in self.points]
        self.idx = np.array([i for i, _ in skin])
        self.w = np.array([w for _, w in skin])
        self.arm = (self.points[:, None, :] - sim.graph.centers[self.idx])[..., None]  # p̄ - X̄_j

    def residuals(self, sim):
        """s_c - t_c: where each skinned point is against its target."""
        x, rot = sim.positions, sim.rotations
        s = ((rot[self.idx] @ self.arm)[..., 0] + x[self.idx]) * self.w[..., None]
        return s.sum(1) - self.targets

    def energy(self, sim):
        return float(self.weights @ (self.residuals(sim) ** 2).sum(1)) / 2 if len(self.points) else 0.0

    def stiffness(self):
        """Σ_c w_c Σ_a w_a²: what the constraints add to the diagonal of the global matrix."""
        return float(self.weights @ (self.w ** 2).sum(1)) if len(self.points) else 0.0

    def forces(self, sim):
        return float(self.weights @ np.linalg.norm(self.residuals(sim), axis=1)) if len(self.points) else 0.0


class Body:
    """The terms of a simulation's objective evaluated in numpy, with the graph's constants cached (the cases
    step thousands of times): the mechanical energy of the motion and the round-off of the objective."""

    def __init__(self, sim):
        g, p = sim.graph, sim.params
        self.sim = sim
        self.k, self.rho, self.h = p["stiffness"], p["density"], p["dt"]
        self.keep, self.gravity = 1.0 - p["damping"], np.asarray(p["gravity"])
        self.vol, self.rest, self.a = g.volumes, g.centers, moments(g)
        self.mass = self.rho * self.vol
        self.i = np.r_[g.edges[:, 0], g.edges[:, 1]]  # directed edges i -> j
        self.j = np.r_[g.edges[:, 1], g.edges[:, 0]]
        self.arm = (self.rest[self.j] - self.rest[self.i])[:, :, None]
        self.reach = np.abs(self.rest).max() + g.radii.max()
        self.diag = self.mass.sum() / self.h ** 2 + 2 * self.k * self.vol[g.edges].sum()

    def edge_residuals(self, x, rot):
        """R_i (X̄_j - X̄_i) - (x_j - x_i) per directed edge."""
        return (rot[self.i] @ self.arm)[:, :, 0] - (x[self.j] - x[self.i])

    def mechanical_energy(self, pins=None):
        """Kinetic (linear and angular) + elastic (METHOD.md's Ee) + gravity potential + position
        constraints (a Pins) of the current state: what implicit Euler must not increase."""
        s = self.sim
        x, rot, v, w = s.positions, s.rotations, s.velocities, s.angular_velocities
        spin = skew(w) @ rot
        e = self.mass @ (v * v).sum(1) / 2 + self.rho * (spin @ self.a * spin).sum() / 2
        d = rot[self.i] - rot[self.j]
        r = self.edge_residuals(x, rot)
        e += self.k / 2 * ((d @ self.a[self.j] * d).sum() + self.vol[self.j] @ (r * r).sum(1))
        e -= self.mass @ (x @ self.gravity)
        return float(e) + (pins.energy(s) if pins else 0.0)

    def roundoff(self, before, pins=None):
        """The round-off of a dynamic step's objective at the current state, ``before`` = (x, R, v, ω) at
        the start of the step (None: a static pose's objective): eps x Σ over the terms s|r|²/2 of s|r| L
        (L the size of the coordinates r is a difference of), eps x Σ of the rotation terms' k‖(R_i - R_j) Ā_j‖
        (a rotation is known to eps), and 50 D (eps L)²: a state stored to an ulp of L cannot resolve the
        objective below 1/2 D (eps L)² near a minimum, D the stiffness (the global matrix's diagonal); we
        allow 10 ulps."""
        s = self.sim
        x, rot = s.positions, s.rotations
        size = np.abs(x).max() + self.reach
        force = self.k * self.vol[self.j] @ np.linalg.norm(self.edge_residuals(x, rot), axis=1)
        force += np.linalg.norm(self.gravity) * self.mass.sum()
        turn = self.k * np.linalg.norm((rot[self.i] - rot[self.j]) @ self.a[self.j], axis=(1, 2)).sum()
        diag = self.diag
        if before is None:  # a static pose: no inertia
            diag -= self.mass.sum() / self.h ** 2
        else:
            x0, r0, v0, w0 = before
            h, keep = self.h, self.keep
            y = x0 + h * keep * v0 + h * h * self.gravity
            predicted = r0 + h * keep * skew(w0) @ r0
            force += self.mass @ np.linalg.norm(x - y, axis=1) / h ** 2
            turn += self.rho / h ** 2 * np.linalg.norm((rot - predicted) @ self.a, axis=(1, 2)).sum()
        if pins is not None:
            force += pins.forces(s)
            diag += pins.stiffness()
        return float(EPS * (force * size + turn) + 50 * diag * (EPS * size) ** 2)


def mechanical_energy(sim, pins=None):
    return Body(sim).mechanical_energy(pins)


def static_pose(make_sim, iterations=5000):
    """The minimum of elastic + gravity + constraints (a static solve; the bar converges in a few thousand
    iterations, METHOD.md fact 3)."""
    sim = make_sim()
    sim.solve_static(iterations)
    return sim


# -- starts -----------------------------------------------------------------------------------------------

def random_rotations(rng, n, max_angle=math.pi):
    """n rotations about random axes by angles uniform in [0, max_angle] (max_angle = pi: uniform-ish)."""
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0.0, max_angle, n)
    k = skew(axis)
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1 - c) * (k @ k)


# -- the cases --------------------------------------------------------------------------------------------

def bar_pins(sim, weight=None):
    """The bar's 25 end-face pins of scenes.fig1_bar."""
    face = scenes.end_face_points(0.0)
    return Pins(sim, face, face, sim.default_weight() if weight is None else weight)


def energy_band(make_sim, steps, pins=bar_pins):
    """Runs a scene from rest: the mechanical energy must never exceed its start. Figure: the largest
    excess over the run relative to the depth of the static minimum |E* - E(0)|."""
    sim = make_sim()
    held = pins(sim)
    mon = Monitor(sim, pins=held)
    e0 = mon.body.mechanical_energy(held)
    ref = static_pose(make_sim)
    depth = abs(mechanical_energy(ref, held) - e0)
    worst = -math.inf
    for _ in range(steps):
        mon.step()
        worst = max(worst, mon.body.mechanical_energy(held) - e0)
    return mon.outcome(worst / depth, 1e-9, "max (E(t)-E(0)) / |E*-E(0)|",
                       f"tip sag {scenes.tip_sag(sim):.3g}, static {scenes.tip_sag(ref):.3g}")


def stiffness_case(ratio, iterations):
    def run(quick):
        rho = 1000.0
        return energy_band(lambda: scenes.fig1_bar(ratio * rho, density=rho, iterations=iterations), 300)
    return Case(f"stiffness k/rho={ratio:g} it={iterations}", f"bar, k = {ratio:g} rho, h = 1/60, 300 steps",
                run)


def static_case(ratio=1e12, reference=1e9, iterations=10000):
    """The static pose of the Fig. 1 bar at k = 1e12 rho, where the sag is 1e-7 m on a 2 m bar: in the linear
    regime sag x k is a constant, so it must match the k = 1e9 rho pose's. No inertia, so the rises of the
    objective are held to the static objective's round-off at the final pose (the smallest over the solve)."""
    def run(quick):
        sags = []
        for r in (reference, ratio):
            sim = scenes.fig1_bar(r * 1e3)
            sim.trace_energy = True
            t = time.process_time()
            sim.solve_static(iterations)
            seconds = time.process_time() - t
            sags.append(scenes.tip_sag(sim) * r)
        tr = sim.energy_trace
        allowance = ROUND_OFF * np.abs(tr).max() + Body(sim).roundoff(None, bar_pins(sim))
        return Outcome(abs(sags[1] / sags[0] - 1), 1e-3, f"|sag k / (sag k at k = {reference:g} rho) - 1|",
                       rise=float(np.diff(tr).max() / allowance), steps=iterations, ms=1e3 * seconds / iterations,
                       notes=f"sag {sags[1] / ratio:.6g} m; ms per iteration",
                       finite=bool(np.isfinite(sim.positions).all()))
    return Case(f"static k/rho={ratio:g}", f"bar, solve_static({iterations}), against k = {reference:g} rho", run)


def step_size_case(steps_per_second):
    def run(quick):
        return energy_band(lambda: scenes.fig1_bar(dt=1.0 / steps_per_second), 2 * steps_per_second)
    return Case(f"step h=1/{steps_per_second}", "bar, k = 1e6 rho, 10 it, 2 s", run)


def ellipsoid_points(centers, rotations, graph):
    """Each particle's centre and the six tips of its ellipsoid's axes (x ± R Ē r_a e_a): the visible body."""
    tips = np.einsum("nab,nb->nba", rotations @ graph.axes, graph.radii)  # (n, 3 axes, 3)
    return np.concatenate([centers, (centers[:, None] + tips).reshape(-1, 3), (centers[:, None] - tips).reshape(-1, 3)])


def shape_error(sim):
    """The worst distance of a centre or axis tip from the rest shape after the best rigid alignment
    (Kabsch over all of them), in particle diameters (twice the mean largest radius)."""
    g = sim.graph
    now = ellipsoid_points(sim.positions, sim.rotations, g)
    rest = ellipsoid_points(g.centers, np.tile(np.eye(3), (g.n_particles, 1, 1)), g)
    _, rot = rigid_residual(now, rest)
    err = np.linalg.norm((now - now.mean(0)) @ rot - (rest - rest.mean(0)), axis=1).max()
    return float(err / (2 * g.radii.max(1).mean()))


def recover(make_sim, start, steps, bound=1e-6):
    """From a start (positions, rotations), zero gravity, damped: the body returns to its rest shape up to a
    rigid motion, every ellipsoid turned with the body. Figure: shape_error."""
    sim = make_sim()
    sim.set_state(*start)
    mon = Monitor(sim)
    mon.step(steps)
    residual, _ = rigid_residual(sim.positions, sim.graph.centers)
    return mon.outcome(shape_error(sim), bound, "worst point off the rest shape / particle diameter",
                       f"centres' RMS residual {residual:.2g}")


def lattice_sim(graph=None, stiffness=1e5, **kw):
    kw = {"gravity": (0, 0, 0), "damping": 0.05, **kw}
    return opdeform.Simulation(graph or lattice_graph(), stiffness, **kw)


def start_label(ratio, steps_per_second):
    return "" if (ratio, steps_per_second) == (100, 60) else f" k/rho={ratio:g} h=1/{steps_per_second}"


def collapsed_case(ratio=100, steps_per_second=60, steps=600):
    """Fig. 3: every particle at the lattice's centre with a random rotation; at k = 1e12 rho the step is
    stiff against its inertia by 1e10, the case that needed the global solve's correction."""
    def run(quick):
        g = lattice_graph()
        rng = np.random.default_rng(3)
        start = (np.tile(g.centers.mean(0), (g.n_particles, 1)), random_rotations(rng, g.n_particles))
        return recover(lambda: lattice_sim(g, ratio * 1e3, dt=1 / steps_per_second), start, steps)
    return Case("collapsed start" + start_label(ratio, steps_per_second), f"4x4x4 lattice, k = {ratio:g} rho, "
                f"h = 1/{steps_per_second}, all at one point, random rotations, {steps} steps", run)


def inverted_case(ratio=100, steps_per_second=60, steps=600):
    def run(quick):
        g = lattice_graph()
        mirrored = g.centers * [-1, 1, 1]
        start = (mirrored, np.tile(np.eye(3), (g.n_particles, 1, 1)))
        return recover(lambda: lattice_sim(g, ratio * 1e3, dt=1 / steps_per_second), start, steps)
    return Case("inverted start" + start_label(ratio, steps_per_second), f"4x4x4 lattice, k = {ratio:g} rho, "
                f"h = 1/{steps_per_second}, mirrored in x, rotations I, {steps} steps", run)


SHAPES = {  # radii as fractions of half the spacing; the long axis along x
    "spheres": (1.0, 1.0, 1.0),
    "needles": (1.0, 1e-3, 1e-3),
    "discs": (1.0, 1.0, 1e-3),
}


def shaped_graph(kind, shape, spacing=0.1):
    """A 20-particle chain along x, a flat 10 x 10 triangulated sheet, or a 4x4x4 lattice, with every
    particle's radii set to SHAPES[shape] x spacing/2 (axes: the rest frames of the graph)."""
    if kind == "chain":
        n = 20
        centers = np.c_[np.arange(n) * spacing, np.zeros(n), np.zeros(n)]
        edges, axes = np.c_[np.arange(n - 1), np.arange(1, n)], None
    elif kind == "sheet":
        flat = scenes.body_graph(spacing=spacing, height=0.0)
        centers, edges, axes = flat.centers, flat.edges, flat.axes
    else:
        solid = lattice_graph(spacing=spacing)
        centers, edges, axes = solid.centers, solid.edges, None
    radii = np.tile(np.asarray(SHAPES[shape]) * spacing / 2, (len(centers), 1))
    return opdeform.Graph(centers, radii, edges, axes)


def perturbed(graph, rng, shift=0.2, spacing=0.1, max_angle=math.pi / 2):
    """Rest centres moved by up to shift x spacing and rotations turned by up to max_angle, at random."""
    x = graph.centers + rng.uniform(-shift, shift, graph.centers.shape) * spacing
    return x, random_rotations(rng, graph.n_particles, max_angle)


def shape_case(kind, shape, steps=600, stiffness=1e7):
    """k/rho = 1e4: a chain bends through the rotation term alone, and at k/rho = 100 its slowest mode
    takes thousands of steps to settle (it halves every 600 steps)."""
    def run(quick):
        g = shaped_graph(kind, shape)
        return recover(lambda: lattice_sim(g, stiffness), perturbed(g, np.random.default_rng(5)), steps)
    return Case(f"{shape} {kind}", f"{g_size(kind)}, radii {SHAPES[shape]}, k = 1e4 rho, perturbed, {steps} steps",
                run)


def g_size(kind):
    return {"chain": "20-particle chain", "sheet": "10x10 sheet", "solid": "4x4x4 lattice"}[kind]


def mass_ratio_case(kind, ratio=1e6, steps=600, stiffness=1e7):
    """Neighbours alternate between radius r and r / ratio^(1/3): masses (and elastic weights, which scale
    with the volume) differ by ``ratio`` across every chain edge and every lattice axis edge."""
    def run(quick):
        g0 = shaped_graph(kind, "spheres")
        parity = np.rint(g0.centers / 0.1).astype(int).sum(1) % 2
        radii = g0.radii * np.where(parity, ratio ** (-1 / 3), 1.0)[:, None]
        g = opdeform.Graph(g0.centers, radii, g0.edges, g0.axes)
        return recover(lambda: lattice_sim(g, stiffness), perturbed(g, np.random.default_rng(7)), steps)
    return Case(f"mass ratio {ratio:g} {kind}", f"{g_size(kind)}, alternate radii 1 : {ratio ** (1 / 3):g}, "
                f"k = 1e4 rho, perturbed, {steps} steps", run)


def elastic_unit(sim):
    """k x the mean particle volume: the weight of an edge's position term, what constraint weights are
    measured against (the default weight is 1000 of these)."""
    return sim.params["stiffness"] * sim._mean_volume


def handle_bar(handle=None, pins=1e3, lift=0.5):
    """The Fig. 1 bar with its 25 end-face pins and, unless handle is None, a tip handle raised by ``lift``;
    weights in elastic units (pins=1e3: the default weight). Returns (sim, Pins of all constraints)."""
    sim = opdeform.Simulation(scenes.bar_graph(), scenes.BAR_STIFFNESS)
    unit = elastic_unit(sim)
    face = scenes.end_face_points(0.0)
    for p in face:
        sim.add_position_constraint(p, weight=pins * unit)
    points, targets, weights = list(face), list(face), [pins * unit] * len(face)
    if handle is not None:
        target = np.add(scenes.BAR_TIP, (0.0, 0.0, lift))
        sim.add_position_constraint(scenes.BAR_TIP, target, handle * unit)
        points.append(scenes.BAR_TIP), targets.append(target), weights.append(handle * unit)
    return sim, Pins(sim, points, targets, weights)


def light_constraint_case(relative=1e-6, steps=300):
    """A handle of 1e-6 elastic units is a 1 N/m spring on a 412 N bar: it must act, and act linearly (the
    tip's departure from the bar without a handle doubles when the weight doubles)."""
    def run(quick):
        free, _ = handle_bar()
        sim, pins = handle_bar(relative)
        double, _ = handle_bar(2 * relative)
        mon = Monitor(sim, pins=pins)
        for _ in range(steps):
            free.step(), double.step()
            mon.step()
        tip = [s.skin_points([scenes.BAR_TIP])[0] for s in (free, sim, double)]
        pull, pull2 = tip[1] - tip[0], tip[2] - tip[0]
        return mon.outcome(np.linalg.norm(pull2 - 2 * pull) / np.linalg.norm(2 * pull), 1e-2,
                           "|d(2w) - 2 d(w)| / |2 d(w)|, d = tip shift by the handle",
                           f"tip shift {np.linalg.norm(pull):.3g} m, sag {scenes.tip_sag(free):.3g}")
    return Case(f"constraint weight {relative:g}", f"bar + tip handle of weight {relative:g} k v, raised 0.5, "
                f"{steps} steps", run)


def heavy_constraint_case(relative=1e12, steps=300):
    def run(quick):
        sim, pins = handle_bar(relative, relative)
        mon = Monitor(sim, pins=pins)
        mon.step(steps)
        err = np.linalg.norm(pins.residuals(sim), axis=1).max()
        return mon.outcome(err, 1e-9, "worst constraint error (m)",
                           f"tip {sim.skin_points([scenes.BAR_TIP])[0].round(9)}")
    return Case(f"constraint weight {relative:g}", f"bar, 25 pins + tip handle raised 0.5, all of weight "
                f"{relative:g} k v, {steps} steps", run)


def yank_case(lengths=100.0, steps=900):
    """A free 4x4x4 lattice (0.3 m) held by one corner handle; the handle's target jumps 100 body lengths
    in one frame and stays there. Figure: the body has followed and recovered its rest shape."""
    def run(quick):
        g = lattice_graph()
        sim = lattice_sim(g, 1e5)
        size = float(np.ptp(g.centers, axis=0).max())
        target = (lengths * size, 0.0, 0.0)
        cid = sim.add_position_constraint((0.0, 0.0, 0.0))
        pins = Pins(sim, [(0.0, 0.0, 0.0)], [target], sim.default_weight())
        sim.set_constraint_target(cid, target)
        mon = Monitor(sim, pins=pins)
        mon.step(steps)
        miss = float(np.linalg.norm(pins.residuals(sim)))
        return mon.outcome(max(shape_error(sim), miss / size), 1e-6,
                           "max(shape error, handle miss / size)", f"handle miss {miss:.2g} m")
    return Case(f"yank {lengths:g} lengths", f"4x4x4 lattice, k = 100 rho, corner handle moved "
                f"{lengths:g} x 0.3 m in one frame, {steps} steps", run)


def jiggle_case(frames=10000, quick_frames=1500, settle=1000, period=50, amplitude=0.1):
    """The 100-particle, 261-edge body (a slab) pinned along one edge, its far corner jiggled up and down by
    a handle (0.1 m, every 50 frames) under gravity, k = 200 rho, damping 0.05. After `settle` frames the
    start has died out (measured: to 1e-12 m by frame 1000) and the motion is periodic: the state at the
    last frame must equal the state at frame `settle` (same phase), and the energy's range over the last
    500 frames the range over the 500 before `settle`: no creep of the shape, no energy pumped in or lost."""
    def run(quick):
        total = quick_frames if quick else frames
        g = scenes.body_graph(height=0.0)
        sim = opdeform.Simulation(g, 2e5, damping=0.05)
        rest = g.centers
        edge, corner = rest[:10], rest[-1]
        for p in edge:
            sim.add_position_constraint(p)
        handle = sim.add_position_constraint(corner)
        pins = Pins(sim, list(edge) + [corner], list(edge) + [corner], sim.default_weight())
        mon = Monitor(sim, pins=pins)
        energy, mid = np.empty(total), None

        def move(frame):
            pins.targets[-1] = corner + (0.0, 0.0, amplitude * math.sin(2 * math.pi * (frame + 1) / period))
            sim.set_constraint_target(handle, pins.targets[-1])

        for f in range(total):
            mon.step(1, move)
            energy[f] = mon.body.mechanical_energy(pins)
            if f + 1 == settle:
                mid = sim.positions
        size = float(np.ptp(rest, axis=0).max())
        creep = float(np.abs(sim.positions - mid).max()) / size
        before, last = energy[settle - 500:settle], energy[-500:]
        growth = abs(np.ptp(last) - np.ptp(before)) / np.ptp(before)
        out = mon.outcome(creep, 1e-6, f"max |x({total}) - x({settle})| / size",
                          f"energy range {np.ptp(last):.6g} J (at {settle}: {np.ptp(before):.6g}), growth {growth:.1g}")
        out.extra.append(("energy range growth", growth, 1e-6))
        return out
    return Case("jiggle 10,000 frames", f"100-particle body, corner handle +-{amplitude} m every {period} frames, "
                f"{frames} frames ({quick_frames} in the test)", run, slow=True)


def twist_case(angle=math.pi, steps=600):
    """Fig. 2's bar (25 pins, a tip handle and three direction constraints on the end frame), its end yanked
    in one frame to a half turn about the bar and moved by (-0.3, 0, 0.5). At the start two of the end's axes
    point exactly away from their targets, a stationary point of the direction terms the iteration has to
    leave. Direction constraints: only the global steps are held to the allowance (see the module's doc).
    Figure: the largest distance of a skinned end axis from its target direction at the end."""
    def run(quick):
        tb = scenes.TwistedBar(damping=0.05)
        offset = (-0.3, 0.0, 0.5)
        tb.pose(angle, offset)
        sim = tb.sim
        face = list(scenes.end_face_points(0.0))
        tip = np.add(scenes.BAR_TIP, offset)
        pins = Pins(sim, face + [scenes.BAR_TIP], face + [tip], sim.default_weight())
        mon = Monitor(sim, directions=True, pins=pins)
        mon.step(steps)
        idx, w = sim.graph.skin_weights(scenes.BAR_TIP, sim.params["skin_neighbors"])
        axes = np.einsum("j,jab->ab", w, sim.rotations[idx])  # columns: the skinned end axes
        axes /= np.linalg.norm(axes, axis=0)
        c, s = math.cos(angle), math.sin(angle)
        targets = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]]).T
        miss = float(np.linalg.norm(axes - targets, axis=0).max())
        return mon.outcome(miss, 1e-2, "max |end axis - target direction|",
                           f"tip {sim.skin_points([scenes.BAR_TIP])[0].round(5)} (target {tip})")
    return Case(f"twist {math.degrees(angle):.0f} deg", f"twisted bar, end turned {math.degrees(angle):.0f} deg "
                f"and moved in one frame, damping 0.05, {steps} steps", run)


CASES = [stiffness_case(r, it) for r in (1.0, 1e3, 1e6, 1e9, 1e12) for it in (1, 100)]
CASES += [static_case()]
CASES += [step_size_case(s) for s in (1000, 240, 60, 30, 5)]
CASES += [collapsed_case(), inverted_case()]
CASES += [make(r, s) for make in (collapsed_case, inverted_case) for r, s in ((1e12, 60), (1e9, 5))]
CASES += [shape_case(k, s) for s in SHAPES for k in ("chain", "sheet", "solid")]
CASES += [mass_ratio_case(k) for k in ("chain", "solid")]
CASES += [light_constraint_case(), heavy_constraint_case()]
CASES += [yank_case(), twist_case(), jiggle_case()]


def find(name):
    return next(c for c in CASES if c.name == name)
