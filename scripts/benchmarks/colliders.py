"""Collision modifiers in Blender: Suzanne dropped on a sphere and on a ramp, opdeform with and without contact
and Soft Body, in one Blender run.

`scripts/bench colliders` starts Debian's Blender (one thread, `-t 1`) on this file. Inside it Suzanne
(subdivided once, 1,968 vertices, stiffness 1e6) falls 0.4 m onto a UV sphere (radius 1, 1,152 triangles) or a 30-degree
ramp (an 8 m grid, 512 triangles), each carrying a Collision modifier. Per collider, scenes of their own:
opdeform at 100 and 1,000 particles with Scene Colliders on (contact) and off (free fall), and Soft Body
(no goal, its default edges and collision) in the file's scene (Blender simulates Soft Body only there).
ms = process time of scene.frame_set (median of frames 2..48), wall ms = its wall time (a second table), solver
= the add-on's own sim.step time (the add-on measures wall time only).

Two passes in the one run. "Clips": Soft Body's 48 frames, then opdeform's variants clip by clip, three
rounds (each simulated anew; the median round). "Frames": every scene, Soft Body's too, interleaved frame by
frame. A frame of another scene between two of opdeform's slows the second: by 0.4-0.5 ms after a Soft Body
frame on this machine (Suzanne on the ramp at 100 particles: 1.13 ms a frame alone, 1.52-1.61 ms with Soft
Body's frames between, also where Soft Body has no collider and costs 7 ms: its work leaves the caches cold),
and by about 0.3 ms after a frame of the 1,000-particle variant; the clips keep that out, as a user plays one
scene. Printed: ms per frame, the contact / free ratio and Soft Body's ms over opdeform's in both passes (the
aim: >= 50x).
"""

import json
import os
import sys

HERE = os.path.abspath(__file__)
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
FRAMES = 48
ROUNDS = 3  # opdeform's clips, each variant's in turn
PARTICLES = (100, 1000)
STIFFNESS = 1e6  # Suzanne keeps its shape when it lands (1e5 flattens it)
SOFT_BODY = "Soft Body"


# -- inside Blender ------------------------------------------------------------------------------------------
def _collider(kind, scene):
    import helpers as H
    import suite_colliders
    return H.move_to(suite_colliders.collider(kind, name=f"{kind}_{scene.name}"), scene)


def suzanne(scene, kind):
    import math

    import helpers as H
    import numpy as np
    obj = H.monkey_in(scene, 1)
    if kind == "sphere":
        obj.location = (0.0, 0.0, 1.7)
    else:
        normal = np.array([math.sin(math.radians(30.0)), 0.0, math.cos(math.radians(30.0))])
        obj.location = tuple(normal * 0.7)
    return obj


def _opdeform(scene, kind, particles, contact):
    import bpy
    obj = suzanne(scene, kind)
    s = obj.opdeform
    s.particles, s.stiffness = particles, STIFFNESS
    obj.opdeform_contact.use_colliders = contact
    with bpy.context.temp_override(scene=scene):
        bpy.ops.opdeform.enable(object=obj.name)
    assert s.built and not s.error, s.error
    return obj


def soft_body(scene, kind):
    obj = suzanne(scene, kind)
    obj.modifiers.new("Softbody", 'SOFT_BODY')
    obj.soft_body.use_goal = False
    return obj


def _scenes(kind):
    """{label: (scene, object)} for one collider: opdeform's variants in scenes of their own, Soft Body in
    the window's scene."""
    import bpy
    import helpers as H
    H.fresh()
    out = {}
    for particles in PARTICLES:
        for contact in (True, False):
            scene = bpy.data.scenes.new(f"{kind} {particles} {'contact' if contact else 'free'}")
            _collider(kind, scene)
            out[(particles, contact)] = (scene, _opdeform(scene, kind, particles, contact))
    scene = bpy.context.scene
    _collider(kind, scene)
    out[SOFT_BODY] = (scene, soft_body(scene, kind))
    return out


