"""Stiffness against the iteration count and the step size: settled tip sag of the Fig. 1 bar, ARAP vs shape matching.

Answers issue 5's "does its stiffness change with the iteration count": the bar of scenes.fig1_bar (held at
its x = 0 end face by 25 position constraints) is run until nothing moves (max speed < 1e-7 m/s) with
opdeform.Simulation (ARAP, k = scenes.BAR_STIFFNESS) and with opdeform.ShapeMatching (Müller and Chentanez
2011, stiffness 1), both with per-step velocity damping 0.1 (which does not move an equilibrium), for every
iteration count and step size. ms/step is the median of 5 x 50 steps at the settled state, one thread, in wall
and in processor time (cpu).
Writes out/bench/stiffness/stiffness.csv. Options: --quick (iterations 1, 5, 20 at h = 1/60 only).

`settled_sag(solver, iterations, dt)` is the reusable measurement (solver "arap" or "shape_matching").
"""

import csv
import os

from opdeform import scenes, shape_matching

from .common import median_times, out_dir, table

SOLVERS = ("arap", "shape_matching")
ITERATIONS = (1, 2, 5, 10, 20, 50)
DTS = (1 / 30, 1 / 60, 1 / 120)
DAMPING = 0.1


def make_bar(solver, iterations, dt, damping=DAMPING):
    """The Fig. 1 bar for either solver (the same graph, constraints and gravity)."""
    args = dict(iterations=iterations, dt=dt, damping=damping)
    if solver == "arap":
        return scenes.fig1_bar(**args)
    if solver == "shape_matching":
        return shape_matching.fig1_bar(**args)
    raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")


def settled_bar(solver, iterations, dt, damping=DAMPING):
    """(the settled bar, the steps it took to settle)."""
    bar = make_bar(solver, iterations, dt, damping)
    return bar, shape_matching.settle(bar, max_steps=200_000)


def settled_sag(solver, iterations, dt):
    """How far the tip of the Fig. 1 bar has dropped once the motion has died out (m)."""
    return scenes.tip_sag(settled_bar(solver, iterations, dt)[0])


def static_sag():
    """The ARAP static equilibrium (converged), the value ARAP's settled sag should equal at every setting."""
    bar = scenes.fig1_bar()
    bar.solve_static(10000)
    return scenes.tip_sag(bar)


def measure(solver, iterations, dt):
    bar, steps = settled_bar(solver, iterations, dt)
    wall, cpu = median_times(lambda: bar.step(), repeats=5, inner=50)
    return {"solver": solver, "iterations": iterations, "dt": dt, "sag": scenes.tip_sag(bar), "settle_steps": steps,
            "ms_per_step": wall, "cpu_ms_per_step": cpu}


def run(args):
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    quick = "--quick" in args
    dts = DTS[1:2] if quick else DTS
    iterations = (1, 5, 20) if quick else ITERATIONS
    reference = static_sag()
    results = {(r["solver"], r["dt"], r["iterations"]): r
               for r in (measure(s, k, dt) for s in SOLVERS for dt in dts for k in iterations)}
    rows = []
    for dt in dts:
        for k in iterations:
            a, s = results["arap", dt, k], results["shape_matching", dt, k]
            rows.append((f"1/{round(1 / dt)}", k, f"{a['sag']:.4f}", f"{100 * (a['sag'] / reference - 1):+.2f}",
                         f"{a['ms_per_step']:.4f}", f"{a['cpu_ms_per_step']:.4f}", f"{s['sag']:.4f}",
                         f"{s['sag'] / reference:.1f}x", f"{s['ms_per_step']:.4f}", f"{s['cpu_ms_per_step']:.4f}"))
    print(f"settled tip sag of the Fig. 1 bar (m); ARAP static equilibrium {reference:.4f} m")
    table(rows, ["dt", "iters", "ARAP sag", "vs static %", "ARAP ms/step", "cpu ms", "SM sag", "SM / static",
                 "SM ms/step", "cpu ms"])
    for solver in SOLVERS:
        sags = [r["sag"] for r in results.values() if r["solver"] == solver]
        print(f"{solver}: settled sag from {min(sags):.4f} to {max(sags):.4f} m (max/min {max(sags) / min(sags):.2f})")
    path = os.path.join(out_dir("stiffness"), "stiffness.csv")
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, ["solver", "dt", "iterations", "sag", "settle_steps", "ms_per_step",
                                    "cpu_ms_per_step"])
        writer.writeheader()
        for r in results.values():
            writer.writerow(r)
    print(f"wrote {path}")
