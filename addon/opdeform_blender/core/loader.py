"""Finds and imports the compiled ``opdeform`` package, and says clearly why when it cannot.

Search order:
1. ``$OPDEFORM_PYTHONPATH`` (a folder holding ``opdeform/``, e.g. ``<build>/python``): development and tests;
   when it is set, nothing else is tried;
2. the copy vendored inside the add-on (``<add-on>/vendor/opdeform``) by ``scripts/package``;
3. a plain ``import opdeform`` (installed into Blender's Python).

The result is cached; ``load(force=True)`` retries (the panel's "Retry" button).
"""

import importlib
import importlib.util
import os
import sys

ENV_VAR = "OPDEFORM_PYTHONPATH"
# The add-on speaks this version of the opdeform API (major, minor); another minor still loads.
API_VERSION = (0, 1)
# Names the add-on calls: a package without them is reported as mismatched, never as a traceback.
REQUIRED = ("Graph", "Simulation", "SolverError", "Graph.from_mesh", "Skin", "pin_vertices",
            "add_vertex_direction", "mesh.mesh_pieces")

_state = {"module": None, "error": None, "where": None, "tried": False}


def _import_from_folder(folder):
    init = os.path.join(folder, "opdeform", "__init__.py")
    if not os.path.isfile(init):
        raise ImportError(f"{ENV_VAR}={folder!r} holds no opdeform/__init__.py")
    loaded = sys.modules.get("opdeform")
    if loaded is not None and os.path.dirname(os.path.dirname(os.path.abspath(loaded.__file__))) == \
            os.path.abspath(folder):
        return loaded
    if folder not in sys.path:
        sys.path.insert(0, folder)
    for name in [n for n in sys.modules if n == "opdeform" or n.startswith("opdeform.")]:
        del sys.modules[name]
    return importlib.import_module("opdeform")


def _candidates(addon_package, addon_dir):
    folder = os.environ.get(ENV_VAR)
    if folder:  # explicit: the only place tried
        yield f"${ENV_VAR} ({folder})", lambda: _import_from_folder(folder)
        return
    vendored = os.path.join(addon_dir, "vendor", "opdeform", "__init__.py")
    if addon_package and os.path.isfile(vendored):
        yield "the add-on's vendored copy", lambda: importlib.import_module(addon_package + ".vendor.opdeform")
    yield "Blender's Python (import opdeform)", lambda: importlib.import_module("opdeform")


def check(module):
    """None when ``module`` is an opdeform this add-on can drive, else a sentence saying what is wrong."""
    version = getattr(module, "__version__", "?")
    try:
        parts = tuple(int(p) for p in str(version).split(".")[:2])
    except ValueError:
        parts = ()
    if parts[:1] != API_VERSION[:1] or parts < API_VERSION:
        return (f"opdeform {version} does not match this add-on (needs {API_VERSION[0]}.{API_VERSION[1]}.x or "
                f"a later {API_VERSION[0]}.x): rebuild it or install the matching add-on zip")
    missing = []
    for name in REQUIRED:
        obj = module
        for part in name.split("."):
            obj = getattr(obj, part, None)
        if obj is None:
            missing.append(name)
    if missing:
        return (f"opdeform {version} lacks {', '.join(missing)}: it is older than this add-on; rebuild it "
                f"(scripts/build) or install the matching add-on zip")
    return None


def load(addon_package=None, addon_dir=None, force=False):
    """(module or None, error sentence or None). Never raises."""
    if _state["tried"] and not force:
        return _state["module"], _state["error"]
    if addon_dir is None:
        addon_dir = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    if addon_package is None:
        addon_package = __package__.rpartition(".")[0] if __package__ else None
    errors = []
    module = None
    for where, importer in _candidates(addon_package, addon_dir):
        try:
            module = importer()
        except Exception as exc:  # ImportError, OSError from a missing libcholmod, a wrong platform, ...
            errors.append(f"{where}: {type(exc).__name__}: {exc}")
            continue
        problem = check(module)
        if problem is None:
            _state.update(module=module, error=None, where=where, tried=True)
            return module, None
        errors.append(f"{where}: {problem}")
        module = None
    message = ("The compiled opdeform module could not be loaded. Build it (scripts/build) and set "
               f"{ENV_VAR}=<build>/python, or install the add-on zip made by scripts/package. ")
    message += " | ".join(errors)
    _state.update(module=None, error=message, where=None, tried=True)
    return None, message


def status():
    """(loaded?, where or error) without trying again."""
    return _state["module"] is not None, _state["where"] or _state["error"] or "not tried yet"
