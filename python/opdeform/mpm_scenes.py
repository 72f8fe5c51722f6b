"""The seed's two scenes (Song et al. 2022, Figs. 9-11) and the meshes they use, built in code.

- scattered_flakes: flakes falling through Perlin-noise wind; run it with spin=0 for the plain MLS-MPM
  comparison of Fig. 9, where flakes keep their rest orientation.
- car_collision: a car-shaped mesh collider drives through a layer of flakes lying on the ground.

Each returns a Scene: the world, the frame rate, the frame count and ``on_frame(frame, world)``, which
moves the colliders before each frame (pass it to mpm.write_frames).
"""

from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from . import mpm
from ._arguments import ArrayLike, Floats, Ints
from .io import FilePath


@dataclass
class Scene:
    world: mpm.World
    fps: float
    frames: int
    on_frame: Callable[[int, mpm.World], object] | None = None
    name: str = ""

    def run(self, out_dir: FilePath, frames: int | None = None, prefix: str | None = None) -> list[str]:
        """Writes the scene's frames as PLY files; returns their paths."""
        return mpm.write_frames(self.world, out_dir, self.frames if frames is None else frames, self.fps,
                                prefix or self.name or "frame", self.on_frame)


def extrude_profile(profile: ArrayLike, width: float) -> tuple[Floats, Ints]:
    """A closed mesh: the star-shaped polygon ``profile`` ((k,2) points (x, z), counter-clockwise) extruded
    along y over [-width/2, width/2]. Returns (vertices (2k+2, 3), triangles)."""
    p = np.asarray(profile, float)
    k = len(p)
    centre = p.mean(axis=0)
    ring = np.concatenate([p, centre[None]])
    side = [np.column_stack([ring[:, 0], np.full(k + 1, y), ring[:, 1]]) for y in (-width / 2, width / 2)]
    vertices = np.concatenate(side)
    tris = []
    for i in range(k):
        j = (i + 1) % k
        tris += [(i, j, k), (k + 1 + i, 2 * k + 1, k + 1 + j)]  # the two caps, fans from the centre
        tris += [(i, k + 1 + j, j), (i, k + 1 + i, k + 1 + j)]  # the side quad
    return vertices, np.array(tris, np.int32)


def car_mesh(length: float = 1.2, width: float = 0.55, height: float = 0.45) -> tuple[Floats, Ints]:
    """A car's side silhouette (body, bonnet, cabin) extruded to its width; x forward, z up, the ground at
    z = 0 and the body's underside 0.05 * height above it."""
    profile = np.array([(0.0, 0.05), (1.0, 0.05), (1.0, 0.35), (0.78, 0.45), (0.68, 0.9), (0.3, 0.9), (0.18, 0.5),
                        (0.0, 0.42)])
    profile = (profile - [0.5, 0.0]) * [length, height]
    return extrude_profile(profile, width)


def snowflake_mesh(radius: float = 1.0, thickness: float = 0.08, arms: int = 6) -> tuple[Floats, Ints]:
    """A flat star with ``arms`` arms in the xy plane (normal +z), for instancing on the particles."""
    angles = np.arange(2 * arms) * np.pi / arms
    r = np.where(np.arange(2 * arms) % 2 == 0, radius, 0.3 * radius)
    outline = np.column_stack([r * np.cos(angles), r * np.sin(angles)])
    vertices, triangles = extrude_profile(outline, thickness)
    return vertices[:, [0, 2, 1]], triangles[:, ::-1].copy()  # the profile plane becomes xy, keep outward faces


def scattered_flakes(spin: float = 1.0, count: int = 3000, seed: int = 0, threads: int = 0, fps: float = 24,
                     frames: int = 72, wind: str = "noise", material: mpm.Material | None = None) -> Scene:
    """Flakes released flat (all alike, as the seed's) over a 3 m × 3 m area at 2.5 m height fall through
    vortical Perlin wind whose strength grows with height; the air's drag (the wind's coupling) holds them
    near 1 m/s. With spin = 0 they stay flat (plain MLS-MPM). ``wind="potential"`` is the control: a
    curl-free wind of the same mean speed, which turns them a tenth as much (docs/mpm.md). ``material``
    replaces mpm.flakes()."""
    world = mpm.World((0, 0, -0.2), (4, 4, 3), 0.05, spin=spin, threads=threads, max_dt=2e-3)
    positions = mpm.flake_layer((2.0, 2.0, 2.5), (3.0, 3.0), 0.3, count, seed)
    world.add_particles(positions, mpm.flakes() if material is None else material, particle_volume=2e-6)
    world.set_wind(wind, velocity=(0.6, 0.2, 0.0), amplitude=1.5, wavelength=1.5, octaves=4, persistence=0.6,
                   drift=(0.4, 0.1), drag=10.0, ground=0.0, ref_height=2.0, exponent=0.4, seed=seed + 7)
    world.add_floor(0.0, contact="sticky")
    return Scene(world, fps, frames, None, "plain_flakes" if spin == 0 else "flakes")


def car_position(frame: int, fps: float = 24, speed: float = 3.0) -> Floats:
    """Where the car of car_collision is at a frame (it starts at x = 0.5 and drives along +x)."""
    return np.array([0.5 + speed * frame / fps, 1.25, 0.0])


def car_collision(spin: float = 1.0, count: int = 6000, seed: int = 0, threads: int = 0, fps: float = 24,
                  frames: int = 36, speed: float = 3.0) -> Scene:
    """A layer of flakes lies on the ground; a car drives through it along +x at ``speed`` m/s."""
    world = mpm.World((0, 0, -0.2), (4, 2.5, 1.6), 0.04, spin=spin, threads=threads, max_dt=2e-3)
    positions = mpm.flake_layer((2.3, 1.25, 0.1), (3.0, 1.8), 0.18, count, seed)
    world.add_particles(positions, mpm.flakes(), particle_volume=1.5e-5,
                        orientations=mpm.random_orientations(count, seed + 1))
    world.add_floor(0.0, friction=0.5)
    vertices, triangles = car_mesh()
    car = world.add_collider("mesh", "separate", 0.3, vertices=vertices, triangles=triangles,
                             translation=car_position(0, fps, speed))

    def drive(frame: int, world: mpm.World) -> None:
        world.move_collider(car, car_position(frame, fps, speed))

    return Scene(world, fps, frames, drive, "car")
