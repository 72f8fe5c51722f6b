"""Tumbling particles in the add-on, bpy-free: plain settings to an ``opdeform.mpm`` world, the bake loop that
writes one PLY per frame (positions, orientation quaternions, velocities), and the frames read back. The
functions take the ``opdeform.mpm`` module that core/loader.py found.

The Blender side (blender/tumbling.py) gathers the settings, the emitter's particles and the colliders'
meshes and per-frame matrices from the scene, and turns the frames into a point cloud whose orientation
attribute drives Geometry Nodes' Instance on Points.
"""

import os

import numpy as np

QUATERNION_ATTRIBUTES = (4, 1)  # Blender version with QUATERNION mesh attributes and rotation sockets


def frame_file(folder, frame):
    return os.path.join(folder, f"tumbling_{int(frame):05d}.ply")


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
