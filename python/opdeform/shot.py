"""A shot: one mesh simulated over a frame range, described by a TOML file (docs/pipeline.md), and its bake.

``load(path)`` reads and checks a spec: every key known, every value of the right kind and range, the files
there, vertex indices in range, the output folder writable; a problem raises ``SpecError`` naming the spec,
the key and the problem, before anything runs. ``bake(shot)`` runs it the way the Blender add-on's engine does
(graph from the mesh, pins and handles as position and direction constraints, ``substeps`` solver steps per
frame, the first frame the rest shape) and writes the outputs, each complete or not at all; with
``checkpoint_every`` it saves the simulation's state every so many frames (arrays behind a checked header, never
a pickle) and a later bake resumes from there.
"""

import contextlib
import hashlib
import json
import logging
import os
import re
import stat
import string
import tempfile
import time
import tomllib
import urllib.parse
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal, NoReturn, overload

import numpy as np
import numpy.typing as npt

from . import io, meshes
from ._arguments import ArrayLike, Floats
from .goals import GoalFit, relative_deform
from .graph import MODES, Graph
from .mesh import Skin, add_vertex_direction, pin_vertices
from .simulation import Simulation

__all__ = ["Shot", "SpecError", "VERSION", "bake", "load", "read_report", "report_row"]

VERSION = 1
log = logging.getLogger("opdeform.shot")
REPORT_COLUMNS = ("frame", "step_seconds", "skin_seconds", "energy", "residual", "max_speed", "over_tolerance")
# A report row: REPORT_COLUMNS to numbers (frame and over_tolerance ints); a spec's checked table: key to value;
# a schema: key to (check, default); a check takes (where, value) and returns the value
Row = dict[str, Any]
Settings = dict[str, Any]
Check = Callable[[str, Any], Any]
Schema = dict[str, tuple[Check, Any]]


class SpecError(ValueError):
    """A shot description that cannot run: the message names the spec file, the key and the problem."""


# -- value checks: each takes (where, value) and returns the value or raises SpecError ------------------------
def _fail(where: str, problem: str) -> NoReturn:
    raise SpecError(f"{where}: {problem}")


