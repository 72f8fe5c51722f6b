"""Tumbling particles: MLS-MPM snow whose particles turn with the material (Song et al. 2022).

The C core (``opdeform._core.MpmWorld``) simulates; this module checks and converts arguments (ValueError
naming the argument), provides the material presets, emitters that fill boxes, meshes and flake layers
with randomly oriented particles, and PLY export of the frames. Quaternions are (w, x, y, z). See docs/mpm.md.
"""

import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _core
from ._arguments import ArrayLike, Floats, Vector, as_array, choice, integer, number, vector
from .fields import ForceFields
from .io import FilePath

__all__ = ["Material", "snow", "jelly", "flakes", "World", "fill_box", "fill_mesh", "flake_layer",
           "random_orientations", "quaternions_to_euler", "write_ply", "read_ply", "write_frames"]

_KINDS = {"snow": 0, "jelly": 1, "flakes": 2}
_CONTACTS = {"sticky": 0, "slip": 1, "separate": 2}
_SHAPES = {"plane": 0, "box": 1, "sphere": 2, "mesh": 3}
_WINDS = {"off": 0, "noise": 1, "potential": 2}
_FIELDS: dict[str, int | tuple[int, ...]] = {
    "positions": 3, "velocities": 3, "orientations": 4, "rotations": (3, 3), "deformation": (3, 3), "affine": (3, 3),
    "plastic_j": ()}


@dataclass
class Material:
    """kind: 'snow' (Stomakhin 2013 plasticity), 'jelly' (elastic) or 'flakes' (loose: no shear, no tension)."""
    kind: str = "snow"
    density: float = 600.0
    young_modulus: float = 5e3
    poisson_ratio: float = 0.3
    critical_compression: float = 2.5e-2
    critical_stretch: float = 4.5e-3
    hardening: float = 10.0

    def _core_tuple(self) -> tuple[int, float, float, float, float, float, float]:
        d, e, p, c, s, h = (number(f"material.{n}", getattr(self, n)) for n in (
            "density", "young_modulus", "poisson_ratio", "critical_compression", "critical_stretch", "hardening"))
        return choice("material.kind", self.kind, _KINDS), d, e, p, c, s, h


def snow(**changes: Any) -> Material:
    """The seed's Table 2: θc 2.5e-2, θs 4.5e-3, ξ 10, ρ 600, E 5e3, ν 0.3."""
    return Material(**changes)


def jelly(**changes: Any) -> Material:
    return Material(**{"kind": "jelly", "density": 1000.0, "young_modulus": 1e5, **changes})


def flakes(**changes: Any) -> Material:
    return Material(**{"kind": "flakes", "density": 100.0, "young_modulus": 1e3, **changes})


