"""Benchmark suites for scripts/bench: each module NAME here has run(args) and a one-line __doc__."""
