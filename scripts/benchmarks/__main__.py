"""Dispatch: python -m benchmarks [suite|report|all] [options]. The default suite is `core`; `report` runs
the error-against-time report with its plots, the stability table, the leave-it-out switches and the scale
series in one go. Every suite's output begins with the load average and ends with it again, beside the suite's
wall time and processor time (this process's threads and the child processes that ended: Blender, runners)."""

import importlib
import os
import pkgutil
import sys
import time

import benchmarks
from benchmarks.common import load


REPORT = ("error", "stability", "features", "scale")


def suites():
    """The suites: the package's modules but the private ones and common.py, the suites' shared helpers."""
    return sorted(m.name for m in pkgutil.iter_modules(benchmarks.__path__)
                  if not m.name.startswith("_") and m.name != "common")


def main(argv):
    names = suites()
    if argv and argv[0] in ("-h", "--help"):
        print("usage: scripts/bench [SUITE|report|all] [options]\nsuites:")
        for name in names:
            print(f"  {name:10s} {importlib.import_module('benchmarks.' + name).__doc__.strip().splitlines()[0]}")
        return 0
    if argv and argv[0].startswith("--"):
        # options of the core suite (e.g. --error) may be given without naming it
        flag_suite = {"--error": "error"}.get(argv[0])
        if flag_suite in names:
            argv = [flag_suite] + argv[1:]
    target = argv[0] if argv and not argv[0].startswith("-") else "core"
    rest = argv[1:] if argv and not argv[0].startswith("-") else argv
    for name in names if target == "all" else REPORT if target == "report" else [target]:
        if name not in names:
            print(f"unknown suite {name!r}; suites: {', '.join(names)}", file=sys.stderr)
            return 2
        print(f"== {name}; before: {load()}", flush=True)
        wall, cpu = time.perf_counter(), os.times()
        importlib.import_module("benchmarks." + name).run(rest)
        done = os.times()
        own = done.user + done.system - cpu.user - cpu.system
        children = max(done.children_user + done.children_system - cpu.children_user - cpu.children_system, 0.0)
        print(f"== {name}: {time.perf_counter() - wall:.1f} s wall, {own + children:.1f} s processor time (this "
              f"process {own:.1f}, child processes {children:.1f}); after: {load()}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
