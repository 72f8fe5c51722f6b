"""Skinning 1,000,000 vertices (m = 4, positions + normals, float32): processor time per frame on one thread
and on every thread, and a hash of the output (scripts/speed/side-by-side)."""
import os, sys, time, statistics
import numpy as np
import opdeform
from opdeform import meshes
N = 1_000_000
cache = os.path.join(os.environ.get("TMPDIR", "/tmp"), "opdeform_skin_mesh.npz")
if os.path.exists(cache):
    z = np.load(cache); v, nrm = z["v"], z["n"]
    base_v, base_t = meshes.creature()
    graph = opdeform.Graph.from_mesh(base_v, base_t, particles=100)
else:
    v, t = meshes.subdivide(*meshes.creature(138), levels=3)
    base_v, base_t = meshes.creature()
    graph = opdeform.Graph.from_mesh(base_v, base_t, particles=100)
    nrm = opdeform.Skin(graph, v, triangles=t).rest_normals[:N]
    v = np.ascontiguousarray(v[:N]); np.savez(cache, v=v, n=nrm)
sim = opdeform.Simulation(graph, 2e5)
sim.set_state(graph.centers + [0.0, 0.0, 0.3], np.tile(np.eye(3), (graph.n_particles, 1, 1)))
sim.set_floor(0.0, 0.5); sim.step(30)
P, R = sim.positions, sim.rotations
out, on = np.empty(3 * N, np.float32), np.empty(3 * N, np.float32)
mode = sys.argv[1] if len(sys.argv) > 1 else "both"
res = {}
for threads in (1, 0):
    skin = opdeform.Skin(graph, v, 4, rest_normals=nrm, threads=threads)
    skin.deform(P, R, out, on)
    cpu, wall = [], []
    for _ in range(int(os.environ.get("REPS", 15))):
        c, w = time.process_time(), time.perf_counter()
        skin.deform(P, R, out, on)
        cpu.append(time.process_time() - c); wall.append(time.perf_counter() - w)
    res[threads] = (1e3 * statistics.median(cpu), 1e3 * statistics.median(wall))
import hashlib
print(f"RESULT cpu1={res[1][0]:.3f} wall1={res[1][1]:.3f} cpuall={res[0][0]:.3f} wallall={res[0][1]:.3f} "
      f"hash={hashlib.md5(out.tobytes()+on.tobytes()).hexdigest()[:8]}")
