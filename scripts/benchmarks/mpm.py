"""Tumbling-particle MPM: particle-steps/s of a 3-D snow block on one core and all cores, side by side with
Taichi's MLS-MPM on the CPU (same particles, grid, material, dt and steps), and bytes per particle-step
against the memory bandwidth measured in the same run.

Options: --particles 100000,1000000 (cube sizes, rounded to a cube), --steps N (default: about 3e6
particle-steps per run), --no-taichi. Taichi is installed with pip on first use (bench only); when it
cannot be installed or imported the reason is printed instead of its columns.
"""

import argparse
import json
import os
import subprocess
import sys
import time

from .common import print_aims, table

HERE = os.path.dirname(os.path.abspath(__file__))
PARTICLE_BYTES = 256  # od_MpmParticle
BLOCK_BYTES = 64 * 4 * 8  # a 4³ block of (m v, m) doubles


def _env():
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (os.path.dirname(HERE), env.get("PYTHONPATH")) if p)
    return env


def _run(*args, timeout=900):
    """Runs benchmarks._mpm_runner in a fresh process; returns its JSON or raises RuntimeError."""
    cmd = [sys.executable, "-m", "benchmarks._mpm_runner"] + [str(a) for a in args]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=_env(), timeout=timeout)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError((proc.stderr or proc.stdout).strip().splitlines()[-1] if (proc.stderr or proc.stdout)
                           else f"exit code {proc.returncode}")
    return json.loads(lines[-1])


def _taichi_status():
    """None when taichi imports (after a pip install if needed), else the reason it cannot be used."""
    probe = [sys.executable, "-c", "import taichi"]
    if subprocess.run(probe, capture_output=True, env=_env()).returncode == 0:
        return None
    print("installing taichi with pip (benchmark only) ...", flush=True)
    pip = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "taichi"], capture_output=True, text=True)
    if pip.returncode != 0:
        tail = (pip.stderr or pip.stdout).strip().splitlines()
        return f"pip install taichi failed for Python {sys.version.split()[0]}: {tail[-1] if tail else pip.returncode}"
    imp = subprocess.run(probe, capture_output=True, text=True, env=_env())
    if imp.returncode != 0:
        return f"taichi installed but does not import: {imp.stderr.strip().splitlines()[-1]}"
    return None


def _bandwidth_gbs():
    """Memory bandwidth of a large copy (numpy, one thread): bytes read + written per second."""
    import numpy as np

    a = np.ones(64 * 2 ** 20 // 8 * 4)  # 256 MiB
    b = np.empty_like(a)
    best = 0.0
    for _ in range(5):
        t = time.perf_counter()
        np.copyto(b, a)
        best = max(best, 2 * a.nbytes / (time.perf_counter() - t))
    return best / 1e9


def _bytes_per_step(particles, blocks):
    """Traffic of one substep per particle, from the data layout: P2G reads the particle, G2P reads and
    writes it; the radix sort touches 8-byte keys 2 passes x 2 (read + write) plus the 4-byte order; the
    particles are reordered (read + write) every 16 substeps; the grid blocks are cleared, added into
    (read + write), updated (read + write) and read by G2P."""
    particle = PARTICLE_BYTES + 2 * PARTICLE_BYTES + 2 * 2 * 2 * 8 + 4 + 2 * PARTICLE_BYTES / 16
    grid = blocks * BLOCK_BYTES * (1 + 2 + 2 + 1) / particles
    return particle + grid


def _grid_for(per_axis):
    """Cells per axis so that the block (spacing dx/2) spans about 0.36 of the domain."""
    return 32 * -(-per_axis // 26)


def run(args):
    parser = argparse.ArgumentParser(prog="scripts/bench mpm")
    parser.add_argument("--particles", default="100000,1000000")
    parser.add_argument("--steps", type=int, default=0)
    parser.add_argument("--no-taichi", action="store_true")
    opts = parser.parse_args(args)
    cores = os.cpu_count() or 1
    taichi = "not requested (--no-taichi)" if opts.no_taichi else _taichi_status()
    bandwidth = _bandwidth_gbs()
    load = os.getloadavg()[0]
    print(f"machine: {cores} cores; copy bandwidth {bandwidth:.1f} GB/s (numpy, 1 thread, read + write); "
          f"load average {load:.1f} at the start (other work on the machine slows every column alike)")
    print("scene: snow block (seed's Table 2) falling at 1 m/s in [0,1]^3, 2 particles per cell per axis, "
          "gravity, dt = 2e-4 fixed, float64 (opdeform); taichi: mpm99 kernel in 3-D, dense grid\n")
    rows, aims = [], []
    for requested in (int(p) for p in opts.particles.split(",")):
        per_axis = round(requested ** (1 / 3))
        n_grid = _grid_for(per_axis)
        n = per_axis ** 3
        steps = opts.steps or max(5, int(3e6 / n))
        mine = {t: _run("opdeform", per_axis, n_grid, 2e-4, steps, t) for t in (1, cores)}
        rate = {t: n * steps / r["seconds"] / 1e6 for t, r in mine.items()}
        per_step = _bytes_per_step(n, mine[cores]["blocks"])
        row = [n, f"{n_grid}^3", steps, f"{rate[1]:.2f}", f"{rate[cores]:.2f}"]
        if taichi is None:
            theirs = {}
            for key, t, fp in (("f64 1", 1, "f64"), ("f64 all", cores, "f64"), ("f32 all", cores, "f32")):
                try:
                    r = _run("taichi", per_axis, n_grid, 2e-4, steps, t, fp)
                    theirs[key] = n * steps / r["seconds"] / 1e6
                except (RuntimeError, subprocess.TimeoutExpired) as exc:
                    print(f"taichi {key} failed: {exc}")
                    theirs[key] = float("nan")
            row += [f"{theirs['f64 1']:.2f}", f"{theirs['f64 all']:.2f}", f"{theirs['f32 all']:.2f}",
                    f"{rate[cores] / theirs['f64 all']:.1f}x", f"{rate[cores] / theirs['f32 all']:.1f}x"]
            ratio = rate[cores] / theirs["f32 all"]
            aims.append((f"{n:,} particles, {cores} threads, against Taichi f32", f"{ratio:.1f}x", ">= 3x", ratio >= 3))
        gbs = per_step * rate[cores] * 1e6 / 1e9
        row += [f"{per_step:.0f}", f"{gbs:.2f}", f"{100 * gbs / bandwidth:.0f}%"]
        rows.append(row)
    headers = ["particles", "grid", "steps", "ours 1 core", f"ours {cores} cores"]
    if taichi is None:
        headers += ["taichi f64 1", f"taichi f64 {cores}", f"taichi f32 {cores}", "ours/taichi f64",
                    "ours/taichi f32"]
    headers += ["bytes/p-step", "GB/s", "of bandwidth"]
    print("million particle-steps per second (one timed run each, after a warm-up substep)")
    table(rows, headers)
    print_aims(aims[:1])  # the aim is set on the ~100k-particle block
    if taichi is not None:
        print(f"\ntaichi: {taichi}")
