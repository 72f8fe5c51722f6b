"""Scale: ms/step against particle count (100 to 100,000; 10 iterations), one thread and all cores, the
share of time in the local step and the global solve, CHOLMOD's simplicial against supernodal path, and the
growth rate. Options: --max N (largest particle count, default 100000)."""

import math
import os
import statistics
import time

import numpy as np

import opdeform

from .common import table
from .error import lattice

SIZES = ((10, 5, 2), (10, 10, 10), (100, 10, 10), (250, 20, 20))  # 100, 1,000, 10,000 and 100,000 particles


def beam(dims):
    """A lattice beam pinned at its x = 0 face, sagging under gravity."""
    g = lattice(*dims)
    sim = opdeform.Simulation(g, 1e9, damping=0.01)
    face = g.centers[g.centers[:, 0] == 0.0]
    for p in face[:: max(1, len(face) // 50)]:
        sim.add_position_constraint(p)
    return sim


def measure(sim, steps):
    sim.step(2)  # factorization and warm-up
    before = sim.counters
    samples = []
    for _ in range(steps):
        t = time.perf_counter()
        sim.step()
        samples.append((time.perf_counter() - t) * 1e3)
    after = sim.counters
    total = sum(samples) / 1e3
    local = (after["local_seconds"] - before["local_seconds"]) / total
    glob = (after["global_seconds"] - before["global_seconds"]) / total
    return statistics.median(samples), local, glob


def run(args):
    largest = int(args[args.index("--max") + 1]) if "--max" in args else 100000
    cores = os.cpu_count() or 1
    rows, series = [], {}
    for dims in SIZES:
        n = dims[0] * dims[1] * dims[2]
        if n > largest:
            continue
        steps = max(3, min(50, int(2e5 / n)))
        for threads, factorization in ((1, "simplicial"), (1, "supernodal"), (0, "auto")):
            sim = beam(dims)
            sim.set_solver(threads=threads, factorization=factorization)
            ms, local, glob = measure(sim, steps)
            label = f"{'1 thread' if threads == 1 else f'{cores} threads'}, {factorization}"
            series.setdefault(label, []).append((n, ms))
            rows.append((n, sim.graph.n_edges, label, f"{ms:.3f}", f"{100 * local:.0f} %", f"{100 * glob:.0f} %"))
    table(rows, ["particles", "edges", "threads, CHOLMOD path", "ms/step", "local", "global"])
    print()
    for label, pts in series.items():
        if len(pts) >= 2:
            (n0, t0), (n1, t1) = pts[-2], pts[-1]
            print(f"growth ({label}), {n0} -> {n1} particles: ms/step ~ n^{math.log(t1 / t0) / math.log(n1 / n0):.2f}")
    ten_k = [ms for label, pts in series.items() for n, ms in pts if n == 10000]
    if ten_k:
        print(f"10,000 particles at 10 iterations: best {min(ten_k):.2f} ms/step (aim: under 16 ms)")
