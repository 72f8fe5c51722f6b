"""Timing helpers shared by the suites: medians of repeated runs in wall and processor time, measured side by
side; the load average; a copy's memory bandwidth."""

import os
import statistics
import time


def median_times(fn, repeats=7, inner=1):
    """Medians over `repeats` runs of fn() (called `inner` times per run), in milliseconds per call: (wall time,
    processor time of every thread of the process)."""
    wall, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        for _ in range(inner):
            fn()
        wall.append((time.perf_counter() - t) * 1e3 / inner)
        cpu.append((time.process_time() - c) * 1e3 / inner)
    return statistics.median(wall), statistics.median(cpu)


def load():
    """The load average over 1, 5 and 15 minutes and, on Linux, the threads runnable right now / all threads."""
    try:
        with open("/proc/loadavg") as f:  # Linux: the 4th field, runnable / all threads right now
            running = f", {f.read().split()[3]} running/threads"
    except OSError:
        running = ""
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()) + running


def copy_bandwidth(threads, megabytes=512, repeats=9):
    """A large copy split over `threads` threads (numpy copies without the GIL), bytes read plus bytes written:
    (GB per second of wall time, GB per second of processor time of all threads), medians of `repeats`. The
    reference for a kernel on the same number of threads: its wall time against the first, its processor time
    against the second."""
    import threading

    import numpy as np

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
    wall_ms, cpu_ms = median_times(copy, repeats)
    return 2 * src.nbytes / wall_ms / 1e6, 2 * src.nbytes / cpu_ms / 1e6


def out_dir(*parts):
    path = os.path.join(os.path.dirname(__file__), "..", "..", "out", "bench", *parts)
    os.makedirs(path, exist_ok=True)
    return os.path.abspath(path)


def table(rows, headers):
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) for i, h in enumerate(headers)]
    line = "  ".join(str(h).ljust(w) for h, w in zip(headers, widths))
    print(line)
    print("-" * len(line))
    for r in rows:
        print("  ".join(str(c).ljust(w) for c, w in zip(r, widths)))


def blender_json(script, marker, data):
    """Runs ``script`` inside Debian's Blender (one thread, the built opdeform module) with ``--inside data``;
    the JSON it wrote to data, or None when no line starts with ``marker`` (the end of Blender's log printed)."""
    import json
    import re
    import subprocess
    import sys
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    module_dir = next((p for p in sys.path if os.path.isfile(os.path.join(p, "opdeform", "__init__.py"))), None)
    env = dict(os.environ, OPDEFORM_PYTHONPATH=os.path.abspath(module_dir), OMP_NUM_THREADS="1")
    env.pop("PYTHONPATH", None)
    if "BLENDER_USER_CONFIG" not in os.environ:  # fresh user folders: no preference or add-on of the machine
        import tempfile
        user = tempfile.mkdtemp(prefix="opdeform-bench-user-")
        env.update(BLENDER_USER_CONFIG=user, BLENDER_USER_SCRIPTS=user)
    cmd = [os.path.join(root, "scripts", "blender"), "-b", "--factory-startup", "-t", "1", "--python-exit-code",
           "1", "-P", script, "--", "--inside", data]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=1800)
    if not re.search(rf"^{marker}", proc.stdout, re.M):
        print(f"Blender failed\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
        return None
    with open(data) as f:
        return json.load(f)


def print_aims(aims, issue=18):
    """Prints an issue's speed aims, each (what, measured, aim, met), with the load average beside them."""
    load = os.getloadavg()[0]
    for what, measured, aim, met in aims:
        print(f"aim (issue {issue}): {what}: {measured} (aim {aim}): {'met' if met else 'NOT met'}; "
              f"load average {load:.1f}")
