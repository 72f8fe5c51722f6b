"""The 10,000-particle lattice beam of scripts/bench scale: processor and wall time per step; T threads
(1, or 0 for every core) (scripts/speed/side-by-side)."""
import os, sys, time
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from benchmarks.scale import beam
sim = beam((100, 10, 10)); sim.set_solver(threads=int(os.environ.get("T", 1)))
sim.step(2)
t = time.process_time(); w = time.perf_counter()
n = int(os.environ.get("N", 100))
for _ in range(n): sim.step()
print("RESULT beam_cpu_ms=%.2f wall_ms=%.2f" % ((time.process_time() - t) * 1e3 / n, (time.perf_counter() - w) * 1e3 / n))
