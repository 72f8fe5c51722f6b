"""Headless regression renders of baked shots (``python -m opdeform render``, docs/pipeline.md).

Each shot's PC2 (baked before) is rendered at a few frames by ``blender -b`` (``blender_render.py``: Cycles on
the CPU, 160 x 120, 16 samples, seed 0, no denoiser; a .blend shot in its own file with its camera, a mesh
shot in a scene made for it) and compared with the references: the image (mean absolute difference, and
the share of pixels off by more than 0.1 in a channel) and the baked vertices at that frame (largest
difference, against a tolerance relative to the mesh's size). ``report.csv`` and ``report.md`` (a page with
the images) list every shot and frame. ``update`` writes the references instead.
"""

import csv
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
import numpy.typing as npt

from . import blender, io
from . import shot as shots

__all__ = ["IMAGE_FRACTION", "IMAGE_MEAN", "RenderRow", "VERTEX_TOLERANCE", "chosen_frames", "image_difference",
           "render", "render_shot", "write_report"]

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_render.py")
# An image passes when its mean absolute difference from the reference is at most IMAGE_MEAN (0..1 scale,
# over all RGB values) and at most IMAGE_FRACTION of its pixels differ by more than PIXEL in any channel.
IMAGE_MEAN = 0.01
IMAGE_FRACTION = 0.01
PIXEL = 0.1
# Baked vertices pass when max |difference| <= VERTEX_TOLERANCE x the first frame's bounding-box diagonal.
VERTEX_TOLERANCE = 1e-3


@dataclass
class RenderRow:
    """One rendered frame of a shot and its differences from the references (``ok`` when within tolerance;
    ``note`` says what went wrong otherwise)."""
    shot: str
    frame: int = 0
    image: str = ""
    reference: str = ""
    image_mean: float = float("nan")
    image_fraction: float = float("nan")
    vertex_max: float = float("nan")
    vertex_limit: float = float("nan")
    ok: bool = False
    note: str = ""


def chosen_frames(shot: shots.Shot, count: int) -> list[int]:
    """``count`` frames spread over the shot, the first and the last included."""
    return sorted({int(round(f)) for f in np.linspace(shot.first, shot.last, max(count, 1))})


def image_difference(a: npt.ArrayLike, b: npt.ArrayLike) -> tuple[float, float]:
    """(mean absolute difference, share of pixels off by more than PIXEL in a channel) of two RGB images."""
    a, b = np.asarray(a, np.float32)[..., :3], np.asarray(b, np.float32)[..., :3]
    if a.shape != b.shape:
        raise ValueError(f"image size {a.shape[:2]} differs from the reference's {b.shape[:2]}")
    diff = np.abs(a - b)
    return float(diff.mean()), float((diff.max(axis=2) > PIXEL).mean())


def _read_png(path: str) -> npt.NDArray[Any]:
    import matplotlib.image
    return matplotlib.image.imread(path)


def _blender_job(shot: shots.Shot, baked: npt.NDArray[Any], frames: list[int], out: str,
                 work: str) -> dict[str, Any]:
    """The job of blender_render.py for a shot."""
    job = {"pc2": shot.output("pc2"), "frames": frames, "out": out, "name": shot.name, "start": shot.first,
           "bounds": [baked.min(axis=(0, 1)).tolist(), baked.max(axis=(0, 1)).tolist()]}
    if shot.blend:
        return dict(job, object=shot.blend[1])
    mesh = os.path.join(work, "mesh.npz")
    np.savez(mesh, vertices=shot.vertices, triangles=shot.triangles)
    floor = shot.section("floor")
    return dict(job, mesh=mesh, floor=floor and floor["height"])


def _render_images(shot: shots.Shot, baked: npt.NDArray[Any], frames: list[int], out: str) -> list[str]:
    """Renders the frames with Blender; returns the PNG paths."""
    settings = shot.section("blender")
    what = f"shot {shot.name} ({shot.spec})"
    work = tempfile.mkdtemp(prefix=f".{shot.name}.render.", dir=out)
    try:
        job = os.path.join(work, "job.json")
        with open(job, "w") as f:
            json.dump(_blender_job(shot, baked, frames, out, work), f)
        try:
            executable = blender.find_blender(settings["executable"])
        except blender.BlenderError as exc:
            raise blender.BlenderError(f"{what}: {exc}") from None
        blend = shot.blend[0] if shot.blend else None
        command = blender.blender_command(executable, blend, SCRIPT, [job], settings["memory"])
        blender.run(command, blender.blender_env(work), settings["timeout"], what)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return [os.path.join(out, f"{shot.name}_{f:04d}.png") for f in frames]