def _number(where: str, value: Any, low: float | None = None, above: float | None = None,
            most: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        _fail(where, f"must be a number, got {value!r}")
    if (low is not None and value < low) or (above is not None and value <= above):
        _fail(where, f"must be {'>= ' + str(low) if low is not None else '> ' + str(above)}, got {value!r}")
    if most is not None and value > most:
        _fail(where, f"must be at most {most:g}, got {value!r}")
    return float(value)


def _positive(where: str, value: Any) -> float:
    return _number(where, value, above=0)


def _bounded(most: float) -> Check:
    """A check of a positive number of at most ``most``."""
    return lambda where, value: _number(where, value, above=0, most=most)


def _fraction(where: str, value: Any) -> float:
    value = _number(where, value, low=0)
    return value if value <= 1 else _fail(where, f"must be in [0, 1], got {value!r}")


def _nonnegative(where: str, value: Any) -> float:
    return _number(where, value, low=0)


def _finite(where: str, value: Any) -> float:
    return _number(where, value)


def _integer(where: str, value: Any, low: int | None = None, most: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or (low is not None and value < low):
        _fail(where, f"must be an integer{'' if low is None else ' >= ' + str(low)}, got {value!r}")
    if most is not None and value > most:
        _fail(where, f"must be at most {most:,}, got {value:,}")
    return value


def _count(where: str, value: Any) -> int:
    return _integer(where, value, 1)


def _counted(most: int) -> Check:
    """A check of a count (an integer >= 1) of at most ``most``."""
    return lambda where, value: _integer(where, value, 1, most)


def _natural(where: str, value: Any) -> int:
    return _integer(where, value, 0)


def _vector(where: str, value: Any) -> tuple[float, ...]:
    if not isinstance(value, list) or len(value) != 3:
        _fail(where, f"must be three numbers, got {value!r}")
    return tuple(_number(f"{where}[{k}]", x) for k, x in enumerate(value))


def _text(where: str, value: Any) -> str:
    if not isinstance(value, str) or not value or "\0" in value:
        _fail(where, f"must be a non-empty string without NUL, got {value!r}")
    return value


def _flag(where: str, value: Any) -> bool:
    return value if isinstance(value, bool) else _fail(where, f"must be true or false, got {value!r}")


def _mode(where: str, value: Any) -> str:
    return value if value in MODES else _fail(where, f"must be one of {list(MODES)}, got {value!r}")


ACCELERATORS = ("none", "anderson", "chebyshev", "auto")


def _accelerator(where: str, value: Any) -> str:
    return value if value in ACCELERATORS else _fail(where, f"must be one of {list(ACCELERATORS)}, got {value!r}")


def _frame_range(where: str, value: Any) -> tuple[int, ...]:
    if not (isinstance(value, list) and len(value) == 2 and all(type(v) is int for v in value)) or \
            value[1] <= value[0]:
        _fail(where, f"must be [first, last] integers with last > first, got {value!r}")
    if value[1] - value[0] >= MAX_FRAMES or max(map(abs, value)) > 2 ** 31 - 1:
        _fail(where, f"a shot has at most {MAX_FRAMES:,} frames numbered within 32 bits, got {value!r}")
    return tuple(value)


def _indices(where: str, value: Any) -> str | list[int]:
    if isinstance(value, str):  # a text file of indices (a vertex group written out), one or more a line
        return value
    if not isinstance(value, list) or not all(type(v) is int for v in value):
        _fail(where, f"must be a list of vertex indices or the name of a file of them, got {value!r}")
    return value


def _keys(where: str, value: Any) -> list[Settings]:
    if not isinstance(value, list) or not value:
        _fail(where, "must be a non-empty list of {frame, offset, rotate} tables")
    return [_table(f"{where}[{k}]", key, KEY_SCHEMA) for k, key in enumerate(value)]


# Upper bounds of a spec's values: past them a bake cannot run (memory, overflow) or would take days.
MAX_FRAMES = 1_000_000
MAX_SUBSTEPS = 10_000
MAX_PARTICLES = 1_000_000
MAX_ITERATIONS = 100_000
MAX_STIFFNESS = 1e15  # Pa; diamond is about 1.2e12
MAX_DENSITY = 1e6  # kg/m^3; osmium is 22,590
REQUIRED = object()
KEY_SCHEMA: Schema = {"frame": (_integer, REQUIRED), "offset": (_vector, (0.0, 0.0, 0.0)), "rotate": (_vector, (0.0, 0.0, 0.0))}
HANDLE_SCHEMA: Schema = {"vertex": (_natural, REQUIRED), "strength": (_positive, 1.0),
                 "rotation": (_flag, False), "keys": (_keys, REQUIRED)}
SCHEMA: dict[str, Schema] = {
    "": {"version": (_count, REQUIRED), "name": (_text, None), "mesh": (_text, REQUIRED),
         "frames": (_frame_range, REQUIRED), "fps": (_positive, 24.0), "substeps": (_counted(MAX_SUBSTEPS), 1)},
    "graph": {"particles": (_counted(MAX_PARTICLES), 100), "mode": (_mode, "auto"), "neighbors": (_count, 4)},
    "material": {"stiffness": (_bounded(MAX_STIFFNESS), REQUIRED), "density": (_bounded(MAX_DENSITY), 1000.0), "damping": (_fraction, 0.0),
                 "gravity": (_vector, (0.0, 0.0, -9.81))},
    "solver": {"iterations": (_counted(MAX_ITERATIONS), 10), "accelerator": (_accelerator, "none"), "threads": (_natural, 0),
               "tolerance": (_positive, None)},
    "pins": {"vertices": (_indices, REQUIRED), "strength": (_positive, 1.0)},
    "goals": {"animation": (_text, REQUIRED), "strength": (_fraction, REQUIRED), "neighbors": (_count, 16)},
    "floor": {"height": (_finite, 0.0), "friction": (_nonnegative, 0.0)},
    "output": {"folder": (_text, REQUIRED), "pc2": (_text, None), "frames": (_text, None), "report": (_text, None),
               "plot": (_text, None), "checkpoint_every": (_natural, 0)},
    "blender": {"executable": (_text, None), "addon": (_text, None), "timeout": (_positive, 3600.0),
                "memory": (_positive, 8.0)},
}
OPTIONAL_SECTIONS = ("pins", "goals", "floor")
# A .blend object brings its own pins, handles and goals (its opdeform settings); the spec's keys of these
# sections override the object's settings; BLEND_ONLY is for that path alone.
OVERRIDES = ("frames", "fps", "substeps", "graph", "material", "solver", "floor")
BLEND_ONLY = ("blender",)
NOT_BLEND = ("pins", "goals", "handles")


def _table(where: str, table: Any, schema: Schema, required: bool = True) -> Settings:
    """The table's values checked by the schema, defaults filled in; unknown keys refused, and missing ones
    unless not ``required`` (then None: a .blend object's setting)."""
    if not isinstance(table, dict):
        _fail(where, f"must be a table, got {table!r}")
    unknown = sorted(set(table) - set(schema))
    if unknown:
        _fail(f"{where}.{unknown[0]}" if where else unknown[0], f"unknown key (known: {', '.join(schema)})")
    out = {}
    for key, (check, default) in schema.items():
        name = f"{where}.{key}" if where else key
        if key in table:
            out[key] = check(name, table[key])
        elif default is REQUIRED and required:
            _fail(name, "missing")
        elif default is REQUIRED:
            out[key] = None
        else:
            out[key] = default
    return out


# -- the shot ----------------------------------------------------------------------------------------------
@dataclass
class Shot:
    """A checked shot description; ``spec`` is the file, paths are resolved, the mesh is read."""
    spec: str
    name: str
    settings: dict[str, Any]
    vertices: np.ndarray = field(repr=False)
    triangles: np.ndarray = field(repr=False)
    pins: np.ndarray = field(repr=False)
    animation: np.ndarray = field(repr=False)
    digest: str = ""
    blend: tuple[str, str] | None = None  # (file, object) of a .blend mesh, baked by Blender
    overrides: dict[str, Any] = field(default_factory=dict)  # what the spec sets of a .blend object's settings

    def section(self, name: str) -> Any:
        return self.settings[name]

    @property
    def first(self) -> int:
        return self.settings[""]["frames"][0]

    @property
    def last(self) -> int:
        return self.settings[""]["frames"][1]

    @overload
    def output(self, key: Literal["pc2", "report"]) -> str: ...

    @overload
    def output(self, key: str) -> str | None: ...

    def output(self, key: str) -> str | None:
        """The full path of an output (None when the spec asks for none; the spec always has pc2 and report)."""
        out = self.settings["output"]
        return None if out[key] is None else os.path.join(out["folder"], out[key])

    def threads(self, available: int) -> int:
        """The solver threads: the spec's, or (0 there) what the runner allows."""
        return self.settings["solver"]["threads"] or available

    @property
    def checkpoint(self) -> str:
        return os.path.join(self.settings["output"]["folder"], f".{self.name}.checkpoint")


def load(path: io.FilePath) -> Shot:
    """The checked ``Shot`` of a TOML spec; SpecError naming the key and the problem otherwise."""
    path = os.path.abspath(os.fspath(path))
    try:
        with open(path, "rb") as f:
            raw = f.read()
        data = tomllib.loads(raw.decode("utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise SpecError(f"{path}: cannot read the spec: {exc}") from None
    try:
        return _load(path, raw, data)
    except SpecError as exc:
        raise SpecError(f"{path}: {exc}") from None


def _load(path: str, raw: bytes, data: dict[str, Any]) -> Shot:
    top = {k: v for k, v in data.items() if k not in SCHEMA and k != "handles"}
    settings: dict[str, Any] = {"": _table("", top, SCHEMA[""])}
    if settings[""]["version"] != VERSION:
        _fail("version", f"this opdeform reads version {VERSION}, got {settings['']['version']}")
    folder = os.path.dirname(path)
    blend = _blend(folder, settings[""]["mesh"], data)
    for section, schema in SCHEMA.items():
        if section and (section in data or section not in OPTIONAL_SECTIONS):
            settings[section] = _table(section, data.get(section, {}), schema, required=not blend)
        elif section:
            settings[section] = None
    if blend:
        return _blend_shot(path, raw, data, settings, blend)
    handles = data.get("handles", [])
    if not isinstance(handles, list):
        _fail("handles", "must be an array of tables ([[handles]])")
    settings["handles"] = [_table(f"handles[{k}]", h, HANDLE_SCHEMA) for k, h in enumerate(handles)]
    vertices, triangles = _mesh(folder, settings[""]["mesh"])
    name = _outputs(path, settings)
    pins = _pins(folder, settings["pins"], len(vertices))
    for k, h in enumerate(settings["handles"]):
        _in_range(f"handles[{k}].vertex", [h["vertex"]], len(vertices))
    animation = _animation(folder, settings["goals"], len(vertices), settings[""]["frames"])
    digest = hashlib.sha256(raw + vertices.tobytes() + triangles.tobytes() + animation.tobytes()).hexdigest()
    return Shot(path, name, settings, vertices, triangles, pins, animation, digest)


def _outputs(path: str, settings: dict[str, Any]) -> str:
    """The shot's name; the output folder made absolute (and checked writable), the default file names; every
    output name inside the folder."""
    name = settings[""]["name"] or os.path.splitext(os.path.basename(path))[0]
    if os.path.basename(name) != name or name in (os.curdir, os.pardir) or (os.altsep and os.altsep in name):
        _fail("name" if settings[""]["name"] else "spec", f"must be a plain name (no folders) to name files inside "
                                                           f"the output folder, got {name!r}")
    out = settings["output"]
    out["pc2"] = out["pc2"] or f"{name}.pc2"
    out["report"] = out["report"] or f"{name}_report.csv"
    for key in ("pc2", "report", "plot"):
        if out[key]:
            _inside(f"output.{key}", out[key])
    if out["frames"]:
        first, last = settings[""]["frames"]
        for frame in (first, last):
            _inside("output.frames", _frame_names(out["frames"]).format(frame=frame, name=name))
    out["folder"] = _writable(os.path.normpath(os.path.join(os.path.dirname(path), out["folder"])))
    return name


def _inside(where: str, name: str) -> None:
    """Refuses a file name that is absolute or leaves the output folder once normalised."""
    norm = os.path.normpath(name)
    if os.path.isabs(name) or norm in (os.curdir, os.pardir) or norm.startswith(os.pardir + os.sep):
        _fail(where, f"must name a file inside the output folder, got {name!r}")


BLEND = ".blend:"


def _blend(folder: str, source: str, data: dict[str, Any]) -> tuple[str, str] | None:
    """(file, object) of a ``FILE.blend:OBJECT`` mesh (the file checked), else None; the sections that do not
    go with the mesh's kind refused."""
    if BLEND not in source:
        wrong = [k for k in BLEND_ONLY if k in data]
        if wrong:
            _fail(wrong[0], "only with a .blend mesh (mesh = \"FILE.blend:OBJECT\")")
        return None
    wrong = [k for k in NOT_BLEND if k in data]
    if wrong:
        _fail(wrong[0], "not with a .blend mesh: the object's own opdeform settings give them")
    file, _, obj = source.partition(BLEND)
    path = os.path.join(folder, file + ".blend")
    if not obj:
        _fail("mesh", f"names no object: {source!r} (FILE.blend:OBJECT)")
    if not os.path.isfile(path):
        _fail("mesh", f"no such file: {path}")
    return path, obj


def _blend_shot(path: str, raw: bytes, data: dict[str, Any], settings: dict[str, Any],
                blend: tuple[str, str]) -> Shot:
    """The Shot of a .blend object: no mesh read here (Blender reads it), the spec's overriding keys kept."""
    if settings["output"]["checkpoint_every"]:
        _fail("output.checkpoint_every", "not with a .blend mesh: Blender bakes the shot in one go")
    overrides = {k: settings[""][k] for k in OVERRIDES if k in SCHEMA[""] and k in data}
    overrides.update({f"{s}.{k}": settings[s][k] for s in OVERRIDES if s in SCHEMA and s in data for k in data[s]})
    name = _outputs(path, settings)
    empty = np.zeros((0, 3))
    with open(blend[0], "rb") as f:
        digest = hashlib.sha256(raw + f.read()).hexdigest()
    return Shot(path, name, settings, empty, empty.astype(np.int64), np.zeros(0, np.int64),
                np.zeros((0, 0, 3), np.float32), digest, blend, overrides)


BUILTIN = "builtin:"


def _mesh(folder: str, source: str) -> io.Mesh:
    """An OBJ or PLY file relative to the spec, or ``builtin:NAME`` of opdeform.meshes (bar, capsule, creature,
    sheet, strand)."""
    if source.startswith(BUILTIN):
        maker = source[len(BUILTIN):]
        if maker not in ("bar", "capsule", "creature", "sheet", "strand"):
            _fail("mesh", f"no built-in mesh {maker!r} (bar, capsule, creature, sheet, strand)")
        return getattr(meshes, maker)()
    path = os.path.join(folder, source)
    if not os.path.isfile(path):
        _fail("mesh", f"no such file: {path}")
    try:
        return io.read(path)
    except ValueError as exc:
        _fail("mesh", str(exc))


def _in_range(where: str, indices: Iterable[int], count: int) -> None:
    bad = [i for i in indices if not 0 <= i < count]
    if bad:
        _fail(where, f"vertex index {bad[0]} is out of range: the mesh has {count} vertices")


def _pins(folder: str, pins: Settings | None, count: int) -> npt.NDArray[np.int64]:
    if pins is None:
        return np.zeros(0, np.int64)
    indices = pins["vertices"]
    if isinstance(indices, str):
        path = os.path.join(folder, indices)
        try:
            with open(path) as f:
                indices = [int(x) for x in f.read().split()]
        except (OSError, ValueError) as exc:
            _fail("pins.vertices", f"cannot read vertex indices from {path}: {exc}")
    _in_range("pins.vertices", indices, count)
    return np.asarray(indices, np.int64)


def _animation(folder: str, goals: Settings | None, count: int, frames: Sequence[int]) -> npt.NDArray[np.float32]:
    """The goal animation's frames (one per shot frame from the first), from a PC2 file."""
    if goals is None:
        return np.zeros((0, count, 3), np.float32)
    path = os.path.join(folder, goals["animation"])
    if not os.path.isfile(path):
        _fail("goals.animation", f"no such file: {path}")
    try:
        _, _, samples = io.read_pc2(path)
    except ValueError as exc:
        _fail("goals.animation", str(exc))
    if samples.shape[1] != count:
        _fail("goals.animation", f"{path} has {samples.shape[1]} points, the mesh {count} vertices")
    if len(samples) < frames[1] - frames[0] + 1:
        _fail("goals.animation", f"{path} has {len(samples)} frames, the shot needs {frames[1] - frames[0] + 1}")
    return samples


MAX_FIELD_WIDTH = 32


def _frame_names(template: str) -> str:
    """The frames template checked: only {frame} and {name} fields of a width up to MAX_FIELD_WIDTH (checked
    before formatting: a width of 10^9 would build a gigabyte string), frames named apart, .obj or .ply."""
    try:
        fields = [(f, spec) for _, f, spec, _ in string.Formatter().parse(template)
                  if f is not None and spec is not None]  # a field always has a spec, maybe empty
    except ValueError as exc:
        _fail("output.frames", f"{template!r} is not a name with {{frame}} (and {{name}}): {exc}")
    for f, spec in fields:
        if f not in ("frame", "name"):
            _fail("output.frames", f"{template!r} has the field {{{f}}}: only {{frame}} and {{name}}")
        if "{" in spec or any(int(w) > MAX_FIELD_WIDTH for w in re.findall(r"\d+", spec)):
            _fail("output.frames", f"{template!r}: a field width is at most {MAX_FIELD_WIDTH}, got {{{f}:{spec}}}")
    try:
        name = template.format(frame=1, name="shot")
    except (KeyError, IndexError, ValueError) as exc:
        _fail("output.frames", f"{template!r} is not a name with {{frame}} (and {{name}}): {exc!r}")
    if name == template.format(frame=2, name="shot"):
        _fail("output.frames", f"{template!r} names every frame the same: put {{frame:04d}} in it")
    if os.path.splitext(name)[1].lower() not in (".obj", ".ply"):
        _fail("output.frames", f"must end in .obj or .ply, got {template!r}")
    return template


def _writable(folder: str) -> str:
    try:
        os.makedirs(folder, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        _fail("output.folder", f"cannot write to {folder}: {exc}")
    return folder


# -- the rig: what a bake simulates --------------------------------------------------------------------------
@dataclass
class Rig:
    sim: Simulation
    skin: Skin
    handle_ids: list[list[int]]
    fit: GoalFit | None = None


def build(shot: Shot, threads: int = 1) -> Rig:
    """Graph, skin, simulation, pins, handles and goals of a shot (the Blender engine's recipe)."""
    top, graph_settings, material, solver = (shot.section(k) for k in ("", "graph", "material", "solver"))
    graph = Graph.from_mesh(shot.vertices, shot.triangles, particles=graph_settings["particles"],
                            mode=graph_settings["mode"])
    sim = Simulation(graph, material["stiffness"], density=material["density"],
                     dt=1.0 / (top["fps"] * top["substeps"]), iterations=solver["iterations"],
                     gravity=material["gravity"], damping=material["damping"],
                     skin_neighbors=graph_settings["neighbors"])
    sim.set_solver(solver["accelerator"], threads=threads)
    sim.trace_energy = True
    if shot.section("floor"):
        sim.set_floor(shot.section("floor")["height"], shot.section("floor")["friction"])
    if len(shot.pins):
        pin_vertices(sim, shot.vertices, shot.pins, weight=shot.section("pins")["strength"] * sim.default_weight())
    handle_ids = [_add_handle(sim, shot.vertices, h) for h in shot.section("handles")]
    rig = Rig(sim, Skin(graph, shot.vertices, neighbors=graph_settings["neighbors"]), handle_ids)
    sim.set_contact_skin(rig.skin)  # as the engine: the skin meets the floor (docs/contact.md)
    if shot.section("goals"):
        rig.fit = GoalFit(graph, shot.vertices, neighbors=shot.section("goals")["neighbors"])
        sim.set_goal_strength(shot.section("goals")["strength"])
    return rig


def _add_handle(sim: Simulation, vertices: ArrayLike, handle: Settings) -> list[int]:
    weight = handle["strength"] * sim.default_weight("position")
    ids = pin_vertices(sim, vertices, [handle["vertex"]], weight=weight)
    if handle["rotation"]:
        w = handle["strength"] * sim.default_weight("direction")
        ids += [add_vertex_direction(sim, vertices, handle["vertex"], axis, weight=w) for axis in np.eye(3)]
    return ids


def _rotation(degrees: ArrayLike) -> Floats:
    """The rotation of Euler angles (degrees) about x, then y, then z (Blender's XYZ)."""
    rx, ry, rz = np.radians(degrees)
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    x = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    y = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    z = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return z @ y @ x


def _key_at(keys: Sequence[Settings], frame: int) -> tuple[Floats, Floats]:
    """(offset, rotate) at a frame: linear between keys, held before the first and after the last."""
    frames = [k["frame"] for k in keys]
    offset = [np.interp(frame, frames, [k["offset"][a] for k in keys]) for a in range(3)]
    rotate = [np.interp(frame, frames, [k["rotate"][a] for k in keys]) for a in range(3)]
    return np.array(offset), np.array(rotate)


def _apply_handles(rig: Rig, shot: Shot, frame: int) -> None:
    for ids, handle in zip(rig.handle_ids, shot.section("handles")):
        offset, rotate = _key_at(handle["keys"], frame)
        rig.sim.set_constraint_target(ids[0], shot.vertices[handle["vertex"]] + offset)
        for cid, axis in zip(ids[1:], _rotation(rotate).T):  # column a: the turned axis a
            rig.sim.set_constraint_target(cid, axis)


# -- the bake ------------------------------------------------------------------------------------------------
@dataclass
class Outputs:
    """The writers of one bake: PC2 (atomic, resumable), mesh frames and the report rows."""
    shot: Shot
    pc2: io.PC2Writer
    rows: list[Row]

    def frame(self, frame: int, vertices: Floats, row: Row) -> None:
        self.pc2.write(vertices)
        _write_frame(self.shot, frame, vertices)
        self.rows.append(row)


def _write_frame(shot: Shot, frame: int, vertices: ArrayLike) -> None:
    """The frame's mesh file (OBJ or PLY) when the spec asks for frames."""
    frames = shot.output("frames")
    if frames:
        path = frames.format(frame=frame, name=shot.name)
        os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
        with io.atomic_path(path) as part:
            io.write(part, vertices, shot.triangles)


def bake(shot: Shot, threads: int | None = None, progress: Callable[[int, int], object] | None = None,
         resume: bool = True) -> list[Row]:
    """Simulates the shot and writes its outputs; returns the report rows (one dict per frame, REPORT_COLUMNS).
    threads: the solver's when the spec leaves them to the runner (None: 1; results are the same bits for the
    same count); progress(done, total) after each frame; resume: continue from the shot's checkpoint
    when it was written for this spec, mesh and animation (same digest). Every output is locked for the bake
    (``io.exclusive``: a second bake of one of them raises ``io.OutputBusy``). A .blend shot is baked by
    Blender (``opdeform.blender``)."""
    with contextlib.ExitStack() as locks:
        for path in _output_paths(shot):
            locks.enter_context(io.exclusive(path, _lock(shot, path)))
        if shot.blend:
            from . import blender
            return blender.bake(shot, threads, progress, _place_baked)
        return _bake(shot, shot.threads(threads or 1), progress, resume)


def _output_paths(shot: Shot) -> list[str]:
    """Every file a bake writes (the frames by their first frame's name), the checkpoint included, the PC2 first
    and the others in a fixed order."""
    frames = shot.output("frames")
    first = frames and frames.format(frame=shot.first, name=shot.name)
    others = {shot.output("report"), shot.output("plot"), first, shot.checkpoint} - {shot.output("pc2")}
    return [shot.output("pc2")] + sorted(path for path in others if path is not None)


def _lock(shot: Shot, path: str) -> str:
    """The lock of an output, in the output folder: ``.NAME.lock``, a path in a subfolder quoted (``%2F``)."""
    folder = shot.settings["output"]["folder"]
    return os.path.join(folder, f".{urllib.parse.quote(os.path.relpath(path, folder), safe='')}.lock")


def _bake(shot: Shot, threads: int, progress: Callable[[int, int], object] | None, resume: bool) -> list[Row]:
    rig = build(shot, threads)
    start, rows = shot.first, []
    saved = _read_checkpoint(shot, rig, threads) if resume else None
    if saved:
        start, rows = saved["frame"], saved["rows"]
        log.info("%s: resuming after frame %d", shot.name, start)
    for path in (shot.output("pc2"), shot.output("report"), shot.output("plot"), shot.checkpoint):
        for part in io.partial_files(path) if path else ():  # left by a bake that was killed
            if not saved or part != saved["partial"]:
                os.remove(part)
    total = shot.last - shot.first + 1
    writer = io.PC2Writer(shot.output("pc2"), len(shot.vertices), shot.first, 1.0, keep=len(rows),
                          resume=saved["partial"] if saved else None)
    with writer:
        outputs = Outputs(shot, writer, rows)
        if not saved:
            _frame(rig, shot, shot.first, outputs, step=False)
        for frame in range(start + 1, shot.last + 1):
            _frame(rig, shot, frame, outputs)
            if progress:
                progress(frame - shot.first + 1, total)
            every = shot.section("output")["checkpoint_every"]
            if every and (frame - shot.first) % every == 0 and frame < shot.last:
                _write_checkpoint(shot, frame, rig.sim, rows, writer.partial)
    _write_report(shot, rows)
    if os.path.exists(shot.checkpoint):
        os.remove(shot.checkpoint)
    return rows


def _place_baked(shot: Shot, pc2: str, triangles: npt.NDArray[Any], rows: list[Row]) -> None:
    """The outputs of a bake made by Blender: frames and report from its PC2 (the mesh's ``triangles``), then
    the PC2 renamed into place."""
    shot = replace(shot, triangles=triangles)
    for k, vertices in enumerate(io.read_pc2(pc2)[2]):
        _write_frame(shot, shot.first + k, vertices)
    _write_report(shot, rows)
    os.replace(pc2, shot.output("pc2"))


def _frame(rig: Rig, shot: Shot, frame: int, outputs: Outputs, step: bool = True) -> None:
    """Targets and goals of the frame, ``substeps`` steps (none on the first frame: the rest state), the output."""
    _apply_handles(rig, shot, frame)
    goals = rig.fit.fit(shot.animation[frame - shot.first]) if rig.fit else None
    if goals:
        rig.sim.set_goals(*goals)
    t0 = time.perf_counter()
    if step:
        rig.sim.step(shot.section("")["substeps"])
    t1 = time.perf_counter()
    if goals:
        vertices = relative_deform(rig.skin, shot.animation[frame - shot.first], rig.sim, goals)
    else:
        vertices = rig.skin.deform(rig.sim.positions, rig.sim.rotations)
    solver = shot.section("solver")
    outputs.frame(frame, vertices, report_row(frame, rig.sim, step, t1 - t0, time.perf_counter() - t1,
                                              solver["iterations"], solver["tolerance"]))
    log.debug("%s: frame %d", shot.name, frame)


def report_row(frame: int, sim: Simulation, stepped: bool, step_seconds: float, skin_seconds: float, iterations: int,
               tolerance: float | None = None) -> Row:
    """The report row of a frame (REPORT_COLUMNS): times, the final objective, the residual (the last
    local/global pair's share of the last step's decrease of the objective: small when converged) and the
    fastest particle; ``stepped``: the simulation stepped for this frame (sim.trace_energy on)."""
    trace = sim.energy_trace if stepped else np.zeros(0)
    pair = 2 * iterations + 1
    last = trace[-pair:]
    drop = last[0] - last[-1] if len(last) >= 3 else 0.0
    residual = float((last[-3] - last[-1]) / drop) if drop > 0 else 0.0
    return {"frame": frame, "step_seconds": step_seconds, "skin_seconds": skin_seconds,
            "energy": float(last[-1]) if len(last) else 0.0, "residual": residual,
            "max_speed": float(np.linalg.norm(sim.velocities, axis=1).max()),
            "over_tolerance": int(tolerance is not None and residual > tolerance)}


# -- checkpoints: data, never code ----------------------------------------------------------------------------
# A checkpoint holds what a bake cannot make again from its spec: the simulation's state (positions, rotations,
# velocities, angular velocities, the floor's carried normal forces and their surfaces) after a frame and the report rows so far, as float64 arrays, behind a JSON
# header (format version, the shot's digest, the frame, the counts, the partial PC2's name and the payload's
# SHA-256). It is read only once the header matches this shot and the payload its digest; the rig itself comes
# from the spec. Nothing in an output folder is unpickled: the folder may be shared farm storage.
CHECKPOINT_MAGIC = b"OPDEFORM CHECKPOINT\n"
CHECKPOINT_VERSION = 2  # 2: with the carried normal forces (Simulation.surface_forces)
CHECKPOINT_HEADER = 4096  # bytes at most


def _read_checkpoint(shot: Shot, rig: Rig, threads: int) -> dict[str, Any] | None:
    """{"frame", "rows", "partial"} of the shot's checkpoint with ``rig.sim`` put in its state, or None: no
    checkpoint, or one that cannot be used (reported with its path: the bake starts over)."""
    if not os.path.lexists(shot.checkpoint):
        return None
    try:
        header, arrays = _checkpoint_arrays(shot, rig.sim.graph.n_particles)
        rig.sim._core.restore_state(*arrays[:4])
        rig.sim.set_surface_forces((arrays[4], arrays[5]))
    except (OSError, ValueError) as exc:
        log.warning("%s: cannot resume from it (%s); baking from the first frame (bake --restart ignores "
                    "checkpoints)", shot.checkpoint, exc)
        rig.sim = build(shot, threads).sim  # whatever a failed restore left
        return None
    rows = [dict(zip(REPORT_COLUMNS, row)) for row in arrays[6].tolist()]
    for row in rows:
        row["frame"], row["over_tolerance"] = int(row["frame"]), int(row["over_tolerance"])
    return {"frame": header["frame"], "rows": rows,
            "partial": os.path.join(os.path.dirname(shot.output("pc2")), header["partial"])}


def _checkpoint_arrays(shot: Shot, particles: int) -> tuple[dict[str, Any], list[Floats]]:
    """The header and arrays of the shot's checkpoint, checked; ValueError naming the first problem."""
    fd = os.open(shot.checkpoint, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOFOLLOW", 0))
    with os.fdopen(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
            raise ValueError("not a regular file")
        head = f.read(len(CHECKPOINT_MAGIC) + CHECKPOINT_HEADER)
        if not head.startswith(CHECKPOINT_MAGIC) or b"\n" not in head[len(CHECKPOINT_MAGIC):]:
            raise ValueError("not an opdeform checkpoint")
        line = head[len(CHECKPOINT_MAGIC):].split(b"\n", 1)[0]
        header = _checkpoint_header(shot, line, particles)
        f.seek(len(CHECKPOINT_MAGIC) + len(line) + 1)
        size = 8 * (particles * 22 + header["rows"] * len(REPORT_COLUMNS))
        payload = f.read(size + 1)
    if len(payload) != size:
        raise ValueError(f"{len(payload)} bytes of data where the header says {size}")
    if hashlib.sha256(payload).hexdigest() != header["sha256"]:
        raise ValueError("its data does not match its SHA-256")
    data = np.frombuffer(payload, "<f8")
    shapes = [(particles, 3), (particles, 3, 3), (particles, 3), (particles, 3), (particles, 3), (particles,),
              (header["rows"], len(REPORT_COLUMNS))]
    arrays, at = [], 0
    for shape in shapes:
        arrays.append(data[at:at + int(np.prod(shape))].reshape(shape).copy())
        at += int(np.prod(shape))
    if not np.array_equal(arrays[6][:, 0], np.arange(shot.first, header["frame"] + 1)):
        raise ValueError("its report rows are not the frames before it")
    return header, arrays


def _checkpoint_header(shot: Shot, line: bytes, particles: int) -> dict[str, Any]:
    try:
        header = json.loads(line)
    except (ValueError, RecursionError):
        raise ValueError("its header is not JSON") from None
    expected = {"version": int, "digest": str, "frame": int, "particles": int, "rows": int, "partial": str,
                "sha256": str}
    if not isinstance(header, dict) or set(header) != set(expected) or \
            any(type(header[k]) is not kind for k, kind in expected.items()):
        raise ValueError(f"its header is not that of version {CHECKPOINT_VERSION}")
    if header["version"] != CHECKPOINT_VERSION:
        raise ValueError(f"format version {header['version']}, this opdeform reads {CHECKPOINT_VERSION}")
    if header["digest"] != shot.digest:
        raise ValueError("written for another spec, mesh or animation")
    if header["particles"] != particles or not shot.first <= header["frame"] < shot.last or \
            header["rows"] != header["frame"] - shot.first + 1:
        raise ValueError(f"frame {header['frame']} of {header['particles']} particles does not fit this shot")
    partial = os.path.join(os.path.dirname(shot.output("pc2")), header["partial"])
    if os.path.basename(header["partial"]) != header["partial"] or partial not in io.partial_files(shot.output("pc2")):
        raise ValueError(f"its partial PC2 {header['partial']!r} is not there")
    return header


def _write_checkpoint(shot: Shot, frame: int, sim: Simulation, rows: list[Row], partial: str) -> None:
    table = np.array([[row[c] for c in REPORT_COLUMNS] for row in rows], "<f8")
    n = sim.graph.n_particles
    forces, surfaces = sim.surface_forces or (np.zeros((n, 3)), np.full(n, -2))
    arrays = (sim.positions, sim.rotations, sim.velocities, sim.angular_velocities, forces, surfaces, table)
    payload = b"".join(np.ascontiguousarray(a, "<f8").tobytes() for a in arrays)
    header = {"version": CHECKPOINT_VERSION, "digest": shot.digest, "frame": frame,
              "particles": sim.graph.n_particles, "rows": len(rows), "partial": os.path.basename(partial),
              "sha256": hashlib.sha256(payload).hexdigest()}
    with io.atomic_path(shot.checkpoint) as part, open(part, "wb") as f:
        f.write(CHECKPOINT_MAGIC + json.dumps(header).encode() + b"\n" + payload)


# -- the report ----------------------------------------------------------------------------------------------
def _write_report(shot: Shot, rows: list[Row]) -> None:
    """The report CSV (and its plot) of the spec's outputs."""
    report, plot = shot.output("report"), shot.output("plot")
    if report:
        with io.atomic_path(report) as part, open(part, "w") as f:
            f.write(",".join(REPORT_COLUMNS) + "\n")
            f.writelines(",".join(repr(row[c]) for c in REPORT_COLUMNS) + "\n" for row in rows)
    if plot:
        _plot(plot, rows, shot.name)


def _plot(path: str, rows: list[Row], title: str) -> None:
    try:
        import matplotlib
    except ModuleNotFoundError:  # an optional package: the bake's other outputs stand without it
        log.warning('%s not written: the plot needs matplotlib (pip install "opdeform[plot]")', path)
        return
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = rows[1:] or rows  # the first frame is the rest shape: nothing was solved
    frames = [r["frame"] for r in rows]
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    top.semilogy(frames, [max(r["residual"], 1e-17) for r in rows])
    top.set_ylabel("residual")
    top.set_title(title)
    bottom.plot(frames, [1e3 * r["step_seconds"] for r in rows])
    bottom.set_ylabel("ms per frame")
    bottom.set_xlabel("frame")
    with io.atomic_path(path) as part:
        fig.savefig(part, dpi=100, format="png")
    plt.close(fig)


def read_report(path: io.FilePath) -> list[Row]:
    """The rows of a report CSV (a dict per frame, numbers as numbers)."""
    with open(path) as f:
        header = f.readline().strip().split(",")
        if tuple(header) != REPORT_COLUMNS:
            raise ValueError(f"{path}: not an opdeform report (columns {header})")
        return [{k: (int(v) if k in ("frame", "over_tolerance") else float(v)) for k, v in
                 zip(header, line.strip().split(","))} for line in f if line.strip()]
