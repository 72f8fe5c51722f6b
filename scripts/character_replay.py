"""The character benchmark's 1,000-particle creature replayed without Blender (docs/speed.md, "The 60 fps aim").

Inside Debian's Blender, `scripts/bench character`'s scene (tests/blender/character_scene.py: the creature on its
floor, Goal on, 1,000 particles) is played to frame 1, its simulation pickled, and every call the add-on makes on
it over the next frames that changes it (set_goals, step, the colliders' moves ...) recorded with its arguments:

    OPDEFORM_PYTHONPATH=$PWD/build/python OMP_NUM_THREADS=1 scripts/blender -b --factory-startup -t 1 \
        -P scripts/character_replay.py -- --dump /tmp/creature1000.pkl

then, with any build (builds compared one after another, in turns):

    PYTHONPATH=build/python OMP_NUM_THREADS=1 python3 scripts/character_replay.py /tmp/creature1000.pkl

replays the calls (best of 3 rounds) and prints the median process time of a frame's steps, the iterations a
step, and a hash of the positions and rotations after each frame (equal hashes: the same trajectory).
"""

import hashlib
import os
import pickle
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FRAMES = 48
PARTICLES = 1000
CHANGES = ("set_", "add_", "move_", "update_", "remove_", "clear_")


def _recorder(sim, calls):
    """Each changing method of ``sim`` wrapped to append (frame, name, args, kwargs) to ``calls``."""
    frame = [1]
    for name in dir(type(sim)):
        attr = getattr(type(sim), name)
        if callable(attr) and (name == "step" or name.startswith(CHANGES)):
            def wrapped(*args, _name=name, _method=getattr(sim, name), **kwargs):
                calls.append((frame[0], _name, pickle.loads(pickle.dumps(args)), kwargs))
                return _method(*args, **kwargs)
            setattr(sim, name, wrapped)
    return frame


def dump(path):
    sys.path[:0] = [os.path.join(ROOT, "tests", "blender")]
    import bpy
    import character_scene as C
    import helpers as H
    H.fresh()
    scene, obj = C.variant_scene("opdeform", C.build())
    C.enable(obj, particles=PARTICLES)
    with bpy.context.temp_override(scene=scene):
        scene.frame_set(1)
        sim = H.runtime().get(obj).engine.sim
        start = pickle.dumps(sim)
        calls = []
        frame = _recorder(sim, calls)
        for f in range(2, FRAMES + 2):
            frame[0] = f
            scene.frame_set(f)
    assert sum(name == "step" for _, name, _, _ in calls) == FRAMES, [c[1] for c in calls]
    with open(path, "wb") as f:
        pickle.dump({"start": start, "calls": calls}, f)
    print("dumped", path, len(calls), "calls")


def replay(recorded):
    """(process seconds of each frame's steps, iterations a step, digest of the states after each frame)."""
    sim = pickle.loads(recorded["start"])
    times, iterations, digest = [], [], hashlib.sha256()
    for _, name, args, kwargs in recorded["calls"]:
        if name != "step":
            getattr(sim, name)(*args, **kwargs)
            continue
        t = time.process_time()
        sim.step(*args, **kwargs)
        times.append(time.process_time() - t)
        report = sim.step_report
        iterations.append(report["iterations"] / report["steps"])
        for a in (sim.positions, sim.rotations):
            digest.update(np.ascontiguousarray(a).tobytes())
    return times, iterations, digest.hexdigest()[:16]


def main(path):
    with open(path, "rb") as f:
        recorded = pickle.load(f)
    rounds = [replay(recorded) for _ in range(3)]
    best = min(rounds, key=lambda r: np.median(r[0]))
    steps = sum(name == "step" for _, name, _, _ in recorded["calls"])
    print(f"{steps} frames: {1e3 * np.median(best[0]):.3f} ms a frame (median, best of 3), "
          f"iterations {np.mean(best[1]):.2f}, state {best[2]}")


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    if argv[0] == "--dump":
        dump(argv[1])
    else:
        main(argv[0])
