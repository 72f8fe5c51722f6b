"""Tumbling particles in the add-on, bpy-free: plain settings to an ``opdeform.mpm`` world, the bake loop that
writes one PLY per frame (positions, orientation quaternions, velocities), and the frames read back. The
functions take the ``opdeform.mpm`` module that core/loader.py found.

Also the plain logic around them: where the particles are emitted, the settings dictionary made from the
Tumbling Particles settings, the cache folder and which baked frame a scene frame shows.

The Blender side (blender/tumbling_runtime.py) gathers the settings, the emitter's mesh and the colliders'
meshes and per-frame matrices from the scene; blender/point_cloud.py turns the frames into a point cloud whose
orientation attribute drives Geometry Nodes' Instance on Points. Errors here are ValueError, which the Blender
side reports.
"""

import os

import numpy as np

QUATERNION_ATTRIBUTES = (4, 1)  # Blender version with QUATERNION mesh attributes and rotation sockets
DEFAULT_FOLDER = "//opdeform_tumbling"  # next to the .blend


def frame_file(folder, frame):
    return os.path.join(folder, f"tumbling_{int(frame):05d}.ply")


def free_frames(folder):
    """Deletes the baked frame files in folder (nothing else)."""
    for frame in baked_frames(folder):
        os.remove(frame_file(folder, frame))


def shown_frame(frame, start, end):
    """The baked frame a scene frame shows: past either end of the baked range, the end's frame."""
    return min(max(frame, start), end)


def settings_dict(s, gravity, lower, upper):
    """The Bake's settings from the Tumbling Particles settings ``s`` (any object with their attributes), the
    scene's gravity and the domain's world box."""
    wind = None
    if s.wind != "off":
        wind = {"kind": s.wind, "velocity": tuple(s.wind_velocity), "amplitude": s.wind_amplitude,
                "wavelength": s.wind_wavelength, "octaves": s.wind_octaves, "persistence": s.wind_persistence,
                "drift": tuple(s.wind_drift), "drag": s.wind_drag, "ground": float(lower[2]),
                "ref_height": float(upper[2] - lower[2]), "exponent": s.wind_exponent, "seed": s.seed + 1}
    return {"lower": tuple(lower), "upper": tuple(upper), "dx": s.dx, "gravity": tuple(gravity), "spin": s.spin,
            "material": s.material, "density": s.density, "young_modulus": s.young_modulus,
            "poisson_ratio": s.poisson_ratio, "spacing": s.spacing, "seed": s.seed, "wind": wind,
            "floor": (s.floor_height, s.floor_friction) if s.use_floor else None}


def flake_layer(mpm, s, lower, upper):
    """The Flake Layer emitter: s.count flakes in a horizontal layer at s.layer_height (a share of the
    domain's height), s.layer_thickness thick, kept 3 cells clear of the domain's faces (particles must
    start 2 cells inside)."""
    inner_lo, inner_hi = np.asarray(lower, float) + 3 * s.dx, np.asarray(upper, float) - 3 * s.dx
    if np.any(inner_hi <= inner_lo):
        raise ValueError("the domain is too small for its grid spacing: lower Grid Spacing")
    size = inner_hi - inner_lo
    thickness = s.layer_thickness * size[2]
    centre = inner_lo + size * [0.5, 0.5, 0.0]
    centre[2] = np.clip(lower[2] + s.layer_height * (upper[2] - lower[2]), inner_lo[2] + thickness / 2,
                        inner_hi[2] - thickness / 2)
    return mpm.flake_layer(centre, size[:2], thickness, s.count, seed=s.seed)


def fill_volume(mpm, s, vertices, triangles, matrix):
    """The Object Volume emitter: particles s.spacing apart filling the closed mesh (vertices in the object's
    frame, placed by its 4x4 world matrix)."""
    m = np.asarray(matrix, float).reshape(4, 4)
    world = np.asarray(vertices, float) @ m[:3, :3].T + m[:3, 3]
    return mpm.fill_mesh(world, triangles, s.spacing, jitter=0.5, seed=s.seed)