class World(ForceFields):
    """A 3-D MLS-MPM world over the box [lower, upper] with grid spacing dx.

    spin: η, the factor on each particle's rotation angle (0 = plain MLS-MPM, particles keep their rest
    orientation). walls: contact of the domain's faces ('sticky', 'slip', 'separate'). threads: 0..64, 0 = the
    CPUs this process may use (affinity mask, at most OMP_NUM_THREADS). A step is refused, before anything moves,
    when it would take more than 100,000 substeps or 2^27 particle-substeps (colliders' speeds counted).
    """

    def __init__(self, lower: Vector, upper: Vector, dx: float, gravity: Vector = (0.0, 0.0, -9.81), cfl: float = 0.4,
                 max_dt: float = 1e-3, spin: float = 1.0, walls: str = "slip", wall_friction: float = 0.0,
                 threads: int = 0) -> None:
        self.dx = number("dx", dx)
        self._core = _core.MpmWorld(vector("lower", lower), vector("upper", upper), self.dx,
                                    vector("gravity", gravity), number("cfl", cfl), number("max_dt", max_dt),
                                    number("spin", spin), choice("walls", walls, _CONTACTS),
                                    number("wall_friction", wall_friction), integer("threads", threads))
        # the calls that make the model, for pickling (the state itself comes from the core as bytes)
        self._calls: list[tuple[str, tuple[Any, ...]]] = [
            ("__init__", (lower, upper, dx, gravity, cfl, max_dt, spin, walls, wall_friction, threads))]

    def __getstate__(self) -> dict[str, Any]:
        return {"calls": self._calls, "state": self._core.save_state()}

    # what a pickle may replay: the calls that make the model, __init__ first (the particles are in the state)
    _REPLAYED = ("set_wind", "add_collider", "add_force_field", "move_force_field", "remove_force_field")

    def __setstate__(self, saved: dict[str, Any]) -> None:
        """The recorded model calls again, then the core's state bytes, which it checks before writing anything;
        anything else in ``calls`` raises ValueError naming it (a pickle is untrusted input, issue 28). This
        cannot make ``pickle.loads`` safe: it runs whatever a crafted pickle names before this is reached. A
        World has no public loader of plain data (its particles' deformation and plastic state travel only in
        the pickle): unpickle only what you or a trusted process wrote."""
        calls = saved.get("calls") if isinstance(saved, dict) else None
        if not isinstance(calls, list) or not calls:
            raise ValueError(f"calls: a list of (name, arguments) pairs expected, got {type(calls).__name__}")
        for k, call in enumerate(calls):
            allowed = ("__init__",) if k == 0 else self._REPLAYED
            if not (isinstance(call, tuple) and len(call) == 2 and call[0] in allowed and isinstance(call[1], tuple)):
                raise ValueError(f"calls[{k}]: one of {allowed} with a tuple of arguments expected, got {call!r:.80}")
        for name, args in calls:
            getattr(self, name)(*args)
        self._core.load_state(saved["state"])

    # -- content -------------------------------------------------------------------------------------------
    def add_particles(self, positions: ArrayLike, material: Material | None = None,
                      particle_volume: float | None = None, velocities: ArrayLike | None = None,
                      orientations: ArrayLike | None = None, affine: ArrayLike | None = None) -> None:
        """Adds a batch of particles sharing a material. particle_volume defaults to (dx/2)³ (8 per cell)."""
        pos = as_array("positions", positions, (None, 3))
        n = pos.shape[0]
        if n == 0:
            raise ValueError("positions: need at least one particle")
        if not np.all(np.isfinite(pos)):
            raise ValueError("positions must be finite (found NaN or infinity)")
        vel = None if velocities is None else as_array("velocities", velocities, (n, 3))
        quat = None if orientations is None else as_array("orientations", orientations, (n, 4))
        aff = None if affine is None else as_array("affine", affine, (n, 3, 3))
        volume = (0.5 * self.dx) ** 3 if particle_volume is None else number("particle_volume", particle_volume)
        material = snow() if material is None else material
        if not isinstance(material, Material):
            raise ValueError(f"material must be an opdeform.mpm.Material, got {type(material).__name__}")
        self._core.add_particles(pos, vel, aff, quat, volume, material._core_tuple())

    def set_wind(self, kind: str = "noise", velocity: Vector = (0.0, 0.0, 0.0), amplitude: float = 1.0,
                 wavelength: float = 4.0, octaves: int = 4, persistence: float = 0.5, drift: Vector = (0.0, 0.0),
                 drag: float = 2.0, ground: float = 0.0, ref_height: float = 1.0, exponent: float = 0.0,
                 seed: int = 1) -> None:
        """Perlin-noise wind on the grid. kind: 'noise' (vortical), 'potential' (curl-free gradient of
        noise) or 'off'. Grid velocities relax to the wind at rate ``drag`` (1/s); the wind is scaled by
        ((z - ground) / ref_height) ** exponent ('noise' only) and its pattern drifts with ``drift`` (m/s)."""
        self._core.set_wind(choice("wind kind", kind, _WINDS), vector("velocity", velocity),
                            number("amplitude", amplitude), number("wavelength", wavelength),
                            integer("octaves", octaves), number("persistence", persistence),
                            _pair("drift", drift), number("drag", drag), number("ground", ground),
                            number("ref_height", ref_height), number("exponent", exponent),
                            integer("seed", seed, None) & 0xFFFFFFFF)
        self._calls.append(("set_wind", (kind, velocity, amplitude, wavelength, octaves, persistence, drift, drag,
                                         ground, ref_height, exponent, seed)))

    def add_collider(self, shape: str, contact: str = "slip", friction: float = 0.0,
                     half_extents: Vector = (0.5, 0.5, 0.5), radius: float | None = None,
                     vertices: ArrayLike | None = None, triangles: ArrayLike | None = None,
                     rotation: ArrayLike | None = None, translation: Vector = (0.0, 0.0, 0.0)) -> int:
        """A collider: shape 'plane' (z < 0 of its frame), 'box', 'sphere' or 'mesh' (closed triangles in its
        frame). Returns its id for move_collider."""
        shape_id = choice("shape", shape, _SHAPES)
        if radius is not None:
            half_extents = (number("radius", radius),) * 3
        verts: Floats | None = None
        tris = None
        if shape == "mesh":
            verts = as_array("vertices", vertices, (None, 3))
            tris = as_array("triangles", triangles, (None, 3), np.int32)
            if tris.shape[0] == 0:
                raise ValueError("triangles: a mesh collider needs at least one face")
        id = self._core.add_collider(shape_id, choice("contact", contact, _CONTACTS), number("friction", friction),
                                     vector("half_extents", half_extents), verts, tris, _rotation(rotation),
                                     vector("translation", translation))
        self._calls.append(("add_collider", (shape, contact, friction, half_extents, None, verts, tris, rotation,
                                             translation)))
        return id

    def add_floor(self, height: float = 0.0, contact: str = "slip", friction: float = 0.0) -> int:
        return self.add_collider("plane", contact, friction, translation=(0.0, 0.0, number("height", height)))

    def move_collider(self, id: int, translation: Vector, rotation: ArrayLike | None = None) -> None:
        """The collider's frame at the end of the next step(); it moves there at constant velocity."""
        self._core.move_collider(integer("id", id), _rotation(rotation), vector("translation", translation))

    # -- stepping ------------------------------------------------------------------------------------------
    def step(self, duration: float) -> None:
        """Advances ``duration`` seconds in CFL-limited substeps, then updates the orientations."""
        self._core.step(number("duration", duration))

    def substep(self, dt: float) -> None:
        """One substep of exactly dt (no CFL limit, orientations not updated)."""
        self._core.substep(number("dt", dt))

    def update_orientations(self) -> None:
        self._core.update_orientations()

    # -- state ---------------------------------------------------------------------------------------------
    @property
    def n_particles(self) -> int:
        return self._core.n_particles

    def read(self, name: str) -> Floats:
        """A field as a numpy array: positions, velocities (n,3), orientations (n,4), rotations,
        deformation, affine (n,3,3) or plastic_j (n,)."""
        if name not in _FIELDS:
            raise ValueError(f"name must be one of {sorted(_FIELDS)}, got {name!r}")
        width = _FIELDS[name]
        out = np.empty((self.n_particles,) + (width if isinstance(width, tuple) else (width,)))
        self._core.read(name, out)
        return out

    @property
    def positions(self) -> Floats:
        """read("positions"): (n,3)."""
        return self.read("positions")

    @property
    def velocities(self) -> Floats:
        """read("velocities"): (n,3)."""
        return self.read("velocities")

    @property
    def orientations(self) -> Floats:
        """read("orientations"): (n,4) unit quaternions (w, x, y, z)."""
        return self.read("orientations")

    @property
    def rotations(self) -> Floats:
        """read("rotations"): (n,3,3)."""
        return self.read("rotations")

    @property
    def stats(self) -> dict[str, float]:
        """substeps, last_substeps, time, last_dt, active_blocks, max_speed."""
        return self._core.stats()


