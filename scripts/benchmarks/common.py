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
