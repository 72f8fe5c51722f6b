"""csrc/base/platform.c is the one file of the C core (and of the binding) that calls an operating system's API:
threads, locks, the CPU count, fork hooks, the clock. Every other file includes only the C standard library's
headers (and CHOLMOD's, x86 intrinsics' where guarded), so that the core compiles unchanged for Linux, macOS
and Windows (scripts/package cross-builds all three)."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

SHIM = "csrc/base/platform.c"
STANDARD = {"assert.h", "ctype.h", "errno.h", "float.h", "inttypes.h", "limits.h", "math.h", "stdarg.h",
            "stdatomic.h", "stdbool.h", "stddef.h", "stdint.h", "stdio.h", "stdlib.h", "string.h"}
ALLOWED = {"cholmod.h", "cpuid.h", "immintrin.h", "Python.h"}  # the library; x86 intrinsics (guarded)
# Calls of a system API that needs none of those headers' names (would slip past the include check)
CALLS = re.compile(r"\b(pthread_\w+|sched_\w+|sysconf|sysctl\w*|clock_gettime|fork|Sleep|CreateThread|"
                   r"QueryPerformance\w+|GetProcessAffinityMask|GetActiveProcessorCount)\s*\(")


def c_files():
    for pattern in ("csrc/**/*.[ch]", "python/opdeform/*.[ch]", "tests/c/*.[ch]"):
        yield from ROOT.glob(pattern)


def test_only_the_shim_calls_the_system():
    found = {}
    for path in c_files():
        rel = path.relative_to(ROOT).as_posix()
        if rel in (SHIM, "csrc/base/platform.h"):
            continue
        text = path.read_text()
        code = re.sub(r"//[^\n]*|/\*.*?\*/", "", text, flags=re.S)
        headers = set(re.findall(r'#include <([^>]+)>', code)) - STANDARD - ALLOWED
        calls = set(CALLS.findall(code))
        if headers or calls:
            found[rel] = sorted(headers | calls)
    assert not found, found