# -- emitters ------------------------------------------------------------------------------------------------
def random_orientations(n: int, seed: int = 0) -> Floats:
    """n unit quaternions (w, x, y, z) uniform over the rotations (Shoemake)."""
    rng = np.random.default_rng(seed)
    u1, u2, u3 = rng.random((3, integer("n", n)))
    a, b = np.sqrt(1.0 - u1), np.sqrt(u1)
    q = np.stack([a * np.sin(2 * np.pi * u2), a * np.cos(2 * np.pi * u2), b * np.sin(2 * np.pi * u3),
                  b * np.cos(2 * np.pi * u3)], axis=1)
    return q * np.where(q[:, :1] < 0, -1.0, 1.0)


def fill_box(lower: Vector, upper: Vector, spacing: float, jitter: float = 0.0, seed: int = 0) -> Floats:
    """Particle centres on a lattice of ``spacing`` filling [lower, upper], each moved by up to
    jitter * spacing at random."""
    lo, hi, h = vector("lower", lower), vector("upper", upper), number("spacing", spacing)
    if h <= 0 or any(b <= a for a, b in zip(lo, hi)):
        raise ValueError("fill_box: need spacing > 0 and lower < upper")
    axes = [np.arange(a + 0.5 * h, b, h) for a, b in zip(lo, hi)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    if jitter:
        pts = pts + (np.random.default_rng(seed).random(pts.shape) - 0.5) * (number("jitter", jitter) * h)
    return pts


def fill_mesh(vertices: ArrayLike, triangles: ArrayLike, spacing: float, jitter: float = 0.0,
              seed: int = 0) -> Floats:
    """Lattice points inside a closed triangle mesh (parity of ray crossings along +x)."""
    v = as_array("vertices", vertices, (None, 3))
    t = as_array("triangles", triangles, (None, 3), np.int32)
    if t.shape[0] == 0:
        raise ValueError("triangles: fill_mesh needs at least one face")
    pts = fill_box(v.min(axis=0), v.max(axis=0), spacing, jitter, seed)
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    det = (b[:, 1] - a[:, 1]) * (c[:, 2] - a[:, 2]) - (c[:, 1] - a[:, 1]) * (b[:, 2] - a[:, 2])
    keep = det != 0
    a, b, c, det = a[keep], b[keep], c[keep], det[keep]
    inside = np.zeros(len(pts), bool)
    chunk = max(1, 2_000_000 // max(1, len(a)))  # points per batch: about 2e6 point-triangle pairs
    for start in range(0, len(pts), chunk):
        p = pts[start:start + chunk, None, :]
        y, z = p[..., 1] - a[:, 1], p[..., 2] - a[:, 2]
        u = (y * (c[:, 2] - a[:, 2]) - (c[:, 1] - a[:, 1]) * z) / det
        w = ((b[:, 1] - a[:, 1]) * z - y * (b[:, 2] - a[:, 2])) / det
        hit_x = a[:, 0] + u * (b[:, 0] - a[:, 0]) + w * (c[:, 0] - a[:, 0])
        crossing = (u >= 0) & (w >= 0) & (u + w <= 1) & (hit_x > p[..., 0])
        inside[start:start + chunk] = crossing.sum(axis=1) % 2 == 1
    return pts[inside]


def flake_layer(center: Vector, size: ArrayLike, thickness: float, count: int, seed: int = 0) -> Floats:
    """``count`` flakes scattered uniformly in a slab of horizontal size (sx, sy) and ``thickness``."""
    c = np.array(vector("center", center))
    s = as_array("size", size, (2,))
    rng = np.random.default_rng(seed)
    u = rng.random((integer("count", count), 3)) - 0.5
    return c + u * np.array([s[0], s[1], number("thickness", thickness)])


def quaternions_to_euler(q: ArrayLike) -> Floats:
    """(n,4) quaternions (w, x, y, z) to (n,3) Euler angles in Blender's 'XYZ' order (for Blender < 4.1)."""
    w, x, y, z = as_array("q", q, (None, 4)).T
    rx = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    ry = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    rz = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([rx, ry, rz], axis=1)


# -- export --------------------------------------------------------------------------------------------------
_PLY_FIELDS = ("x", "y", "z", "qw", "qx", "qy", "qz", "vx", "vy", "vz")


def write_ply(path: FilePath, positions: ArrayLike, orientations: ArrayLike,
              velocities: ArrayLike | None = None) -> None:
    """Binary little-endian PLY of vertices with float properties x y z qw qx qy qz [vx vy vz]."""
    pos = as_array("positions", positions, (None, 3))
    n = pos.shape[0]
    cols = [pos, as_array("orientations", orientations, (n, 4))]
    if velocities is not None:
        cols.append(as_array("velocities", velocities, (n, 3)))
    data = np.ascontiguousarray(np.concatenate(cols, axis=1), dtype="<f4")
    names = _PLY_FIELDS[:data.shape[1]]
    header = ["ply", "format binary_little_endian 1.0", "comment opdeform tumbling particles, quaternion w x y z",
              f"element vertex {n}"] + [f"property float {name}" for name in names] + ["end_header"]
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(data.tobytes())


def read_ply(path: FilePath) -> dict[str, np.ndarray[Any, np.dtype[np.float32]]]:
    """The dict of float arrays written by write_ply (name -> (n,)); ValueError naming the file for anything
    else (not a regular file, a damaged header, a vertex count the data does not hold)."""
    from .io import read_regular
    data = read_regular(path)
    end = data.find(b"end_header\n", 0, 65536)
    if end < 0:  # a file cut short (or empty): no end_header would ever come
        raise ValueError(f"{os.fspath(path)}: no end_header in the first 64 KiB of the PLY header")
    try:
        lines = data[:end].decode("ascii").splitlines()
    except UnicodeDecodeError:
        raise ValueError(f"{os.fspath(path)}: the PLY header is not ASCII text") from None
    names = [line.split()[2] for line in lines if line.startswith("property float") and len(line.split()) == 3]
    counts = [line.split()[2:] for line in lines if line.startswith("element vertex")]
    given = counts[0][0] if len(counts) == 1 and len(counts[0]) == 1 else None
    if given is None or not given.isdigit():
        raise ValueError(f"{os.fspath(path)}: the PLY header's vertex count must be one integer >= 0, got {given!r}")
    n, body = int(given), data[end + len(b"end_header\n"):]
    if n * 4 * len(names) > len(body):
        raise ValueError(f"{os.fspath(path)}: truncated: {n} vertices of {len(names)} floats need "
                         f"{n * 4 * len(names)} bytes, the file holds {len(body)}")
    values = np.frombuffer(body, dtype="<f4", count=n * len(names)).reshape(n, len(names))
    return {name: values[:, k] for k, name in enumerate(names)}


def write_frames(world: World, out_dir: FilePath, frames: int, fps: float = 24, prefix: str = "frame",
                 on_frame: Callable[[int, World], object] | None = None) -> list[str]:
    """Steps ``world`` one frame at a time and writes out_dir/<prefix>_0000.ply ... (frame 0 = the initial
    state). on_frame(index, world) runs before each step (move colliders there) and may return False to
    stop. Returns the written paths."""
    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for frame in range(integer("frames", frames) + 1):
        if frame > 0:
            if on_frame is not None and on_frame(frame, world) is False:
                break
            world.step(1.0 / fps)
        path = os.path.join(out_dir, f"{prefix}_{frame:04d}.ply")
        write_ply(path, world.positions, world.orientations, world.velocities)
        paths.append(path)
    return paths


# -- argument helpers ----------------------------------------------------------------------------------------
def _pair(name: str, value: Vector) -> tuple[float, float]:
    x, y = vector(name, value, 2)
    return x, y


def _rotation(rotation: ArrayLike | None) -> Floats:
    return np.eye(3) if rotation is None else as_array("rotation", rotation, (3, 3))
