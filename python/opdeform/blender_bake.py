"""Runs inside Blender for ``opdeform.blender.bake`` (not imported by the package):

    blender -b --factory-startup --disable-autoexec FILE.blend --python-exit-code 1 -P blender_bake.py -- JOB

JOB (JSON): ``object``, ``work`` (the folder to bake into), ``overrides`` (spec keys, e.g. "graph.particles",
over the object's opdeform settings), ``threads``, ``tolerance``. Enables the add-on (installed in
$BLENDER_USER_SCRIPTS), bakes the object with its Bake code (``runtime.BakeJob``, what the Bake button runs),
prints ``OPDEFORM_FRAME done total`` after each frame and writes the report rows, the triangles and, last,
``done.json``. A problem prints ``OPDEFORM_ERROR message`` and exits with status 1.
"""

import importlib
import json
import os
import sys
import time
from types import ModuleType
from typing import Any, NoReturn

import addon_utils
import bpy
import numpy as np

ADDON = "opdeform_blender"
# spec key -> the object's opdeform setting of the same meaning
SETTINGS = {"substeps": "substeps", "graph.particles": "particles", "graph.mode": "graph_mode",
            "graph.neighbors": "neighbors", "material.stiffness": "stiffness", "material.density": "density",
            "material.damping": "damping", "solver.iterations": "iterations", "floor.height": "floor_height",
            "floor.friction": "floor_friction"}


def fail(message: str) -> NoReturn:
    print(f"OPDEFORM_ERROR {message}", flush=True)
    sys.exit(1)


def runtime() -> ModuleType:
    """The add-on's runtime module, the add-on enabled and its opdeform loaded."""
    if addon_utils.enable(ADDON, default_set=True, handle_error=lambda exc: print(exc)) is None:
        fail(f"the add-on {ADDON} did not enable (see the output above)")
    rt = importlib.import_module(ADDON + ".blender.runtime")
    try:
        rt.module()
    except rt.AddonError as exc:
        fail(str(exc))
    return rt


def apply_overrides(obj: Any, scene: Any, overrides: dict[str, Any]) -> None:
    """The spec's keys over the object's settings (and the scene's frame rate and gravity)."""
    s = obj.opdeform
    for key, value in overrides.items():
        if key in SETTINGS:
            setattr(s, SETTINGS[key], value)
    if "frames" in overrides:
        s.frame_start, s.frame_end = overrides["frames"]
    if "fps" in overrides:
        scene.render.fps = max(1, round(overrides["fps"]))
        scene.render.fps_base = scene.render.fps / overrides["fps"]
    if "material.gravity" in overrides:
        scene.use_gravity, scene.gravity = True, overrides["material.gravity"]
    if any(key.startswith("floor.") for key in overrides):
        s.use_floor = True


def bake(job: dict[str, Any]) -> None:
    rt = runtime()
    scene = bpy.context.scene
    obj = bpy.data.objects.get(job["object"])
    if obj is None:
        fail(f"{bpy.data.filepath} has no object {job['object']!r}")
    if not obj.opdeform.enabled:
        fail(f"{obj.name!r} in {bpy.data.filepath} does not have oriented particles enabled")
    apply_overrides(obj, scene, job["overrides"])
    obj.opdeform.cache_directory = job["work"]
    try:
        rt.check_object(obj)
        baking = rt.BakeJob(obj, scene)
        rows = run(rt, baking, job)
    except rt.AddonError as exc:
        fail(f"{obj.name!r}: {exc}")
    baking.finish()
    np.save(os.path.join(job["work"], "triangles.npy"), rt.triangles(obj.data).astype(np.int64))
    with open(os.path.join(job["work"], "done.json"), "w") as f:
        json.dump({"pc2": baking.path, "rows": rows}, f)


def run(rt: ModuleType, baking: Any, job: dict[str, Any]) -> list[dict[str, Any]]:
    """Bakes every frame; returns the report rows (opdeform.shot.report_row)."""
    shots = importlib.import_module(rt.module().__name__ + ".shot")
    settings = baking.obj.opdeform
    accelerator = job["overrides"].get("solver.accelerator", "none")
    baking.rt.engine.sim.set_solver(accelerator, threads=job["threads"])
    baking.rt.engine.sim.trace_energy = True
    rows = []
    while not baking.done:
        frame = baking.frame
        t0 = time.perf_counter()
        baking.step()
        engine = baking.rt.engine
        skin = engine.timing["skin"]
        rows.append(shots.report_row(frame, engine.sim, frame > baking.start, time.perf_counter() - t0 - skin,
                                       skin, settings.iterations, job["tolerance"]))
        print(f"OPDEFORM_FRAME {frame - baking.start + 1} {baking.total}", flush=True)
    return rows


if __name__ == "__main__":
    with open(sys.argv[sys.argv.index("--") + 1]) as f:
        bake(json.load(f))