def _clips(kind):
    """Soft Body's clip, then opdeform's variants clip by clip, ROUNDS times (each round simulates anew): per
    variant the median of its rounds."""
    import statistics

    import helpers as H
    scenes = _scenes(kind)
    out = H.play_interleaved({SOFT_BODY: scenes.pop(SOFT_BODY)}, FRAMES)
    rounds = {label: [] for label in scenes}
    for _ in range(ROUNDS):
        for label, (scene, obj) in scenes.items():
            H.runtime().get(obj).engine.invalidate()
            rounds[label].append(H.play_interleaved({label: (scene, obj)}, FRAMES)[label])
    for label, clips in rounds.items():
        out[label] = {key: statistics.median(c[key] for c in clips) for key in ("ms", "wall_ms", "solver_ms")}
    return out


def _inside_blender(out_path):
    import bpy
    import helpers as H
    result = {}
    for kind in ("sphere", "ramp"):
        result[kind] = {str(label): r for label, r in _clips(kind).items()}
        result[kind + " frames"] = {str(label): r for label, r in H.play_interleaved(_scenes(kind), FRAMES).items()}
    result["host"] = f"Blender {bpy.app.version_string}"
    with open(out_path, "w") as f:
        json.dump(result, f)
    print("COLLIDERS_BENCH", out_path)


# -- outside -------------------------------------------------------------------------------------------------
def _report(result):
    from .common import table
    rows, walls = [], []
    for kind in ("sphere", "ramp"):
        r, frames = result[kind], result[kind + " frames"]
        soft, soft_frames = r[SOFT_BODY]["ms"], frames[SOFT_BODY]["ms"]
        for particles in PARTICLES:
            on, off = r[str((particles, True))], r[str((particles, False))]
            on_frames = frames[str((particles, True))]
            rows.append((f"Suzanne on the {kind}, {particles} particles", f"{off['ms']:.2f}", f"{on['ms']:.2f}",
                         f"{on['ms'] / off['ms']:.2f}", f"{on['solver_ms'] / off['solver_ms']:.2f}",
                         f"{soft:.1f}", f"{soft / on['ms']:.0f}", f"{on_frames['ms']:.2f}", f"{soft_frames:.1f}",
                         f"{soft_frames / on_frames['ms']:.0f}"))
            walls.append((rows[-1][0], f"{off['wall_ms']:.2f}", f"{on['wall_ms']:.2f}", f"{on['solver_ms']:.2f}",
                          f"{r[SOFT_BODY]['wall_ms']:.1f}", f"{on_frames['wall_ms']:.2f}",
                          f"{frames[SOFT_BODY]['wall_ms']:.1f}"))
    print(result["host"], "(one process, -t 1; ms = process time of scene.frame_set; clips: Soft Body's, then "
          f"opdeform's clip by clip, median of {ROUNDS} rounds; frames: all interleaved)")
    table(rows, ["scene", "ms free", "ms contact", "contact/free", "solver contact/free", "Soft Body ms",
                 "Soft Body / opdeform", "frames: ms contact", "Soft Body ms", "Soft Body / opdeform"])
    print("\nthe same frames in wall time (ms; solver: the add-on's own sim.step time, which it measures in wall "
          "time only)")
    table(walls, ["scene", "wall ms free", "wall ms contact", "solver ms contact", "Soft Body wall ms",
                  "frames: wall ms contact", "Soft Body wall ms"])


def run(args):
    from .common import blender_json, out_dir
    result = blender_json(HERE, "COLLIDERS_BENCH", os.path.join(out_dir("colliders"), "colliders.json"))
    if result is not None:
        _report(result)


if __name__ == "__main__" and "--inside" in sys.argv:
    sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
    _inside_blender(sys.argv[sys.argv.index("--inside") + 1])
