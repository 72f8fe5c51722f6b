"""What passes a thin collider at one step a frame (docs/contact.md, "Shapes"). A 0.6 m blob (100 particles,
k = 3e4, its skin the contact shape) is dropped onto open table tops of 0.6, 1 and 2 m at z = 1 (friction 0.3)
from 0.1, 0.3 and 1.5 m at 24 and 60 fps, and thrown up against a 1 m top's underside (behind an open mesh's
faces: inside only in a slab behind them) at 2 and 4 m/s at 24, 60 and 240 fps, and dropped from 0.1, 0.3 and 1.5 m
onto a closed box top 0.6 m wide and 2 cm thick at 24, 60 and 240 fps; printed: how many of its particles end on the
other side of the top after 2 s (dropped) or 1 s (thrown). A few seconds.

    PYTHONPATH=build/python python3 scripts/thin_colliders.py
"""

import numpy as np

import opdeform
from opdeform import meshes


def blob():
    v, t = meshes.capsule(radius=0.2, length=0.2)  # 0.6 x 0.4 x 0.4 m
    g = opdeform.Graph.from_mesh(v, t, particles=100)
    return v, g, opdeform.Skin(g, v)


def on_the_other_side(body, size, fps, lift, speed, seconds, box=False):
    """The particles on the far side of a size x size open top at z = 1 (box: a closed top 2 cm thick below it)
    after the seconds: the blob placed lift m above it (its lowest point) and falling, or below it (lift < 0: its
    highest point) and thrown up at speed."""
    v, g, skin = body
    sim = opdeform.Simulation(g, 3e4, dt=1 / fps)
    place = 1.01 + lift - v[:, 2].min() if lift > 0 else 1.0 + lift - v[:, 2].max()
    velocity = np.tile((0.0, 0.0, speed), (g.n_particles, 1))
    sim.set_state(g.centers + (0.0, 0.0, place), np.tile(np.eye(3), (g.n_particles, 1, 1)), velocities=velocity)
    if box:
        sim.add_collider("box", half_extents=(size / 2, size / 2, 0.01), translation=(0.0, 0.0, 0.99), friction=0.3)
    else:
        sv, st = meshes.sheet((size, size), (8, 8))
        sim.add_collider("mesh", vertices=sv + (0.0, 0.0, 1.0), triangles=st, friction=0.3)
    sim.set_contact_skin(skin)
    sim.step(int(seconds * fps))
    z = sim.positions[:, 2]
    return int((z < 0.99).sum() if lift > 0 else (z > 1.0).sum())


def main():
    body = blob()
    print("dropped onto an open top: particles below it after 2 s (of 100)")
    print("| top | " + " | ".join(f"{d} m, {fps} fps" for d in (0.1, 0.3, 1.5) for fps in (24, 60)) + " |")
    for size in (0.6, 1.0, 2.0):
        counts = [on_the_other_side(body, size, fps, d, 0.0, 2) for d in (0.1, 0.3, 1.5) for fps in (24, 60)]
        print(f"| {size} m | " + " | ".join(str(c) for c in counts) + " |")
    print("thrown up against a 1 m open top's underside: particles above it after 1 s (of 100)")
    for fps in (24, 60, 240):
        counts = [on_the_other_side(body, 1.0, fps, -0.35, speed, 1) for speed in (2.0, 4.0)]
        print(f"{fps} fps: 2 m/s {counts[0]}, 4 m/s {counts[1]}")
    print("dropped onto a closed 0.6 m box top 2 cm thick: particles below it after 2 s at 24 / 60 / 240 fps")
    for d in (0.1, 0.3, 1.5):
        counts = [on_the_other_side(body, 0.6, fps, d, 0.0, 2, box=True) for fps in (24, 60, 240)]
        print(f"{d} m: " + " / ".join(str(c) for c in counts))


if __name__ == "__main__":
    main()
