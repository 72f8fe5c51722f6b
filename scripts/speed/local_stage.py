"""The local step alone, one thread (scripts/speed/side-by-side): per scene, the median over ROUNDS samples of the
step counters' local_seconds and of the process's processor time, per step, and per particle update (10 sweeps a
step). Scenes: Fig. 1 bar, Fig. 2 twist, Fig. 4 body, the 1,000- and 10,000-particle beams of scripts/bench
threads. local_seconds is wall time: on a loaded machine, measure with a build whose od_LocalStep reads the
thread's processor clock (docs/speed.md, "One core")."""
import itertools
import os
import statistics
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from opdeform import scenes  # noqa: E402

from benchmarks.scale import beam  # noqa: E402


def twisted_bar():
    """Fig. 2's clip, looped: the sim and one frame's call."""
    twist, frames = scenes.TwistedBar(), itertools.count()

    def frame():
        twist.animate((next(frames) % 240) / 60.0)
        twist.sim.step()
    return twist.sim, frame


def cases():
    """(name, sim, one step, steps per sample)"""
    bar, body = scenes.fig1_bar(), scenes.falling_body()
    yield ("fig1", bar, bar.step, 200)
    yield ("fig2", *twisted_bar(), 200)
    yield ("fig4", body, body.step, 100)
    for dims, inner in (((10, 10, 10), 10), ((100, 10, 10), 2)):
        sim = beam(dims)
        sim.set_solver(threads=1)
        yield f"beam{sim.graph.n_particles}", sim, sim.step, inner


rounds = int(os.environ.get("ROUNDS", 9))
parts = []
for name, sim, step, inner in cases():
    for _ in range(3 * inner):  # warm-up: factorization, a settled motion
        step()
    local, cpu = [], []
    for _ in range(rounds):
        before, t = sim.counters["local_seconds"], time.process_time()
        for _ in range(inner):
            step()
        cpu.append((time.process_time() - t) / inner)
        local.append((sim.counters["local_seconds"] - before) / inner)
    us = statistics.median(local) * 1e6
    parts.append(f"{name}_local_us={us:.2f} {name}_update_ns={us * 1e3 / (10 * sim.graph.n_particles):.1f} "
                 f"{name}_step_cpu_us={statistics.median(cpu) * 1e6:.2f}")
print("RESULT " + " ".join(parts))
