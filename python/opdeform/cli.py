"""The opdeform command (``opdeform`` or ``python -m opdeform``): bake one shot, bake a batch over a Dask
cluster, summarise a bake's report, or render baked shots against references. HELP and EPILOG are its help,
in plain text; a subcommand that needs an optional package names the extra that installs it (EXTRAS).
Progress (frames done, rate, time left) goes to a terminal only: a farm's log stays quiet.
"""

import argparse
import os
import sys
import time
from collections.abc import Callable, Sequence
from typing import TextIO

from . import blender
from ._core import __version__
from . import shot as shots

__all__ = ["main"]

HELP = """Bake shots (TOML specs: a mesh, its material, pins, keyframed handles, goals, frames and outputs) to
point caches, mesh frames and a per-frame report; spread many over a Dask cluster; summarise a report;
render baked shots with Blender against reference images."""
EPILOG = """examples:
  opdeform bake examples/tail.toml
  opdeform report examples/tail.toml
  opdeform batch shots/*.toml --workers 2
  opdeform render shots/*.toml --references refs/

exit status: 0 when everything baked, 1 when a shot failed, 2 for bad arguments, a bad spec or a missing
optional package. Optional packages: pip install "opdeform[plot]" (matplotlib: report plots, render),
"opdeform[batch]" (Dask: batch)."""
EXTRAS = {"matplotlib": "plot", "dask": "batch", "distributed": "batch"}  # top-level module -> extra


def _duration(seconds: float) -> str:
    """'42 s', '3 min 05 s', '2 h 07 min'."""
    s = round(seconds)
    if s < 60:
        return f"{s} s"
    return f"{s // 60} min {s % 60:02d} s" if s < 3600 else f"{s // 3600} h {s % 3600 // 60:02d} min"


def _progress_bar(stream: TextIO) -> Callable[[int, int], None] | None:
    """progress(done, total) drawing a bar on a terminal; None elsewhere (a farm's log stays quiet)."""
    if not stream.isatty():
        return None
    start = time.perf_counter()

    def progress(done: int, total: int) -> None:
        width = 40
        filled = width * done // total
        rate = done / max(time.perf_counter() - start, 1e-9)
        left = f"{_duration((total - done) / rate)} left" if rate > 0 else "time left unknown"
        stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} frames, {rate:.1f} frames/s, "
                     f"{left}\033[K")
        stream.write("\n" if done == total else "")
        stream.flush()
    return progress


def bake(args: argparse.Namespace) -> int:
    shot = shots.load(args.spec)
    t0 = time.perf_counter()
    rows = shots.bake(shot, args.threads, _progress_bar(sys.stderr), resume=not args.restart)
    print(f"{shot.name}: {len(rows)} frames in {time.perf_counter() - t0:.2f} s -> {shot.output('pc2')}")
    return 0


def batch(args: argparse.Namespace) -> int:
    from . import batch as batches

    def line(result: batches.ShotResult) -> None:
        name = os.path.basename(result.spec)
        if result.ok:
            print(f"ok     {name}: {result.frames} frames in {result.seconds:.2f} s", flush=True)
        else:
            print(f"FAILED {name}: {result.error}", flush=True)
            print("".join(f"    {row}\n" for row in result.log.splitlines()[-20:]), end="", flush=True)

    results = batches.run(args.specs, args.scheduler, args.workers, args.timeout, on_result=line)
    failed = sum(not r.ok for r in results)
    print(f"{len(results) - failed} of {len(results)} shots baked")
    return 1 if failed else 0


def report(args: argparse.Namespace) -> int:
    path = args.bake
    if path.endswith(".toml"):
        path = shots.load(path).output("report")
    rows = shots.read_report(path)
    simulated = rows[1:] or rows
    ms = sorted(1e3 * r["step_seconds"] for r in simulated)
    over = [r["frame"] for r in rows if r["over_tolerance"]]
    worst = max(rows, key=lambda r: r["residual"])
    print(f"{path}: frames {rows[0]['frame']}-{rows[-1]['frame']}")
    print(f"solver: {sum(ms):.1f} ms in all, median {ms[len(ms) // 2]:.2f} ms a frame, slowest {ms[-1]:.2f} ms")
    print(f"residual: largest {worst['residual']:.3g} at frame {worst['frame']}; "
          f"{len(over)} frames over the tolerance{': ' + ', '.join(map(str, over[:20])) if over else ''}")
    print(f"fastest particle: {max(r['max_speed'] for r in rows):.3g} m/s")
    return 0


def render(args: argparse.Namespace) -> int:
    import matplotlib  # noqa: F401 (render compares images with it: a missing extra is named before Blender runs)

    from . import render as renders

    def line(row: renders.RenderRow) -> None:
        if row.frame:
            print(f"{'ok  ' if row.ok else 'FAIL'} {row.shot} frame {row.frame}: image mean {row.image_mean:.5f}, "
                  f"pixels off {100 * row.image_fraction:.3f}%, vertices {row.vertex_max:.3g} m "
                  f"(<= {row.vertex_limit:.3g}) {row.note}", flush=True)
        else:
            print(f"FAIL {row.shot}: {row.note}", flush=True)

    rows = renders.render(args.specs, args.references, args.out, args.frames, args.update, on_row=line)
    failed = sum(not r.ok for r in rows)
    print(f"{len(rows) - failed} of {len(rows)} frames within tolerance; {os.path.join(args.out, 'report.md')}")
    return 1 if failed else 0


def main(argv: Sequence[str] | None = None, prog: str = "opdeform") -> int:
    """Runs the command line ``argv`` (default sys.argv[1:]); returns the exit status."""
    parser = argparse.ArgumentParser(prog=prog, description=HELP, epilog=EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"opdeform {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    p = commands.add_parser("bake", help="bake one shot")
    p.add_argument("spec")
    p.add_argument("--threads", type=int, default=None, help="solver threads when the spec leaves them (default 1)")
    p.add_argument("--restart", action="store_true", help="ignore the shot's checkpoint")
    p.set_defaults(run=bake)
    p = commands.add_parser("batch", help="bake shots over a Dask cluster")
    p.add_argument("specs", nargs="+")
    p.add_argument("--scheduler", default=None, help="address of a running scheduler (default: a LocalCluster)")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    p.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the scheduler")
    p.set_defaults(run=batch)
    p = commands.add_parser("report", help="the per-frame error and time report of a bake")
    p.add_argument("bake", help="a spec or its report CSV")
    p.set_defaults(run=report)
    p = commands.add_parser("render", help="headless regression renders of baked shots against references")
    p.add_argument("specs", nargs="+")
    p.add_argument("--references", required=True, help="folder of reference images and vertices")
    p.add_argument("--out", default="render", help="folder of the renders and report.csv, report.md")
    p.add_argument("--frames", type=int, default=3, help="frames a shot, spread from first to last")
    p.add_argument("--update", action="store_true", help="write the references instead of comparing")
    p.set_defaults(run=render)
    args = parser.parse_args(argv)
    try:
        status: int = args.run(args)
        return status
    except shots.SpecError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as exc:
        extra = EXTRAS.get((exc.name or "").split(".")[0])
        if extra is None:
            raise
        print(f'error: {args.command} needs {exc.name}, which is not installed: pip install "opdeform[{extra}]"',
              file=sys.stderr)
        return 2
    except (ConnectionError, OSError, ValueError, blender.BlenderError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
