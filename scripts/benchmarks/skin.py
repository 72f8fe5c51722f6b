"""Skinning 1,000,000 vertices (m = 4, positions and normals) against memory bandwidth; graph building.

Skinning: ms per frame (median) on all cores and on one, into float32 buffers laid out for Blender's
foreach_set, with the machine's memory bandwidth measured in the same run (a large copy, bytes read plus
written; the better of all threads and one) and the fraction of it the skinning reaches: the least bytes a
frame must move (rest positions, indices, weights and rest normals read, positions and normals written)
over the bandwidth, divided by the time taken. Graph building: seconds (median) for a 100k-triangle mesh
into 1,000 particles, and the binding of the million vertices.
"""

import os
import statistics
import threading
import time

import numpy as np

import opdeform
from opdeform import meshes

from .common import print_aims, table

VERTICES = 1_000_000
NEIGHBORS = 4


def _median_s(fn, repeats):
    return _timed(fn, repeats)[0]


def _timed(fn, repeats):
    """Median wall seconds and median process CPU seconds (all threads) of fn()."""
    wall, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return statistics.median(wall), statistics.median(cpu)


def copy_bandwidth(threads, megabytes=512, repeats=9):
    """GB/s of a large copy split over `threads` threads (numpy copies without the GIL): bytes read plus
    bytes written per second, median of `repeats`."""
    src = np.ones(megabytes * 2**20 // 8)
    dst = np.empty_like(src)
    parts = np.array_split(np.arange(len(src)), threads)
    bounds = [(p[0], p[-1] + 1) for p in parts]

    def copy():
        workers = [threading.Thread(target=np.copyto, args=(dst[a:b], src[a:b])) for a, b in bounds[1:]]
        for w in workers:
            w.start()
        a, b = bounds[0]
        np.copyto(dst[a:b], src[a:b])
        for w in workers:
            w.join()

    copy()
    return 2 * src.nbytes / _median_s(copy, repeats) / 1e9


def frame_bytes(n_vertices, m, normals=True, out_bytes=4):
    """The least a frame moves: rest positions (f64), indices (i32), weights (f64), rest normals (f64) read;
    positions and normals written."""
    per_vertex = 24 + 4 * m + 8 * m + 3 * out_bytes + ((24 + 3 * out_bytes) if normals else 0)
    return n_vertices * per_vertex


def _million_vertex_mesh():
    v, t = meshes.subdivide(*meshes.creature(138), levels=3)
    return v, t


def _falling_state(graph, steps=30):
    sim = opdeform.Simulation(graph, 2e5)
    sim.set_state(graph.centers + [0.0, 0.0, 0.3], np.tile(np.eye(3), (graph.n_particles, 1, 1)))
    sim.set_floor(0.0, 0.5)
    sim.step(steps)
    return sim.positions, sim.rotations


def run(args):
    cores = os.cpu_count()
    print(f"machine: {cores} cores, load average {os.getloadavg()[0]:.1f}; mesh: the creature subdivided, first "
          f"{VERTICES:,} vertices; m = {NEIGHBORS}")
    v, t = _million_vertex_mesh()
    base_v, base_t = meshes.creature()
    graph = opdeform.Graph.from_mesh(base_v, base_t, particles=100)
    normals = opdeform.Skin(graph, v, triangles=t).rest_normals[:VERTICES]
    v = np.ascontiguousarray(v[:VERTICES])
    bind_s = _median_s(lambda: opdeform.Skin(graph, v, NEIGHBORS, rest_normals=normals), 3)
    skins = {"all": opdeform.Skin(graph, v, NEIGHBORS, rest_normals=normals),
             "one": opdeform.Skin(graph, v, NEIGHBORS, rest_normals=normals, threads=1)}
    positions, rotations = _falling_state(graph)
    out32, nrm32 = np.empty(3 * VERTICES, np.float32), np.empty(3 * VERTICES, np.float32)
    out64, nrm64 = np.empty((VERTICES, 3)), np.empty((VERTICES, 3))
    every_core, one_core = copy_bandwidth(cores), copy_bandwidth(1)
    bandwidth = max(every_core, one_core)  # the machine's bandwidth: the better of the two
    cases = [("positions + normals, float32", "all", out32, nrm32, 4),
             ("positions only, float32", "all", out32, None, 4),
             ("positions + normals, float64", "all", out64, nrm64, 8),
             ("positions + normals, float32", "one", out32, nrm32, 4)]
    rows, fractions = [], []
    for name, threads, out, nrm, size in cases:
        skin = skins[threads]
        skin.deform(positions, rotations, out, nrm)
        seconds, cpu = _timed(lambda: skin.deform(positions, rotations, out, nrm), 21)
        moved = frame_bytes(VERTICES, NEIGHBORS, nrm is not None, size)
        bound = moved / (bandwidth * 1e9)
        used = cores if threads == "all" else 1
        rows.append((name, f"{used}", f"{seconds * 1e3:.2f}", f"{cpu * 1e3:.2f}",
                     f"{moved / 1e6:.0f}", f"{bound * 1e3:.2f}", f"{bound / seconds:.2f}", f"{bound * used / cpu:.2f}"))
        fractions.append((bound / seconds, bound * used / cpu))
    after = copy_bandwidth(cores)
    table(rows, ["skinning 1M vertices", "threads", "ms/frame", "cpu ms", "MB moved", "bandwidth ms", "fraction",
                 "fraction (cpu)"])
    print("cpu ms: processor time of all threads per frame; wall time near it with several threads means the "
          "other cores were busy (load average above). fraction (cpu): the same with the processor time per "
          "thread (cpu ms / threads) in place of the wall time, which other work on the machine stretches")
    print(f"memory bandwidth (a 512 MB copy, bytes read + written): {every_core:.1f} GB/s on {cores} threads "
          f"({after:.1f} after the skinning), {one_core:.1f} GB/s on one; the fractions use {bandwidth:.1f} GB/s")
    print_aims([(f"1M vertices, positions + normals, float32, {cores} threads", f"{fractions[0][0]:.2f} of the copy "
                 f"bandwidth ({rows[0][2]} ms; {fractions[0][1]:.2f} by processor time per thread)", ">= 0.5",
                 fractions[0][0] >= 0.5)])
    print(f"binding {VERTICES:,} vertices (grid search, all cores): {bind_s:.3f} s")

    big_v, big_t = meshes.subdivide(*meshes.creature(130))
    build_s = _median_s(lambda: opdeform.Graph.from_mesh(big_v, big_t, particles=1000), 5)
    g = opdeform.Graph.from_mesh(big_v, big_t, particles=1000)
    print(f"graph building: {len(big_t):,} triangles into {g.n_particles} particles ({g.n_edges} edges): "
          f"{build_s:.3f} s (median of 5); load average {os.getloadavg()[0]:.1f}")
