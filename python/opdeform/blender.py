"""The Blender path of a shot (docs/pipeline.md): a spec whose mesh is ``FILE.blend:OBJECT`` is baked by
``blender -b`` with the add-on (the object's opdeform settings, the spec's keys overriding them), and the same
outputs as a mesh shot are written: PC2, frames, report.

Blender runs with ``--factory-startup --disable-autoexec`` in a temporary work folder inside the output
folder: its own ``BLENDER_USER_CONFIG`` and ``BLENDER_USER_SCRIPTS`` (the add-on copied or unzipped into
``addons/``), its memory capped (``ulimit -v``: the spec's memory, or the cap this process already runs under
when that is lower, as on a farm: a limit is only ever lowered) and its time limited. ``blender_bake.py`` runs
inside it, bakes into the work folder and writes ``done.json`` last; only then are the outputs renamed into place, so a
crash, a timeout or a bad object leaves no file passed off as complete. Every failure is a ``BlenderError``
naming the shot.
"""

import json
import logging
import os
import shutil
import subprocess
import tempfile
import threading
import zipfile
from collections.abc import Callable, Mapping, Sequence
from types import ModuleType
from typing import Any

resource: ModuleType | None
try:
    import resource
except ImportError:  # Windows: no address-space limit to set
    resource = None

import numpy as np

from . import io

# a shot.Shot (imported by shot, below it in the package's layers: not named here)
Shot = Any
# place(shot, pc2 path, triangles, report rows): writes a bake's outputs (shot.bake gives it)
Place = Callable[[Shot, str, np.ndarray[Any, Any], list[Any]], object]
Progress = Callable[[int, int], object]

__all__ = ["BlenderError", "addon_source", "bake", "blender_command", "blender_env", "find_blender"]

log = logging.getLogger("opdeform.blender")
SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_bake.py")
PACKAGE_FOLDER = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON = "opdeform_blender"
LOG_TAIL = 30


class BlenderError(RuntimeError):
    """Blender could not bake or render a shot: the message names the shot and says why."""


def find_blender(executable: str | None = None) -> str:
    """The Blender to run: ``executable``, else $OPDEFORM_BLENDER, else ``blender`` on PATH."""
    name = executable or os.environ.get("OPDEFORM_BLENDER") or "blender"
    found = shutil.which(name)
    if found is None:
        raise BlenderError(f"Blender not found: {name!r} (set [blender] executable or $OPDEFORM_BLENDER)")
    return found


def addon_source(addon: str | None = None) -> str:
    """The add-on to install: ``addon`` (a folder or a zip of scripts/package), else $OPDEFORM_ADDON, else the
    repository's addon/opdeform_blender above this package (a checkout's build tree)."""
    if addon or os.environ.get("OPDEFORM_ADDON"):
        path = os.path.abspath(addon or os.environ["OPDEFORM_ADDON"])
        if not os.path.exists(path):
            raise BlenderError(f"no add-on at {path}")
        return path
    folder = PACKAGE_FOLDER
    while os.path.dirname(folder) != folder:
        candidate = os.path.join(folder, "addon", ADDON)
        if os.path.isfile(os.path.join(candidate, "__init__.py")):
            return candidate
        folder = os.path.dirname(folder)
    raise BlenderError("no Blender add-on found: set [blender] addon or $OPDEFORM_ADDON (a folder or a zip)")


def _install_addon(source: str, user: str) -> None:
    """Copies (a folder) or unzips (a zip) the add-on into ``user/addons``."""
    addons = os.path.join(user, "addons")
    if zipfile.is_zipfile(source):
        with zipfile.ZipFile(source) as z:
            z.extractall(addons)
    else:
        shutil.copytree(source, os.path.join(addons, ADDON), ignore=shutil.ignore_patterns("__pycache__"))
    if not os.path.isfile(os.path.join(addons, ADDON, "__init__.py")):
        raise BlenderError(f"{source} holds no {ADDON}/__init__.py")


def blender_env(work: str, addon: str | None = None) -> dict[str, str]:
    """Blender's environment: temporary user folders (``addon`` installed there); this opdeform
    ($OPDEFORM_PYTHONPATH) unless the add-on is a zip with its own; no Python paths of this interpreter
    (Blender has its own Python)."""
    user = os.path.join(work, "user")
    if addon:
        _install_addon(addon, user)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "OPDEFORM_PYTHONPATH")}
    # Blender's Python finds its prefix through python3.x on PATH: a venv or pyenv earlier on PATH misleads it
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                  if not any(s in p for s in (".pyenv", "/venv", "/.venv")))
    env.update(BLENDER_USER_SCRIPTS=user, BLENDER_USER_CONFIG=os.path.join(work, "config"))
    if not (addon and zipfile.is_zipfile(addon)):
        env["OPDEFORM_PYTHONPATH"] = PACKAGE_FOLDER
    return env


