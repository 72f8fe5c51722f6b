"""The benchmarks' own measuring (scripts/benchmarks, issue 26's "honest benchmarks"): the factorization timed by
itself in the call that makes it (was a difference of two steps, negative under load), processor time kept apart
from wall time, a copy's bandwidth in both, the load average. Correctness only: no speed is asserted here."""

import importlib
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))

from benchmarks import __main__ as dispatch  # noqa: E402  (scripts/ on the path first)
from benchmarks import calibration, common, scale  # noqa: E402


def test_factorization_timed_by_itself():
    for path in ("simplicial", "supernodal"):
        analyse, factor, cpu, later = scale.factor_ms((10, 5, 2), path)  # raises unless it factored once
        assert analyse > 0 and factor > 0 and cpu > 0 and later > 0, (path, analyse, factor, cpu, later)


def test_median_times_keeps_processor_time_apart():
    wall, cpu = common.median_times(lambda: time.sleep(0.02), repeats=3)
    assert wall >= 20.0 and cpu < 10.0, (wall, cpu)  # a sleep takes wall time, next to no processor time
    wall, cpu = common.median_times(lambda: sum(range(20000)), repeats=3, inner=5)
    assert wall > 0 and cpu > 0


def test_copy_bandwidth_in_wall_and_processor_time():
    wall, cpu = common.copy_bandwidth(2, megabytes=16, repeats=3)
    assert wall > 0 and cpu > 0


def test_load_gives_the_three_averages():
    words = common.load().split()
    assert words[:2] == ["load", "average"]
    assert all(float(x.rstrip(",")) >= 0 for x in words[2:5])


def test_part_drops_split_the_characters_ear_into_head_root_and_tip():
    """scripts/bench calibration --parts (docs/settings.md): at 50 particles the ear is one particle, and its root
    (above the head's middle) drops more than the head and less than its tip: 0.82, 0.92 and 1.27 mm; the bench's
    tip region drops 0.82 mm as the head's rigid motion carries it and 0.45 mm of its own, which add up to its
    drop (the bench's row, 0.24 % of the ear's length)."""
    head, root, tip, count, carried, own = calibration.part_drops("character_ear", 50)
    assert 0.0 < head < root < tip and count == 1, (head, root, tip, count)
    drop = 1e3 * calibration.droop("character_ear", 50)[0] * calibration.character_ear()[4]
    assert 0.0 < own < carried and abs(carried + own - drop) < 1e-9, (carried, own, drop)


def test_every_suite_listed_runs(capsys):
    """scripts/bench --help lists the suites that `scripts/bench all` runs; each must have a run (common.py, the
    shared helpers, was listed and `all` stopped at it with an AttributeError). In this process, not a child:
    the sanitized run's preloaded runtime does not reach a child's python cleanly."""
    assert dispatch.main(["--help"]) == 0
    listed = capsys.readouterr().out
    names = [line.split()[0] for line in listed.splitlines()[2:] if line.startswith("  ")]
    assert "core" in names and "common" not in names, names
    assert all(callable(getattr(importlib.import_module("benchmarks." + n), "run", None)) for n in names), names
