"""Scale: ms/step against particle count (100 to 100,000; 10 iterations) on one thread and on every core,
with the shares of the local step, the global solve and skinning (a surface mesh of ~10 vertices per
particle, deformed every step without normals), the growth rate, and the one-off cost of analysing and
factoring with CHOLMOD's simplicial and supernodal paths (the substitution is the same for both: cholesky.c
copies the factor). Step and skinning times are medians of wall time and of processor time (every thread of
the process); the shares come from the step's own local_seconds and global_seconds (wall). The factorization
is timed directly by the core's counters (analyze_seconds: the ordering; factor_seconds: the numeric
factorization and the copy of the factor for the substitutions; wall time), in the first step of a fresh beam,
beside the processor time of that whole first step and the wall time of a later step for scale. Writes out/bench/scale/scale.csv and scale.png
(ms/step against particles, log-log, with the share of each stage). Options: --max N (largest particle count,
default 100000)."""

import csv
import math
import os
import statistics
import time

import numpy as np

import opdeform
from opdeform import meshes

from .common import median_times, out_dir, print_aims, table
from .error import lattice

SIZES = ((10, 5, 2), (10, 10, 10), (100, 10, 10), (250, 20, 20))  # 100, 1,000, 10,000 and 100,000 particles
SPACING = 0.1


