"""Soak: 10,000 frames of a jiggling body with moving handles and skinning; memory, energy and creep checks."""

import argparse
import json
import os
import sys

from .common import out_dir, table


def run(args):
    p = argparse.ArgumentParser(prog="scripts/bench soak")
    p.add_argument("steps", nargs="?", type=int, default=10000)
    opts = p.parse_args(args)
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tests"))
    import soak_scene

    def report(step, trace):
        if len(trace["step"]) % 5 == 0:
            print(f"  step {step:6d}  core allocations {trace['allocations'][-1]}  rss {trace['rss'][-1] / 2**20:.1f} MiB"
                  f"  kinetic {trace['kinetic'][-1]:.3g} J", flush=True)

    result = soak_scene.run(opts.steps, report=report)
    bad = soak_scene.failures(result)
    rows = [(k, f"{result[k]:.4g}" if isinstance(result[k], float) else result[k], soak_scene.LIMITS.get(k, ""))
            for k in ("steps", "seconds", "cpu_seconds", "ms_per_step", "cpu_ms_per_step", "particles", "vertices",
                      "allocations_after_warmup", "rss_growth", "kinetic_max_first_half", "kinetic_max_second_half",
                      "orthonormality", "creep_relative", "residual_speed")]
    table(rows, ["measure", "value", "limit"])
    print("seconds, ms_per_step: wall time of the frames; cpu_seconds, cpu_ms_per_step: processor time of the same")
    path = os.path.join(out_dir(), "soak.json")
    with open(path, "w") as f:
        json.dump({k: v for k, v in result.items()}, f, indent=1)
    print(f"wrote {path}")
    if bad:
        print("SOAK FAILED:\n  " + "\n  ".join(bad))
        raise SystemExit(1)
    print("soak passed")
