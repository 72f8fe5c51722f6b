"""What making the sweep's schedule costs (local_step.c's batches, docs/speed.md "One core"): on a 100,000-particle
chain (no batch forms: every leader scans its whole window), one thread, the processor time of a step that
rebuilds the partition (a constraint added) and of a plain step, medians of 3; their difference also holds the
refactorization, so compare it between builds (scripts/speed/side-by-side)."""
import statistics
import time

import numpy as np

import opdeform

n = 100000
centers = np.zeros((n, 3))
centers[:, 0] = np.arange(n) * 0.1
edges = np.stack([np.arange(n - 1), np.arange(1, n)], 1)
sim = opdeform.Simulation(opdeform.Graph(centers, np.full((n, 3), 0.05), edges), 1e6)
sim.set_solver(threads=1)
sim.step(2)
plain, rebuilt = [], []
for r in range(3):
    t = time.process_time()
    sim.step()
    plain.append(time.process_time() - t)
    sim.add_position_constraint(centers[r])
    t = time.process_time()
    sim.step()
    rebuilt.append(time.process_time() - t)
print(f"RESULT chain_plain_ms={statistics.median(plain) * 1e3:.1f} "
      f"chain_rebuilt_ms={statistics.median(rebuilt) * 1e3:.1f}")
