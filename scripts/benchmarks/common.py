"""Timing helpers shared by the suites: medians of repeated runs, measured side by side."""

import os
import statistics
import time


def median_ms(fn, repeats=7, inner=1):
    """Median over `repeats` runs of fn() (called `inner` times per run), in milliseconds per call."""
    samples = []
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(inner):
            fn()
        samples.append((time.perf_counter() - t) * 1e3 / inner)
    return statistics.median(samples)


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


def print_aims(aims):
    """Prints issue 18's speed aims, each (what, measured, aim, met), with the load average beside them."""
    load = os.getloadavg()[0]
    for what, measured, aim, met in aims:
        print(f"aim (issue 18): {what}: {measured} (aim {aim}): {'met' if met else 'NOT met'}; load average {load:.1f}")