def memory_cap_kib(memory_gib: float) -> int | None:
    """Blender's ``ulimit -v`` in KiB: ``memory_gib``, or this process's own limit when that is lower (a farm's
    cap is kept: ``ulimit -v`` above it would fail and Blender would never start); None without limits (Windows)."""
    if resource is None:
        return None
    wanted = int(memory_gib * 2 ** 20)
    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    return wanted if soft == resource.RLIM_INFINITY else min(wanted, soft // 1024)


def blender_command(executable: str, blend: str | None, script: str, args: Sequence[str],
                    memory_gib: float) -> list[str]:
    """``blender -b`` on a file with a script, under ``ulimit -v`` of ``memory_gib`` or the lower cap already set."""
    command = [executable, "-b", "--factory-startup", "--disable-autoexec", *([blend] if blend else []),
               "--python-exit-code", "1", "-P", script, "--", *args]
    cap = memory_cap_kib(memory_gib)
    return command if cap is None else ["sh", "-c", 'ulimit -v "$0" && exec "$@"', str(cap), *command]


def run(command: Sequence[str], env: Mapping[str, str], timeout: float, what: str,
        on_line: Callable[[str], object] | None = None) -> str:
    """Runs Blender (``command``), its output to ``log`` lines; on_line(line) for each. BlenderError naming
    ``what`` when it does not end within ``timeout`` seconds or exits with an error. Returns the output."""
    lines: list[str] = []
    proc = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            errors="replace", start_new_session=True)

    def read() -> None:
        for line in proc.stdout or ():
            lines.append(line)
            if on_line:
                on_line(line)
    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, 9)
        proc.wait()
        raise BlenderError(f"{what}: Blender did not finish within {timeout:g} s (killed){_tail(lines)}") from None
    finally:
        reader.join(5)
    output = "".join(lines)
    log.info("%s: Blender output:\n%s", what, output)
    if proc.returncode != 0:
        raise BlenderError(f"{what}: Blender exited with status {proc.returncode}{_tail(lines)}")
    return output


def _tail(lines: Sequence[str]) -> str:
    errors = [line for line in lines if line.startswith("OPDEFORM_ERROR ")]
    if errors:
        return ": " + errors[-1][len("OPDEFORM_ERROR "):].strip()
    return "; the end of its output:\n" + "".join(lines[-LOG_TAIL:])


def _progress_lines(progress: Progress | None) -> Callable[[str], None]:
    """on_line for ``run``: the bake's ``OPDEFORM_FRAME done total`` lines to progress(done, total)."""
    def on_line(line: str) -> None:
        if progress and line.startswith("OPDEFORM_FRAME "):
            done, total = map(int, line.split()[1:3])
            progress(done, total)
    return on_line


def bake(shot: Shot, threads: int | None = None, progress: Progress | None = None,
         place: Place | None = None) -> list[Any]:
    """Bakes a .blend shot with Blender; place(shot, pc2, triangles, rows) writes the outputs from what Blender
    made (``shot.bake`` gives it) before the work folder goes. Returns the report rows (as ``shot.bake``)."""
    what = f"shot {shot.name} ({shot.spec})"
    settings = shot.section("blender")
    try:
        executable = find_blender(settings["executable"])
        addon = addon_source(settings["addon"] and os.path.join(os.path.dirname(shot.spec), settings["addon"]))
    except BlenderError as exc:
        raise BlenderError(f"{what}: {exc}") from None
    work = tempfile.mkdtemp(prefix=f".{shot.name}.blender.", dir=shot.section("output")["folder"])
    try:
        job = {"object": shot.blend[1], "work": work, "overrides": shot.overrides,
               "threads": shot.threads(threads or 1), "tolerance": shot.section("solver")["tolerance"]}
        job_path = os.path.join(work, "job.json")
        with open(job_path, "w") as f:
            json.dump(job, f)
        command = blender_command(executable, shot.blend[0], SCRIPT, [job_path], settings["memory"])
        run(command, blender_env(work, addon), settings["timeout"], what, _progress_lines(progress))
        return _finish(shot, work, what, place)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _finish(shot: Shot, work: str, what: str, place: Place | None) -> list[Any]:
    """Checks what Blender left in ``work`` (done.json written last, the PC2 complete) and places it."""
    done = os.path.join(work, "done.json")
    if not os.path.isfile(done):
        raise BlenderError(f"{what}: Blender ended without finishing the bake (no done.json)")
    with open(done) as f:
        result = json.load(f)
    expected = shot.last - shot.first + 1
    count = io.pc2_header(result["pc2"])[3]
    if count != expected:
        raise BlenderError(f"{what}: the bake holds {count} frames, the shot has {expected}")
    if place is not None:
        place(shot, result["pc2"], np.load(os.path.join(work, "triangles.npy")), result["rows"])
    return result["rows"]