def split_matrix(matrix):
    """A 4x4 object matrix as (rotation, stretch, translation): matrix[:3, :3] = rotation @ stretch (polar)."""
    m = np.asarray(matrix, float).reshape(4, 4)
    u, s, vt = np.linalg.svd(m[:3, :3])
    if np.linalg.det(u @ vt) < 0:
        u[:, -1] = -u[:, -1]
        s[-1] = -s[-1]
    rotation = u @ vt
    return rotation, vt.T @ np.diag(s) @ vt, m[:3, 3].copy()


class Collider:
    """A mesh collider: its vertices in the object's frame with the object's stretch (scale) applied once,
    its triangles, and where it is, as a 4x4 world matrix per baked frame."""

    def __init__(self, name, vertices, triangles, matrix, contact="separate", friction=0.0):
        rotation, stretch, translation = split_matrix(matrix)
        self.name = name
        self.vertices = np.asarray(vertices, float) @ stretch.T
        self.triangles = np.asarray(triangles, np.int32).reshape(-1, 3)
        self.rotation, self.translation = rotation, translation
        self.contact, self.friction = contact, float(friction)


class Bake:
    """Simulates frames start..end and writes frame_file(folder, f) for each (the start frame is the emitted
    state). ``step(matrices)`` takes the colliders' world matrices at the next frame."""

    def __init__(self, mpm, settings, positions, colliders, folder, start, end, fps):
        if end < start:
            raise ValueError("the end frame is before the start frame")
        positions = np.asarray(positions, float).reshape(-1, 3)
        if len(positions) == 0:
            raise ValueError("the emitter made no particles: check its mesh, spacing or count")
        s = settings
        self.world = mpm.World(s["lower"], s["upper"], s["dx"], gravity=s["gravity"], spin=s["spin"],
                               walls=s.get("walls", "slip"))
        material = mpm.Material(kind=s["material"], density=s["density"], young_modulus=s["young_modulus"],
                                poisson_ratio=s["poisson_ratio"])
        spacing = s["spacing"]
        self.world.add_particles(positions, material, particle_volume=spacing ** 3,
                                 orientations=mpm.random_orientations(len(positions), s.get("seed", 0)))
        if s.get("wind"):
            self.world.set_wind(**s["wind"])
        if s.get("floor") is not None:
            height, friction = s["floor"]
            self.world.add_floor(height, friction=friction)
        self.colliders = []
        for c in colliders:
            cid = self.world.add_collider("mesh", c.contact, c.friction, vertices=c.vertices, triangles=c.triangles,
                                          rotation=c.rotation, translation=c.translation)
            self.colliders.append((cid, c))
        self.mpm, self.folder, self.fps = mpm, folder, float(fps)
        self.start, self.end, self.frame = int(start), int(end), int(start)
        os.makedirs(folder, exist_ok=True)
        self._write()

    @property
    def done(self):
        return self.frame >= self.end

    def step(self, matrices=()):
        """Moves the colliders to their matrices of the next frame, simulates it and writes it."""
        for (cid, collider), matrix in zip(self.colliders, matrices):
            rotation, _, translation = split_matrix(matrix)
            self.world.move_collider(cid, translation, rotation)
        self.world.step(1.0 / self.fps)
        self.frame += 1
        self._write()

    def _write(self):
        w = self.world
        self.mpm.write_ply(frame_file(self.folder, self.frame), w.positions, w.orientations, w.velocities)


def read_frame(mpm, folder, frame):
    """(positions (n,3), quaternions (n,4) w x y z) of a baked frame, or None when the file is missing."""
    path = frame_file(folder, frame)
    if not os.path.isfile(path):
        return None
    data = mpm.read_ply(path)
    positions = np.column_stack([data["x"], data["y"], data["z"]])
    quaternions = np.column_stack([data["qw"], data["qx"], data["qy"], data["qz"]])
    return positions, quaternions


def baked_frames(folder):
    """The frame numbers with a file in folder, sorted."""
    if not os.path.isdir(folder):
        return []
    return sorted(int(n[len("tumbling_"):-4]) for n in os.listdir(folder)
                  if n.startswith("tumbling_") and n.endswith(".ply") and n[len("tumbling_"):-4].isdigit())
