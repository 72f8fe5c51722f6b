"""Stability on stiff and extreme cases: one row per case of tests/stability_cases.py (the test suite's cases).

Columns: the case, its parameters, its stated result (a figure against a bound), whether the case passed
(finite, no rise of the objective inside a step beyond round-off, the figure within its bound), the worst rise
as a fraction of the round-off allowance, ms per step (mean CPU time over the case's steps, energy trace
on: processor time only, as the case measures it) and the whole case's wall and processor seconds.
Runs the 10,000-frame jiggle in full (the test runs 1,500). Options: --quick (the test's lengths),
--markdown (also print the table as Markdown, as in docs/stability.md), --only TEXT (cases whose name contains TEXT). Writes
out/bench/stability/stability.csv.
"""

import csv
import os
import sys
import time

from .common import out_dir, table

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tests"))

import stability_cases  # noqa: E402  (tests/ on the path first)


def rows(quick=False, only=None):
    for case in stability_cases.CASES:
        if only and only not in case.name:
            continue
        t, c = time.perf_counter(), time.process_time()
        out = case.run(quick)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
        checks = [(out.what, out.figure, out.bound)] + list(out.extra)
        yield {"case": case.name, "parameters": case.params,
               "result": "; ".join(f"{w} = {f:.3g} <= {b:g}" for w, f, b in checks),
               "stated result": "; ".join(w for w, _, _ in checks),
               "measured": "; ".join(f"{f:.3g}" for _, f, _ in checks),
               "bound": "; ".join(f"{b:g}" for _, _, b in checks),
               "pass": "pass" if out.passed else "FAIL", "rise": f"{max(out.rise, 0.0):.2g}",
               "ms/step": f"{out.ms:.3f}", "s": f"{seconds:.1f}", "cpu s": f"{cpu:.1f}", "notes": out.notes}


def run(args):
    quick = "--quick" in args
    only = args[args.index("--only") + 1] if "--only" in args else None
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    found = []
    for row in rows(quick, only):
        found.append(row)
        print(f"  {row['case']}: {row['pass']} ({row['s']} s)", flush=True)
    headers = ["case", "parameters", "result", "pass", "rise", "ms/step", "s", "cpu s"]
    table([[r[h] for h in headers] for r in found], headers)
    print("ms/step: the case's own mean processor time per step; s, cpu s: the whole case in wall and processor time")
    failed = [r["case"] for r in found if r["pass"] != "pass"]
    print(f"{len(found) - len(failed)} of {len(found)} cases pass" + (f"; failing: {', '.join(failed)}" if failed
                                                                       else ""))
    path = os.path.join(out_dir("stability"), "stability.csv")
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(found[0]) if found else ["case"])
        writer.writeheader()
        writer.writerows(found)
    print(f"wrote {path}")
    if "--markdown" in args:
        columns = ["case", "parameters", "stated result", "measured", "bound", "pass", "rise", "ms/step"]
        print("\n| " + " | ".join(columns) + " |\n|" + " --- |" * len(columns))
        for r in found:
            print("| " + " | ".join(r[h].replace("|", "\\|") for h in columns) + " |")
