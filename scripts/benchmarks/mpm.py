"""Tumbling-particle MPM: particle-steps/s of a 3-D snow block on one core and all cores, side by side with
Taichi's MLS-MPM on the CPU (same particles, grid, material, dt and steps), and bytes per particle-step
against the memory bandwidth measured in the same run: a copy on as many threads as the all-core column, wall
time against wall time and processor time against processor time. The rates are per second of wall time; a
second table gives each column's processor time (every thread of its process) per particle-step.

Options: --particles 100000,1000000 (cube sizes, rounded to a cube), --steps N (default: about 3e6
particle-steps per run), --rounds N (default 3: every column run once a round, the columns interleaved, medians
of the rates and of each round's ratio to Taichi, so a load that comes and goes moves both sides), --no-taichi.
Taichi runs in the benchmark's own virtual environment, ~/.cache/opdeform/taichi-venv (made on first use, Taichi
installed there with pip from the Python package index; the system's site-packages are never touched); when
it cannot be installed or imported the reason is printed instead of its columns.
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys

from .common import copy_bandwidth, print_aims, table

HERE = os.path.dirname(os.path.abspath(__file__))
TAICHI_VENV = os.path.join(os.path.expanduser("~"), ".cache", "opdeform", "taichi-venv")
TAICHI_PYTHON = os.path.join(TAICHI_VENV, "bin", "python")
PARTICLE_BYTES = 256  # od_MpmParticle
BLOCK_BYTES = 64 * 4 * 8  # a 4³ block of (m v, m) doubles


def _env():
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (os.path.dirname(HERE), env.get("PYTHONPATH")) if p)
    return env


def _run(engine, *args, timeout=900):
    """Runs benchmarks._mpm_runner in a fresh process (Taichi's in its virtual environment); returns its JSON or
    raises RuntimeError."""
    python = TAICHI_PYTHON if engine == "taichi" else sys.executable
    cmd = [python, "-m", "benchmarks._mpm_runner", engine] + [str(a) for a in args]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=_env(), timeout=timeout)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError((proc.stderr or proc.stdout).strip().splitlines()[-1] if (proc.stderr or proc.stdout)
                           else f"exit code {proc.returncode}")
    return json.loads(lines[-1])


def _taichi_status():
    """None when taichi imports in its virtual environment (made, and taichi installed with pip, on first use),
    else the reason it cannot be used."""
    probe = [TAICHI_PYTHON, "-c", "import taichi"]
    if os.path.exists(TAICHI_PYTHON) and subprocess.run(probe, capture_output=True, env=_env()).returncode == 0:
        return None
    print(f"installing taichi with pip into {TAICHI_VENV} (benchmark only) ...", flush=True)
    steps = ([sys.executable, "-m", "venv", "--clear", TAICHI_VENV],
             [TAICHI_PYTHON, "-m", "pip", "install", "-q", "--disable-pip-version-check", "taichi"])
    for cmd in steps:
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            tail = (done.stderr or done.stdout).strip().splitlines()
            shutil.rmtree(TAICHI_VENV, ignore_errors=True)  # the next run tries again from nothing
            return (f"{' '.join(cmd[1:4])} failed for Python {sys.version.split()[0]}: "
                    f"{tail[-1] if tail else done.returncode}")
    imp = subprocess.run(probe, capture_output=True, text=True, env=_env())
    if imp.returncode != 0:
        return f"taichi installed in {TAICHI_VENV} but does not import: {imp.stderr.strip().splitlines()[-1]}"
    return None


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


def _round_ratios(runs, threads):
    """Taichi f32's seconds over ours on `threads` threads: the median of the rounds' ratios, and it as text with
    the range."""
    ratios = [b["seconds"] / a["seconds"] for a, b in zip(runs[("opdeform", threads)], runs[("taichi f32", threads)])]
    ratio = statistics.median(ratios)
    return ratio, f"{ratio:.1f}x ({min(ratios):.1f}-{max(ratios):.1f})"


def _interleaved(per_axis, n_grid, steps, cores, with_taichi, rounds):
    """Every column's runs, the columns interleaved round by round: {(solver, threads): [runner results]}."""
    columns = [("opdeform", 1, ()), ("opdeform", cores, ())]
    if with_taichi:
        columns += [("taichi f64", 1, ("f64",)), ("taichi f64", cores, ("f64",)), ("taichi f32", 1, ("f32",)),
                    ("taichi f32", cores, ("f32",))]
    runs = {(name, t): [] for name, t, _ in columns}
    for _ in range(rounds):
        for name, t, extra in columns:
            try:
                runs[name, t].append(_run(name.split()[0], per_axis, n_grid, 2e-4, steps, t, *extra))
            except (RuntimeError, subprocess.TimeoutExpired) as exc:
                print(f"{name} on {t} threads failed: {exc}")
                runs[name, t].append({"seconds": float("nan"), "cpu_seconds": float("nan"), "blocks": 0})
    return runs


def run(args):
    parser = argparse.ArgumentParser(prog="scripts/bench mpm")
    parser.add_argument("--particles", default="100000,1000000")
    parser.add_argument("--steps", type=int, default=0)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-taichi", action="store_true")
    opts = parser.parse_args(args)
    cores = os.cpu_count() or 1
    taichi = "not requested (--no-taichi)" if opts.no_taichi else _taichi_status()
    copy_wall, copy_cpu = copy_bandwidth(cores, 256)
    print(f"machine: {cores} cores; copy bandwidth on {cores} threads (numpy, read + write) {copy_wall:.1f} GB/s of "
          f"wall time, {copy_cpu:.1f} GB/s of processor time (other work on the machine slows every column alike)")
    print("scene: snow block (seed's Table 2) falling at 1 m/s in [0,1]^3, 2 particles per cell per axis, "
          "gravity, dt = 2e-4 fixed, float64 (opdeform); taichi: mpm99 kernel in 3-D, dense grid\n")
    rows, cpu_rows, aims, one_core, version = [], [], [], [], None
    for requested in (int(p) for p in opts.particles.split(",")):
        per_axis = round(requested ** (1 / 3))
        n_grid = _grid_for(per_axis)
        n = per_axis ** 3
        steps = opts.steps or max(5, int(3e6 / n))
        runs = _interleaved(per_axis, n_grid, steps, cores, taichi is None, max(1, opts.rounds))
        rate = {key: statistics.median(n * steps / r["seconds"] / 1e6 for r in rs) for key, rs in runs.items()}
        cpu_ns = {key: statistics.median(r["cpu_seconds"] / (n * steps) * 1e9 for r in rs) for key, rs in runs.items()}
        per_step = _bytes_per_step(n, runs[("opdeform", cores)][0]["blocks"])
        row = [n, f"{n_grid}^3", steps, f"{rate['opdeform', 1]:.2f}", f"{rate['opdeform', cores]:.2f}"]
        if taichi is None:
            ratio, text = _round_ratios(runs, cores)
            ratio1, text1 = _round_ratios(runs, 1)
            row += [f"{rate['taichi f64', 1]:.2f}", f"{rate['taichi f64', cores]:.2f}", f"{rate['taichi f32', 1]:.2f}",
                    f"{rate['taichi f32', cores]:.2f}", f"{rate['opdeform', cores] / rate['taichi f64', cores]:.1f}x",
                    text1, text]
            aims.append((f"{n:,} particles, {cores} threads, against Taichi f32", f"{ratio:.1f}x", ">= 3x", ratio >= 3))
            one_core.append((f"MPM snow, {n:,} particles, one core, against Taichi f32 on one core", f"{ratio1:.1f}x",
                             ">= 3x", ratio1 >= 3))
            version = next((r["version"] for r in runs[("taichi f32", cores)] if "version" in r), version)
        gbs = per_step * rate["opdeform", cores] * 1e6 / 1e9
        cpu_gbs = per_step / cpu_ns["opdeform", cores]
        row += [f"{per_step:.0f}", f"{gbs:.2f}", f"{100 * gbs / copy_wall:.0f}%", f"{100 * cpu_gbs / copy_cpu:.0f}%"]
        rows.append(row)
        cpu_rows.append([n, steps] + [f"{ns:.0f}" for ns in cpu_ns.values()])
    columns = ["ours 1 core", f"ours {cores} cores"]
    columns += ["taichi f64 1", f"taichi f64 {cores}", "taichi f32 1", f"taichi f32 {cores}"] if taichi is None else []
    headers = ["particles", "grid", "steps"] + columns + ([f"ours/taichi f64 {cores}", "ours/taichi f32 1",
                                                           f"ours/taichi f32 {cores}"] if taichi is None else [])
    print(f"million particle-steps per second of wall time (medians of {max(1, opts.rounds)} interleaved rounds, each "
          "run after a warm-up substep; ours/taichi f32: the median of each round's ratio, with its range)")
    table(rows, headers + ["bytes/p-step", "GB/s", "of copy, wall", "of copy, cpu"])
    print(f"GB/s: bytes/p-step at ours {cores} cores' rate; of copy, wall: that against the copy's wall-time "
          f"bandwidth on {cores} threads; of copy, cpu: bytes/p-step over ours {cores} cores' processor time per "
          "particle-step, against the copy's processor-time bandwidth\n")
    print("processor time per particle-step, ns (every thread of the run's process; medians of the rounds)")
    table(cpu_rows, ["particles", "steps"] + columns)
    print_aims(aims[:1])  # issue 18's aim is set on the ~100k-particle block
    print_aims(one_core, issue=26)  # issue 26's: one core, at 100k and 1M particles
    print(f"\ntaichi {version} in {TAICHI_VENV}" if taichi is None else f"\ntaichi: {taichi}")
