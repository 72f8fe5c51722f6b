"""The colliders benchmark's Suzanne replayed without Blender (docs/contact.md, "Cost").

Inside Debian's Blender, the benchmark's own scene (scripts/benchmarks/colliders.py: Suzanne with contact on the
sphere or the ramp, 1,000 particles or PARTICLES) is stepped to frame 2 and its simulation pickled:

    OPDEFORM_PYTHONPATH=$PWD/build/python scripts/blender -b --factory-startup -t 1 -P scripts/colliders_replay.py \
        -- --dump ramp /tmp/ramp1000.pkl [PARTICLES]

then, with any build (builds compared one after another, in turns):

    PYTHONPATH=build/python python3 scripts/colliders_replay.py /tmp/ramp1000.pkl

prints the median process time of its 47 steps with and without the collider (best of 3 each), the local step's
SVD fallbacks, the mean centre, a hash of the positions and rotations after each step with contact (equal hashes:
the same trajectory), and (--slide, the ramp) the centre of mass's speed along and across the ramp.

`--once contact|free` steps the 47 steps once, with the collider or without, and prints the state's hash alone:
the run to count under callgrind (docs/contact.md, "Cost"; the real interpreter, not a pyenv shim):

    PYTHONPATH=build/python valgrind --tool=callgrind --toggle-collect='od_Sim_Step*' \
        $(python3 -c 'import sys; print(sys.executable)') scripts/colliders_replay.py /tmp/ramp1000.pkl --once free
"""

import hashlib
import math
import os
import pickle
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STEPS = 47


def dump(kind, path, particles=1000):
    sys.path[:0] = [os.path.join(ROOT, "tests", "blender"), os.path.join(ROOT, "scripts")]
    import bpy
    import helpers
    from benchmarks import colliders
    scene, obj = colliders._scenes(kind)[(particles, True)]
    with bpy.context.temp_override(scene=scene):
        scene.frame_set(1)
        scene.frame_set(2)
    with open(path, "wb") as f:
        pickle.dump(helpers.runtime().get(obj).engine.sim, f)


def replay(path, collide):
    """(median ms a step, the simulation after the steps, digest of the states after each step)."""
    with open(path, "rb") as f:
        sim = pickle.load(f)
    if not collide:
        for cid in list(sim._colliders):
            sim.remove_collider(cid)
    times, digest = [], hashlib.sha256()
    for _ in range(STEPS):
        t = time.process_time()
        sim.step()
        times.append(time.process_time() - t)
        for a in (sim.positions, sim.rotations):
            digest.update(np.ascontiguousarray(a).tobytes())
    return np.median(times) * 1e3, sim, digest.hexdigest()[:16]


def slide(path):
    """The centre of mass's velocity along the ramp (down) and along its normal, every third step."""
    with open(path, "rb") as f:
        sim = pickle.load(f)
    a = math.radians(30.0)
    down, normal = np.array([math.cos(a), 0.0, -math.sin(a)]), np.array([math.sin(a), 0.0, math.cos(a)])
    speeds = []
    for k in range(STEPS):
        sim.step()
        v = sim.velocities.mean(axis=0)
        speeds += [f"{k}: {v @ down:.2f} / {v @ normal:.2f}"] if k % 3 == 2 else []
    print("m/s along / across the ramp by step:", ", ".join(speeds))


def main():
    path = sys.argv[1]
    free = min(replay(path, False)[0] for _ in range(3))
    contact = min(replay(path, True)[0] for _ in range(3))
    _, sim, state = replay(path, True)
    print(f"load {os.getloadavg()[0]:.2f}: free {free:.3f} ms, contact {contact:.3f} ms a step, ratio "
          f"{contact / free:.2f}, SVD fallbacks {sim.counters['polar_fallbacks']}, centre {sim.positions.mean(0)}, "
          f"state {state}")
    if "--slide" in sys.argv:
        slide(path)


if __name__ == "__main__":
    if "--dump" in sys.argv:
        args = sys.argv[sys.argv.index("--dump") + 1:]
        dump(args[0], args[1], *map(int, args[2:3]))
    elif "--once" in sys.argv:
        print("state", replay(sys.argv[1], sys.argv[sys.argv.index("--once") + 1] == "contact")[2])
    else:
        main()
