"""Skinning 1,000,000 vertices (m = 4, or `--neighbors M`; positions and normals) against memory bandwidth; graph
building.

Skinning: ms per frame (median, wall and processor time) on all cores and on one, into float32 buffers laid
out for Blender's foreach_set, with the machine's memory bandwidth measured in the same run (a large copy,
bytes read plus written, on all threads and on one) and the fraction of it the skinning reaches: the least
bytes a frame must move (rest positions, indices, weights and rest normals read, positions and normals
written) over the copy's bandwidth on the same number of threads, divided by the time taken. Like with
like: wall time against the copy's wall-time bandwidth ("fraction, wall") and processor time of all
threads against the copy's processor-time bandwidth ("fraction, cpu"; other work on the machine stretches
wall times, not these). Graph building: seconds (median, wall and processor) for a 100k-triangle mesh into
1,000 particles, and the binding of the million vertices.
"""

import os

import numpy as np

import opdeform
from opdeform import meshes

from .common import copy_bandwidth, median_times, print_aims, table

VERTICES = 1_000_000
NEIGHBORS = 4


def _timed(fn, repeats):
    """Median wall seconds and median process CPU seconds (all threads) of fn()."""
    wall, cpu = median_times(fn, repeats)
    return wall / 1e3, cpu / 1e3


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
    m = int(args[args.index("--neighbors") + 1]) if "--neighbors" in args else NEIGHBORS
    cores = os.cpu_count()
    print(f"machine: {cores} cores; mesh: the creature subdivided, first {VERTICES:,} vertices; m = {m}")
    v, t = _million_vertex_mesh()
    base_v, base_t = meshes.creature()
    graph = opdeform.Graph.from_mesh(base_v, base_t, particles=100)
    normals = opdeform.Skin(graph, v, triangles=t).rest_normals[:VERTICES]
    v = np.ascontiguousarray(v[:VERTICES])
    bind = _timed(lambda: opdeform.Skin(graph, v, m, rest_normals=normals), 3)
    skins = {cores: opdeform.Skin(graph, v, m, rest_normals=normals),
             1: opdeform.Skin(graph, v, m, rest_normals=normals, threads=1)}
    positions, rotations = _falling_state(graph)
    out32, nrm32 = np.empty(3 * VERTICES, np.float32), np.empty(3 * VERTICES, np.float32)
    out64, nrm64 = np.empty((VERTICES, 3)), np.empty((VERTICES, 3))
    bandwidth = {cores: copy_bandwidth(cores), 1: copy_bandwidth(1)}  # (wall, cpu) GB/s on each thread count
    cases = [("positions + normals, float32", cores, out32, nrm32, 4),
             ("positions only, float32", cores, out32, None, 4),
             ("positions + normals, float64", cores, out64, nrm64, 8),
             ("positions + normals, float32", 1, out32, nrm32, 4)]
    rows, fractions = [], []
    for name, threads, out, nrm, size in cases:
        skin = skins[threads]
        skin.deform(positions, rotations, out, nrm)
        seconds, cpu = _timed(lambda: skin.deform(positions, rotations, out, nrm), 21)
        moved = frame_bytes(VERTICES, m, nrm is not None, size)
        wall_bound, cpu_bound = (moved / (gbs * 1e9) for gbs in bandwidth[threads])
        rows.append((name, f"{threads}", f"{seconds * 1e3:.2f}", f"{cpu * 1e3:.2f}", f"{moved / 1e6:.0f}",
                     f"{wall_bound * 1e3:.2f}", f"{cpu_bound * 1e3:.2f}", f"{wall_bound / seconds:.2f}",
                     f"{cpu_bound / cpu:.2f}"))
        fractions.append((wall_bound / seconds, cpu_bound / cpu))
    after = copy_bandwidth(cores)
    table(rows, ["skinning 1M vertices", "threads", "ms/frame", "cpu ms", "MB moved", "copy ms", "copy cpu ms",
                 "fraction, wall", "fraction, cpu"])
    print("ms/frame: wall time; cpu ms: processor time of all threads per frame. copy ms, copy cpu ms: the same "
          "bytes copied on the same number of threads, in wall and in processor time; fraction, wall = copy ms / "
          "ms/frame; fraction, cpu = copy cpu ms / cpu ms (which other work on the machine does not stretch)")
    print("memory bandwidth (a 512 MB copy, bytes read + written), wall / processor time: "
          + "; ".join(f"{t} thread{'s' * (t > 1)} {w:.1f} / {c:.1f} GB/s" for t, (w, c) in bandwidth.items())
          + f"; {cores} threads after the skinning {after[0]:.1f} / {after[1]:.1f} GB/s")
    print_aims([(f"1M vertices, positions + normals, float32, {cores} threads", f"{fractions[0][0]:.2f} of the copy "
                 f"bandwidth on {cores} threads, wall against wall ({rows[0][2]} ms; {fractions[0][1]:.2f} processor "
                 "time against processor time)", ">= 0.5", fractions[0][0] >= 0.5)])
    print(f"binding {VERTICES:,} vertices (grid search, all cores): {bind[0]:.3f} s wall, {bind[1]:.3f} s processor")

    big_v, big_t = meshes.subdivide(*meshes.creature(130))
    build = _timed(lambda: opdeform.Graph.from_mesh(big_v, big_t, particles=1000), 5)
    g = opdeform.Graph.from_mesh(big_v, big_t, particles=1000)
    print(f"graph building: {len(big_t):,} triangles into {g.n_particles} particles ({g.n_edges} edges): "
          f"{build[0]:.3f} s wall, {build[1]:.3f} s processor (medians of 5)")