def _compare(shot: shots.Shot, frame: int, vertices: npt.NDArray[Any], image: str, references: str, diagonal: float,
             update: bool) -> RenderRow:
    """The row of one rendered frame: image and vertex differences from the references (written first when
    ``update``)."""
    stem = os.path.join(references, f"{shot.name}_{frame:04d}")
    if update:
        os.makedirs(references, exist_ok=True)
        shutil.copyfile(image, stem + ".png")
        np.save(stem + ".npy", vertices)
    row = RenderRow(shot.name, frame, image, stem + ".png", vertex_limit=VERTEX_TOLERANCE * diagonal)
    if not (os.path.isfile(stem + ".png") and os.path.isfile(stem + ".npy")):
        row.note = "no reference (render --update writes them)"
        return row
    try:
        row.image_mean, row.image_fraction = image_difference(_read_png(image), _read_png(stem + ".png"))
    except ValueError as exc:
        row.note = str(exc)
        return row
    reference = np.load(stem + ".npy")
    row.vertex_max = float(np.abs(reference - vertices).max()) if reference.shape == vertices.shape else np.inf
    failed = [what for what, off in (("image", row.image_mean > IMAGE_MEAN or row.image_fraction > IMAGE_FRACTION),
                                     ("vertices", row.vertex_max > row.vertex_limit)) if off]
    row.ok, row.note = not failed, " and ".join(failed) + " beyond tolerance" if failed else ""
    return row


def render_shot(spec: io.FilePath, references: str, out: str, count: int = 3, update: bool = False) -> list[RenderRow]:
    """The RenderRows of one baked shot (``count`` frames); a shot that cannot be rendered is one row that
    says why."""
    try:
        shot = shots.load(spec)
        frames = chosen_frames(shot, count)
        if not os.path.isfile(shot.output("pc2")):
            raise ValueError(f"{shot.output('pc2')}: not baked (python -m opdeform bake {spec})")
        _, _, baked = io.read_pc2(shot.output("pc2"))
        diagonal = float(np.linalg.norm(np.ptp(baked[0], axis=0)))
        images = _render_images(shot, baked, frames, out)
        return [_compare(shot, f, baked[f - shot.first], image, references, diagonal, update)
                for f, image in zip(frames, images)]
    except (ValueError, OSError, blender.BlenderError) as exc:
        return [RenderRow(os.path.basename(os.fspath(spec)), note=str(exc))]


def render(specs: Iterable[io.FilePath], references: io.FilePath, out: io.FilePath, count: int = 3,
           update: bool = False, on_row: Callable[[RenderRow], object] | None = None) -> list[RenderRow]:
    """Renders and compares every baked shot; writes ``out``/report.csv and report.md; returns the rows.
    on_row(row) as each comes."""
    out = os.path.abspath(out)
    os.makedirs(out, exist_ok=True)
    rows = []
    for spec in specs:
        for row in render_shot(spec, os.path.abspath(references), out, count, update):
            rows.append(row)
            if on_row:
                on_row(row)
    write_report(rows, out)
    return rows


def write_report(rows: Sequence[RenderRow], out: str) -> None:
    """``report.csv`` (one row a frame) and ``report.md`` (the same with each image beside its reference)."""
    names = [f.name for f in fields(RenderRow)]
    with io.atomic_path(os.path.join(out, "report.csv")) as part, open(part, "w", newline="") as f:
        writer = csv.DictWriter(f, names)
        writer.writeheader()
        writer.writerows(asdict(r) for r in rows)
    lines = ["# Regression renders", "", f"{sum(r.ok for r in rows)} of {len(rows)} frames within tolerance "
             f"(image: mean <= {IMAGE_MEAN}, pixels off by > {PIXEL} <= {100 * IMAGE_FRACTION:g}%; vertices: "
             f"<= {VERTEX_TOLERANCE:g} x the mesh's diagonal).", "",
             "| shot | frame | render | reference | image mean | pixels off | vertices max (limit) | |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        image = f"![]({os.path.relpath(r.image, out)})" if r.image else ""
        reference = f"![]({os.path.relpath(r.reference, out)})" if os.path.isfile(r.reference or "") else ""
        lines.append(f"| {r.shot} | {r.frame} | {image} | {reference} | {r.image_mean:.5f} | "
                     f"{100 * r.image_fraction:.3f}% | {r.vertex_max:.3g} m ({r.vertex_limit:.3g}) | "
                     f"{'ok' if r.ok else 'FAIL ' + r.note} |")
    with io.atomic_path(os.path.join(out, "report.md")) as part, open(part, "w") as f:
        f.write("\n".join(lines) + "\n")