def beam(dims):
    """A lattice beam pinned at its x = 0 face, sagging under gravity."""
    g = lattice(*dims, spacing=SPACING)
    sim = opdeform.Simulation(g, 1e9, damping=0.01)
    face = g.centers[g.centers[:, 0] == 0.0]
    for p in face[:: max(1, len(face) // 50)]:
        sim.add_position_constraint(p)
    return sim


def beam_skin(sim, dims, threads):
    """A box surface around the beam with about 10 vertices per particle."""
    n = dims[0] * dims[1] * dims[2]
    segments = 2 * dims[0]
    v, t = meshes.bar(length=1.0, width=1.0, segments=segments, cross=max(2, math.ceil(10 * n / (4 * segments))))
    lo, hi = sim.graph.centers.min(0), sim.graph.centers.max(0)
    box = (v - v.min(0)) / np.ptp(v, 0)
    return opdeform.Skin(sim.graph, lo + box * (hi - lo), triangles=t, threads=threads)


def factor_ms(dims, factorization):
    """(analysis wall ms, factorization wall ms) from the core's counters in the first step of a fresh beam at 1
    iteration, that whole step's processor ms, and the wall ms of a later step (median of 3)."""
    sim = beam(dims)
    sim.set_solver(factorization=factorization)
    sim.set_params(iterations=1)
    cpu = time.process_time()
    sim.step()
    cpu = time.process_time() - cpu
    counted = sim.counters
    if (counted["analyses"], counted["factorizations"], counted["steps"]) != (1, 1, 1):
        raise RuntimeError(f"the timed step did not factor exactly once: {counted}")
    return counted["analyze_seconds"] * 1e3, counted["factor_seconds"] * 1e3, cpu * 1e3, median_times(sim.step, 3)[0]


def measure(sim, skin, steps):
    """Medians per step: (step wall ms, step cpu ms, skinning wall ms, skinning cpu ms), and the local step's,
    the global solve's and the skinning's shares of the wall time."""
    sim.step(2)  # factorization and warm-up
    out = np.empty((skin.n_vertices, 3), np.float32)
    before = sim.counters
    step_ms, skin_ms = [], []
    for _ in range(steps):
        t, c = time.perf_counter(), time.process_time()
        sim.step()
        t1, c1 = time.perf_counter(), time.process_time()
        skin.deform_sim(sim, out=out)
        step_ms.append(((t1 - t) * 1e3, (c1 - c) * 1e3))
        skin_ms.append(((time.perf_counter() - t1) * 1e3, (time.process_time() - c1) * 1e3))
    after = sim.counters
    total = sum(w for w, _ in step_ms + skin_ms) / 1e3
    local = (after["local_seconds"] - before["local_seconds"]) / total
    glob = (after["global_seconds"] - before["global_seconds"]) / total
    medians = [statistics.median(x[k] for x in samples) for samples in (step_ms, skin_ms) for k in (0, 1)]
    return (*medians, local, glob, sum(w for w, _ in skin_ms) / 1e3 / total)


def run(args):
    largest = int(args[args.index("--max") + 1]) if "--max" in args else 100000
    cores = os.cpu_count() or 1
    rows, factor_rows, series, shares = [], [], {}, []
    for dims in SIZES:
        n = dims[0] * dims[1] * dims[2]
        if n > largest:
            continue
        print(f"  {n} particles ...", flush=True)
        steps = max(3, min(50, int(2e5 / n)))
        for threads in (1, 0):
            sim = beam(dims)
            sim.set_solver(threads=threads)
            skin = beam_skin(sim, dims, 1 if threads == 1 else 0)
            ms, cpu, skin_ms, skin_cpu, local, glob, skin_share = measure(sim, skin, steps)
            label = "1 thread" if threads == 1 else f"{cores} threads"
            series.setdefault(label, []).append((n, ms))
            rows.append((n, sim.graph.n_edges, skin.n_vertices, label, f"{ms:.3f}", f"{cpu:.3f}", f"{skin_ms:.3f}",
                         f"{skin_cpu:.3f}",
                         f"{100 * local:.0f} %", f"{100 * glob:.0f} %", f"{100 * skin_share:.0f} %"))
            shares.append((n, label, local, glob, skin_share))
        for path in ("simplicial", "supernodal"):
            factor_rows.append((n, path, *(f"{ms:.2f}" for ms in factor_ms(dims, path))))
    table(rows, ["particles", "edges", "vertices", "threads", "ms/step", "cpu ms/step", "skin ms", "skin cpu ms",
                 "local", "global", "skinning"])
    print("ms: wall time, cpu ms: processor time of every thread (medians); local, global, skinning: shares of the "
          "wall time")
    print()
    table(factor_rows, ["particles", "factorization", "analyse ms", "factor ms", "first step cpu ms",
                        "a later step ms"])
    print("analyse, factor: wall time from the core's counters (analyze_seconds, factor_seconds); first step cpu: "
          "the processor time of the whole first step of a fresh beam at 1 iteration, which also holds two "
          "substitutions and a local step, as the later step (wall) does")
    print()
    for label, pts in series.items():
        for (n0, t0), (n1, t1) in zip(pts, pts[1:]):
            print(f"growth ({label}), {n0} -> {n1} particles: ms/step ~ n^{math.log(t1 / t0) / math.log(n1 / n0):.2f}")
    write(rows, series, shares)
    ten_k = {label: ms for label, pts in series.items() for n, ms in pts if n == 10000}
    if ten_k:
        aims = []
        for label, ms in ten_k.items():
            aim = 25 if label == "1 thread" else 16
            aims.append((f"10,000 particles, 10 iterations, {label}", f"{ms:.2f} ms/step", f"<= {aim} ms", ms <= aim))
        print_aims(aims)

def write(rows, series, shares):
    folder = out_dir("scale")
    with open(os.path.join(folder, "scale.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["particles", "edges", "vertices", "threads", "ms_per_step", "cpu_ms_per_step", "skin_ms",
                    "skin_cpu_ms", "local", "global", "skinning"])
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 3.8))
    for label, pts in series.items():
        a.loglog(*zip(*pts), marker="o", label=label)
    a.axhline(16.0, color="grey", ls=":", label="16 ms")
    a.set_xlabel("particles")
    a.set_ylabel("ms/step (10 iterations)")
    a.legend(fontsize=8)
    names = [f"{n:,}\n{label}" for n, label, *_ in shares]
    bottom = np.zeros(len(shares))
    for k, stage in enumerate(("local step", "global solve", "skinning")):
        part = np.array([x[2 + k] for x in shares]) * 100
        b.bar(names, part, bottom=bottom, label=stage)
        bottom += part
    b.set_ylabel("% of step + skinning")
    b.tick_params(axis="x", labelsize=6)
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "scale.png"), dpi=90)
    plt.close(fig)
    print(f"wrote {folder}/scale.csv and scale.png")
