"""What each "leave it out" switch of the step costs and saves: ms/step of one scene without and with a feature.

Every row times the same scene twice, side by side in one run (the two alternate, 21 repeats of 100 calls,
5 for the 10,000-particle beam; medians of CPU time, the wall time beside; one thread): without the feature
and with it. Rows
whose feature is inert (a floor 1 km below the body, direction constraints of negligible weight, a weight
set again every frame) measure what the switch saves when the scene does not need the feature: their
with/without ratio is what a step would cost without the switch. The others measure what the feature costs
when it is used. The switches themselves are checked in tests/test_features.py. Option: --quick (3 repeats
of 20 calls)."""

import math
import os
import statistics

import numpy as np

import opdeform
from opdeform import meshes, scenes

from .common import median_times, table
from .scale import beam


def side_by_side(without, with_, repeats=15, inner=100):
    """Medians in ms per call of the two functions, timed alternately: (processor time of this process without,
    with; wall time without, with). Processor time is the measure (one thread): other work on a shared machine
    does not inflate it the way it inflates wall time."""
    samples = {fn: ([], []) for fn in (without, with_)}
    for fn in (without, with_):
        for _ in range(max(inner // 5, 1)):  # warm-up: factorizations, caches, a settled motion
            fn()
    for _ in range(repeats):
        for fn in (without, with_):
            wall, cpu = median_times(fn, 1, inner)
            samples[fn][0].append(cpu)
            samples[fn][1].append(wall)
    (cpu0, wall0), (cpu1, wall1) = ([statistics.median(x) for x in samples[fn]] for fn in (without, with_))
    return cpu0, cpu1, wall0, wall1


def twisted_bar(directions=True, direction_weight=None):
    """Fig. 2's bar animated by its clip; without directions only the tip's position constraint moves."""
    tb = scenes.TwistedBar()
    if not directions:
        for cid in tb.direction_ids:
            tb.sim.remove_constraint(cid)
        tb.direction_ids = []
    elif direction_weight is not None:
        for cid in tb.direction_ids:
            tb.sim.set_constraint_weight(cid, direction_weight)
    frame = [0]

    def step():
        u = min(frame[0] / 120.0, 1.0)
        tb.sim.set_constraint_target(tb.position_id, (scenes.BAR_LENGTH - 0.3 * u, 0.0, 0.5 * u))
        for cid, axis in zip(tb.direction_ids, ((1.0, 0.0, 0.0), (0.0, math.cos(math.pi * u), math.sin(math.pi * u)),
                                                 (0.0, -math.sin(math.pi * u), math.cos(math.pi * u)))):
            tb.sim.set_constraint_target(cid, axis)
        tb.sim.step()
        frame[0] = (frame[0] + 1) % 240
    return tb, step


def body(floor=None, trace=False):
    """Fig. 4's body (100 particles, 261 edges) falling; floor = (height, friction) or None."""
    sim = opdeform.Simulation(scenes.body_graph(), 2e5)
    if floor is not None:
        sim.set_floor(*floor)
    sim.trace_energy = trace
    return sim


def pinned_body():
    """The body held by position constraints at its first row of 10 particles."""
    sim = body()
    for p in sim.graph.centers[:10]:
        sim.add_position_constraint(p)
    return sim


def handle_moves(sim):
    """Two step functions: a handle at the last particle moving, and the same with its weight changed too."""
    point = sim.graph.centers[-1]
    w = sim.default_weight()
    tip = sim.add_position_constraint(point, weight=w)
    k = [0]

    def move():
        k[0] += 1
        sim.set_constraint_target(tip, point + (0.0, 0.0, 0.1 * math.sin(k[0] / 10)))
        sim.step()

    def reweigh():
        sim.set_constraint_weight(tip, w * (1.0 + 1e-9 * (k[0] % 2)))
        move()

    return move, reweigh


def goal_steps(graph, vertices, goals, fitted, carry=False):
    """Step functions of the creature on the floor; with goals, each step first sets goal frames of an
    animated copy of the mesh (a sway of 0.1 rad about z), fitted to its vertices each step when `fitted`
    (else fitted once: the solver's own cost); `carry`: the goals carry the rest (docs/goals.md)."""
    sim = opdeform.Simulation(graph, 2e5)
    sim.set_goals_carry_rest(carry)
    sim.set_floor(0.0, 0.5)
    fit = opdeform.GoalFit(graph, vertices)
    sways = [vertices @ np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0, 0, 1.0]]).T
             for a in 0.1 * np.sin(np.arange(20) / 3)]
    frames = [fit.fit(sway) for sway in sways]
    if goals:
        sim.set_goal_strength(0.5)
    k = [0]

    def step():
        k[0] = (k[0] + 1) % len(sways)
        if goals:
            sim.set_goals(*(fit.fit(sways[k[0]]) if fitted else frames[k[0]]))
        sim.step()

    return step


