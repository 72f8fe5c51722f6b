"""Whether the local step's Gauss-Seidel sweep could update 4 particles at a time and still give the serial
sweep's result exactly (docs/speed.md, "One core"), on the graphs of Figs. 1-2 (bar), Fig. 4 (body) and the
10,000-particle beam; edges only (constraints would couple more particles).

Serial: particle k reads its neighbours' new rotations where j < k and old ones where j > k. Updated together
with an earlier particle i, k gives the serial result only if none of its neighbours in [i, k) is still to be
updated (k would read an old rotation where the serial sweep reads the new one, and that neighbour would then
read k's new rotation where the serial sweep gives it the old one) and none is in the batch. Greedy batches:
from the first particle not yet updated, up to 3 more within a window of W that qualify. Each schedule is checked
on a nonlinear toy sweep over the same graph (bit-identical to the serial one), and so is, as the contrast, the
sweep of 4 consecutive particles at a time."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from opdeform import scenes  # noqa: E402

from benchmarks.scale import beam  # noqa: E402


def neighbours(graph):
    nb = [set() for _ in range(graph.n_particles)]
    for a, b in graph.edges:
        nb[a].add(int(b))
        nb[b].add(int(a))
    return nb


def exact_batches(nb, window):
    n, done, out = len(nb), np.zeros(len(nb), bool), []
    for i in range(n):
        if done[i]:
            continue
        batch = [i]
        done[i] = True
        for k in range(i + 1, min(n, i + 1 + window)):
            if len(batch) == 4:
                break
            if not done[k] and all(j < i or j > k or (done[j] and j not in batch) for j in nb[k]):
                batch.append(k)
                done[k] = True
        out.append(batch)
    return out


def toy_sweep(nb, batches):
    """Each batch reads the current values, then writes: a nonlinear function of the neighbours, like a rotation."""
    v = np.random.default_rng(1).random(len(nb))
    for batch in batches:
        v[batch] = [np.sin(k + sum(v[j] * (j + 1) for j in sorted(nb[k]))) for k in batch]
    return v


for name, graph in (("bar", scenes.bar_graph()), ("fig4 body", scenes.body_graph()),
                    ("10k beam", beam((100, 10, 10)).graph)):
    nb = neighbours(graph)
    n = len(nb)
    serial = toy_sweep(nb, [[k] for k in range(n)])
    consecutive = toy_sweep(nb, [list(range(i, min(n, i + 4))) for i in range(0, n, 4)])
    print(f"{name}: {n} particles, {np.mean([len(s) for s in nb]):.2f} neighbours each; k+1 a neighbour of k for "
          f"{np.mean([k + 1 in nb[k] for k in range(n - 1)]):.0%}; 4 consecutive at a time: "
          f"{np.mean(consecutive != serial):.0%} of the toy sweep's values differ")
    for window in (4, 16, 64):
        batches = exact_batches(nb, window)
        sizes = np.array([len(b) for b in batches])
        same = np.array_equal(toy_sweep(nb, batches), serial)
        print(f"  window {window:2d}: mean batch {sizes.mean():.2f}, batches of 4 {np.mean(sizes == 4):.1%}, "
              f"of 1 {np.mean(sizes == 1):.1%}; toy sweep identical to the serial one: {same}")
