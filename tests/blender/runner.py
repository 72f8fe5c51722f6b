"""Runs one suite of add-on tests inside Blender, the same way in both hosts:

    blender -b --factory-startup --python-exit-code 1 -P tests/blender/runner.py -- SUITE [TEST ...]
    <python with the bpy module> tests/blender/runner.py SUITE [TEST ...]

SUITE is a module tests/blender/SUITE.py; each of its test_* functions runs on fresh factory settings with the
add-on enabled. One line per test is printed: ``OPDEFORM_TEST {"name": ..., "ok": ..., "seconds": ...,
"error": ...}``; the exit status is 1 when any test failed. The compiled module comes from
$OPDEFORM_PYTHONPATH (tests/test_addon*.py set it to <build>/python, like scripts/test's PYTHONPATH).
"""

import importlib
import json
import os
import sys
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def main(argv):
    import bpy  # noqa: F401  (inside Blender this is the host's module; else the bpy wheel)
    import helpers
    suite = importlib.import_module(argv[0])
    names = argv[1:] or [n for n in vars(suite) if n.startswith("test_") and callable(getattr(suite, n))]
    failed = 0
    for name in names:
        t = time.perf_counter()
        error = None
        try:
            helpers.fresh()
            getattr(suite, name)()
        except Exception:
            error = traceback.format_exc()
            failed += 1
        line = {"name": name, "ok": error is None, "seconds": round(time.perf_counter() - t, 3), "error": error,
                "host": helpers.host()}
        print("OPDEFORM_TEST " + json.dumps(line), flush=True)
    helpers.cleanup()
    return 1 if failed else 0


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    sys.exit(main(args))
