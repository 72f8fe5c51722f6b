"""Python code run in a fresh interpreter, its float64 arrays read back: the SIMD tests choose OPDEFORM_NO_AVX2
before the module loads. The count goes first on stdout, not to stderr: under scripts/test-sanitize's preloaded
runtime LeakSanitizer writes its report to stderr at exit."""

import os
import subprocess
import sys

import numpy as np

WRITE = """
def write_out(count, arrays):
    import sys
    import numpy as np
    sys.stdout.buffer.write(np.int64(count).tobytes())
    for a in arrays:
        sys.stdout.buffer.write(np.ascontiguousarray(a, np.float64).tobytes())
"""


def run(code, **env):
    """(count, every float64 written) from `code`, which ends with write_out(count, arrays); `env` is added to
    the environment."""
    proc = subprocess.run([sys.executable, "-c", WRITE + code], env=dict(os.environ, **env), capture_output=True,
                          check=True, timeout=600)
    return int(np.frombuffer(proc.stdout[:8], np.int64)[0]), np.frombuffer(proc.stdout[8:])
