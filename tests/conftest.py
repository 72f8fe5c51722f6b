"""pytest set-up: the package comes from the meson build tree (scripts/test sets PYTHONPATH to
<build>/python); fail early with a clear message when it is missing."""

import importlib.util

if importlib.util.find_spec("opdeform") is None:
    raise RuntimeError("opdeform is not importable: run scripts/test, or scripts/build and set "
                       "PYTHONPATH=build/python")
