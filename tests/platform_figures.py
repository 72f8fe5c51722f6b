"""The physics figures of a few of the paper's scenes, printed as JSON (name -> [scene size in metres, values]):
tests/test_platforms.py runs this script on Linux (the build) and inside the Windows wheel under wine, and
compares the two to round-off. Not a test file itself: it imports nothing from tests/.

- fig1_bar: the 20-particle bar of Fig. 1 pinned at one end, 60 steps: positions, rotations, energy, tip sag
- twisted_bar: Fig. 2's bar, its end twisted and lifted over 30 steps: positions
- falling_body: Fig. 4's 100-particle body dropped on the floor, 60 steps: positions, lowest point
- skinning: 50 points of the bent bar skinned (linear-blend, 8 particles each)
- flakes: 200 MPM flakes (spin 1) in Perlin wind, 3 frames at 24 fps, one thread: positions, orientations"""

import json

import numpy as np

from opdeform import mpm_scenes, scenes


def bars():
    sim = scenes.fig1_bar()
    sim.step(60)
    points = np.random.default_rng(0).uniform([0.0, -0.1, -0.1], [2.0, 0.1, 0.1], (50, 3))
    bar = [sim.positions.ravel(), sim.rotations.ravel(), [sim.energy(), scenes.tip_sag(sim)]]
    twisted = scenes.TwistedBar()
    for step in range(30):
        twisted.animate(step / 30 * 2.0)
        twisted.sim.step(1)
    return {"fig1_bar": [scenes.BAR_LENGTH, np.concatenate(bar)],
            "twisted_bar": [scenes.BAR_LENGTH, twisted.sim.positions.ravel()],
            "skinning": [scenes.BAR_LENGTH, sim.skin_points(points, 8).ravel()]}


def body():
    sim = scenes.falling_body()
    sim.step(60)
    return {"falling_body": [1.0, np.append(sim.positions.ravel(), scenes.lowest_point(sim))]}


def flakes():
    scene = mpm_scenes.scattered_flakes(count=200, threads=1, frames=3)
    for _ in range(scene.frames):
        scene.world.step(1 / scene.fps)
    world = scene.world
    return {"flakes": [4.0, np.concatenate([world.positions.ravel(), world.orientations.ravel()])]}


if __name__ == "__main__":
    figures = {**bars(), **body(), **flakes()}
    print(json.dumps({name: [size, [float(v) for v in values]] for name, (size, values) in figures.items()}))
