"""Batch: shots per minute over a Dask LocalCluster at 1 and 2 workers against a plain loop of bakes.

Each shot is examples/tail.toml (48 frames, 30 particles, OBJ frames, report CSV and PNG) in its own output
folder. The plain loop bakes them one after the other in this process; the batch runs `opdeform.batch` on a
LocalCluster (worker processes, 1 thread each), timed from submission to the last result (the cluster's
start is printed apart). Overhead per shot = (batch time at 1 worker - loop time) / shots. Beside each wall
time, the processor time over the same span: this process's, and for the batch its workers' too (each
worker's process time, asked before and after).
"""

import os
import re
import time

from benchmarks.common import out_dir, table
from opdeform import batch
from opdeform import shot as shots

SHOTS = 8
EXAMPLE = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "tail.toml")


def _specs(folder):
    text = open(EXAMPLE).read()
    paths = []
    for k in range(SHOTS):
        path = os.path.join(folder, f"tail{k}.toml")
        with open(path, "w") as f:
            f.write(re.sub(r'folder = ".*"', f'folder = "out{k}"', text).replace('name = "tail"', f'name = "tail{k}"'))
        paths.append(path)
    return paths


def _loop(specs):
    """(wall s, processor s) of baking the shots one after the other here."""
    wall, cpu = time.perf_counter(), time.process_time()
    for spec in specs:
        shots.bake(shots.load(spec), threads=1, resume=False)
    return time.perf_counter() - wall, time.process_time() - cpu


def _batch(specs, workers):
    """(cluster start s, wall s, processor s of this process and the workers, seconds in bake) of the shots on a
    new LocalCluster of ``workers``."""
    t0 = time.perf_counter()
    with batch.connect(workers=workers) as client:
        started, cpu = time.perf_counter(), time.process_time()
        before = client.run(time.process_time)
        results = batch.gather(specs, batch.submit(client, specs))
        done = time.perf_counter()
        after = client.run(time.process_time)
        cpu = time.process_time() - cpu + sum(after[w] - before[w] for w in after)
        client.cluster.close()
    assert all(r.ok for r in results), [r.error for r in results if not r.ok]
    return started - t0, done - started, cpu, sum(r.seconds for r in results)


def run(args):
    print(f"machine: {os.cpu_count()} cores; {SHOTS} shots of examples/tail.toml")
    specs = _specs(out_dir("batch"))
    wall, cpu = _loop(specs)
    rows = [("plain loop", "-", f"{wall:.2f}", f"{cpu:.2f}", f"{60 * SHOTS / wall:.0f}", f"{wall / SHOTS:.3f}", "")]
    timings = {}
    for workers in (1, 2):
        start, took, cpu, in_shots = _batch(specs, workers)
        timings[workers] = took
        rows.append((f"dask, {workers} worker{'s' * (workers > 1)}", f"{start:.2f}", f"{took:.2f}", f"{cpu:.2f}",
                     f"{60 * SHOTS / took:.0f}", f"{took / SHOTS:.3f}", f"{in_shots / SHOTS:.3f}"))
    table(rows, ("run", "cluster start s", "wall s", "cpu s", "shots/min", "s per shot", "in bake s per shot"))
    print("cpu s: processor time over the wall span (the batch: this process and its workers)")
    print(f"overhead per shot at 1 worker: {(timings[1] - wall) / SHOTS * 1e3:.0f} ms; "
          f"speed-up 2 workers / 1: {timings[1] / timings[2]:.2f}x")