def rows(repeats, inner):
    out = []

    def row(switch, scene, kind, pair, scale=1):
        ms0, ms1, wall0, wall1 = side_by_side(*pair, repeats=repeats, inner=max(inner // scale, 1))
        out.append((switch, scene, kind, f"{ms0:.4f}", f"{ms1:.4f}", f"{ms1 / ms0:.2f}", f"{wall0:.4f}",
                    f"{wall1:.4f}"))

    # Direction constraints: the code runs only when the set has one.
    _, plain = twisted_bar(directions=False)
    tb, inert = twisted_bar(direction_weight=1e-30)
    row("direction constraints", "fig2 bar, tip moving", "saves: 3 of weight 1e-30", (plain, inert))
    _, used = twisted_bar()
    row("direction constraints", "fig2 bar, tip twisting", "costs: the 3 of Fig. 2", (plain, used))

    # Floor: tested only when set.
    free, far, near = body(), body((-1000.0, 0.5)), body((0.0, 0.5))
    row("floor", "fig4 body falling", "saves: floor 1 km below", (free.step, far.step))
    near.set_state(near.positions - [0.0, 0.0, 0.9], near.rotations)  # resting on the floor from the start
    row("floor", "fig4 body", "costs: resting on it, friction 0.5", (far.step, near.step))

    # Refactorization: a target move changes only the right side; a weight change refactors.
    for name, sim, scale in (("fig1 bar", scenes.fig1_bar(), 1), ("fig4 body, 10 pins", pinned_body(), 1),
                             ("10,000-particle beam", beam((100, 10, 10)), 20)):
        row("refactor only on change", f"{name} + handle moving", "saves: its weight changed every frame",
            handle_moves(sim), scale)

    # Inertia: a static pose has no prediction, inertia term or velocity update. Both from the static
    # equilibrium at rest, where a step stays put, so that the iterations do the same work.
    for name, sim in (("fig1 bar", scenes.fig1_bar()), ("fig4 body, 10 pins", pinned_body())):
        sim.solve_static(3000)
        row("inertia terms", f"{name} at rest, 10 iterations", "costs: step() against solve_static(10)",
            (lambda sim=sim: sim.solve_static(10), sim.step))

    # Energy trace: the objective is evaluated only when asked for.
    untraced, traced = body(), body(trace=True)
    row("energy trace", "fig4 body falling", "costs: trace_energy = True", (untraced.step, traced.step))

    # Goals: the creature following an animated copy of itself (a sway), goal frames fitted every step.
    v, t = meshes.subdivide(*meshes.creature(), levels=2)
    graph = opdeform.Graph.from_mesh(*meshes.creature(), particles=100)
    scene = f"creature, 100 particles, {len(v):,}-vertex goal mesh, floor"
    row("goals", scene, "costs: strength 0.5, new frames each step", (goal_steps(graph, v, False, False),
                                                                       goal_steps(graph, v, True, False)))
    row("goals", scene, "costs: the same, frames fitted each step", (goal_steps(graph, v, False, False),
                                                                      goal_steps(graph, v, True, True)))
    row("goals carrying the rest", scene, "costs: against goals alone, new frames each step",
        (goal_steps(graph, v, True, False), goal_steps(graph, v, True, False, carry=True)))

    # Normals: skinned only when an output for them is given.
    skin = opdeform.Skin(graph, v, triangles=t, threads=1)
    pos, rot = graph.centers + 0.01, np.tile(np.eye(3), (graph.n_particles, 1, 1))
    out32, nrm32 = np.empty(3 * len(v), np.float32), np.empty(3 * len(v), np.float32)
    row("normals", f"creature mesh, {len(v):,} vertices, 1 thread", "costs: normals_out given",
        (lambda: skin.deform(pos, rot, out32), lambda: skin.deform(pos, rot, out32, nrm32)))
    return out


def run(args):
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    quick = "--quick" in args
    found = rows(3 if quick else 21, 20 if quick else 100)
    table(found, ["switch", "scene", "with = ", "ms without", "ms with", "with/without", "wall ms without",
                  "wall ms with"])
    print("ms: processor time, the measure (one thread); wall ms: the same calls' wall time, which other work on "
          "the machine stretches")
