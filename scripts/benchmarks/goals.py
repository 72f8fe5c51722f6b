"""Same-scene comparison inside Blender: the armature-swung tail with opdeform's goal, Soft Body's Goal, plain.

`scripts/bench goals [--png PATH]` starts Debian's Blender (one thread, `-t 1`) on this file. Inside it builds
the shot of docs/blender.md (a 2 m tail, 525 vertices, skinned to a 2-bone armature whose root bone swings 60
degrees about z in 0.5 s and stops, gravity off) once per variant, each variant in its own scene sharing the
one armature: the plain animation; opdeform at goal strengths 0.2, 0.5 and 1 (20 chain particles, stiffness
1e6) and at 0.5 with a Subdivision (2 levels) after OPDeform; Soft Body after the Armature with its goal
weights from a vertex group (1 at the root to 0.5 at the tip), at Blender's default goal stiffness 0.5 and
damping 0 and at a softer 0.1. Every frame steps every scene in turn (interleaved), timing each
`scene.frame_set` in process time and in wall time. Then the creature scene (opdeform.meshes.creature(), 100
particles, floor) twice in one scene, goal off and goal 0.5: the solver's time per frame from the add-on's own timings (wall
time, as are the handler's: the add-on measures no other).

Per variant: ms per frame (median of frames 2..144) and its ratio to the plain animation's frame, the tip's
largest distance from the animated tip during the swing (lag), its largest angle past 60 degrees after the
swing (overshoot), and the first frame from which every vertex stays within 1e-3 of the tail's length of the
animation (settle). The plot of the tip angles goes to out/bench/goals/goal_tail.png (or --png).
"""

import json
import math
import os
import statistics
import sys
import time

HERE = os.path.abspath(__file__)
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
SECONDS = 6
LENGTH = 2.0
SOFT_BODY = (("Soft Body, goal stiffness 0.5 (default)", 0.5), ("Soft Body, goal stiffness 0.1", 0.1))
OPDEFORM = (("opdeform, goal 0.2", 0.2, 0), ("opdeform, goal 0.5", 0.5, 0), ("opdeform, goal 1", 1.0, 0),
            ("opdeform, goal 0.5 + Subdivision 2 after", 0.5, 2))
PLAIN = "animation (Armature only)"


# -- inside Blender ------------------------------------------------------------------------------------------
def _variant_scene(name, tail, rig):
    """A scene holding the shared armature and a copy of the tail (its own mesh); returns (scene, copy)."""
    import bpy
    scene = bpy.data.scenes.new(name)
    scene.use_gravity, scene.render.fps, scene.frame_end = False, 24, SECONDS * 24
    scene.collection.objects.link(rig)
    copy = tail.copy()
    copy.data = tail.data.copy()
    scene.collection.objects.link(copy)
    return scene, copy


def _plain(obj):
    import bpy
    bpy.ops.opdeform.disable(object=obj.name)
    obj.opdeform.enabled = False


def _soft_body(obj, goal_spring):
    """Soft Body after the Armature, goal weights from the vertex group "Goal" (1 at the root, 0.5 at the tip),
    goal damping at its default 0, no gravity."""
    _plain(obj)
    group = obj.vertex_groups.new(name="Goal")
    for v in obj.data.vertices:
        group.add([v.index], 1.0 - 0.25 * v.co.x, 'REPLACE')
    obj.modifiers.new("Softbody", 'SOFT_BODY')
    sb = obj.soft_body
    sb.use_goal, sb.vertex_group_goal, sb.goal_spring = True, "Goal", goal_spring
    sb.effector_weights.gravity = 0.0


def _opdeform(obj, strength, levels):
    obj.opdeform.goal_strength = strength
    if levels:
        obj.modifiers.new("Subdivision", 'SUBSURF').levels = levels


def _shown(obj, scene):
    import numpy as np
    mesh = obj.evaluated_get(scene.view_layers[0].depsgraph).data
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", out)
    return out.reshape(-1, 3)


def _tail_scenes(H):
    """{label: (scene, tail)}: the plain animation and opdeform's variants in scenes of their own, Soft Body at
    its default goal stiffness in the file's scene (Blender simulates Soft Body only in the active depsgraph,
    so the softer setting plays there afterwards, see _inside_blender)."""
    import bpy
    H.fresh()
    tail = H.tail_rig(0.5)
    rig = bpy.data.objects["Rig"]
    scenes = {PLAIN: _variant_scene(PLAIN, tail, rig)}
    _plain(scenes[PLAIN][1])
    for label, strength, levels in OPDEFORM:
        scenes[label] = _variant_scene(label, tail, rig)
        _opdeform(scenes[label][1], strength, levels)
    _soft_body(tail, SOFT_BODY[0][1])
    scenes[SOFT_BODY[0][0]] = (bpy.context.scene, tail)
    return scenes


def _metrics(H, paths):
    """Lag, overshoot and settle frame of each variant's vertex paths against the plain animation's."""
    import numpy as np
    anim = paths[PLAIN]
    n = len(anim[0])
    tip = int(np.argmin(np.linalg.norm(anim[0] - (LENGTH, 0.0, 0.0), axis=1)))
    out = {}
    for label, frames in paths.items():
        shown = [f[:n] for f in frames]  # a Subdivision after OPDeform keeps the mesh's vertices first
        angle = np.degrees([math.atan2(f[tip, 1], f[tip, 0]) for f in shown])
        deviation = np.array([np.linalg.norm(s - a, axis=1).max() for s, a in zip(shown, anim)])
        lag = [float(np.linalg.norm(s[tip] - a[tip])) for s, a in zip(shown, anim)]
        out[label] = dict(angle=angle.tolist(), lag_m=max(lag[:H.SWING_FRAMES + 1]),
                          overshoot_deg=float((angle[H.SWING_FRAMES:] - 60.0).max()),
                          settle_frame=next((i + 1 for i in range(len(deviation))
                                             if deviation[i:].max() < 1e-3 * LENGTH), None))
    return out


def _play_interleaved(scenes, runtime):
    """Steps every scene through every frame in turn; per variant the process times and wall times (s) of
    scene.frame_set, handler times (s, opdeform only) and the shown vertices per frame."""
    times = {label: [] for label in scenes}
    walls = {label: [] for label in scenes}
    handler = {label: [] for label in scenes}
    paths = {label: [] for label in scenes}
    for f in range(1, SECONDS * 24 + 1):
        for label, (scene, obj) in scenes.items():
            t, wall = time.process_time(), time.perf_counter()
            scene.frame_set(f)
            times[label].append(time.process_time() - t)
            walls[label].append(time.perf_counter() - wall)
            assert not obj.opdeform.error, (label, obj.opdeform.error)
            rt = runtime.get(obj)
            if rt is not None:
                handler[label].append(rt.timing.get("total", 0.0))
            paths[label].append(_shown(obj, scene).copy() if rt is None else rt.engine.out.copy())
    return times, walls, handler, paths


def _creature_goal_cost(H):
    """Solver ms per frame of the creature with the goal off and at 0.5, side by side in one scene."""
    import bpy
    H.fresh()
    od = H.runtime().module()
    v, t = od.meshes.creature()
    objs = []
    for name, use_goal in (("NoGoal", False), ("Goal", True)):
        obj = H.mesh_object(name, v, t, location=(0.0, 0.0, 0.5))
        s = obj.opdeform
        s.use_floor, s.stiffness, s.use_goal, s.goal_strength = True, 2e5, use_goal, 0.5
        bpy.ops.opdeform.enable(object=obj.name)
        objs.append(obj)
    solver = {o.name: [] for o in objs}
    for f in range(1, 62):
        bpy.context.scene.frame_set(f)
        for o in objs:
            if f > 1:
                solver[o.name].append(H.runtime().get(o).timing["solver"])
    return {k: 1e3 * statistics.median(v) for k, v in solver.items()}


def _measure(H, scenes, result):
    """Plays the scenes interleaved; adds each one's figures to result (ms per frame and its ratio to the
    plain animation's in the same pass)."""
    times, walls, handler, paths = _play_interleaved(scenes, H.runtime())
    result.update(_metrics(H, paths))
    plain_ms = statistics.median(times[PLAIN][1:])
    for label, (scene, obj) in scenes.items():
        ms = statistics.median(times[label][1:])
        result[label].update(ms=1e3 * ms, wall_ms=1e3 * statistics.median(walls[label][1:]), ratio=ms / plain_ms,
                             vertices_shown=len(_shown(obj, scene)),
                             handler_ms=1e3 * statistics.median(handler[label][1:]) if handler[label] else None)


def _inside_blender(out_path):
    import bpy
    sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
    import helpers as H
    scenes = _tail_scenes(H)
    result = {}
    _measure(H, scenes, result)
    label, spring = SOFT_BODY[1]  # the softer Soft Body: the same object, another pass against the plain one
    scene, tail = scenes.pop(SOFT_BODY[0][0])
    tail.soft_body.goal_spring = spring
    scene.frame_set(1)
    _measure(H, {PLAIN: scenes[PLAIN], label: (scene, tail)}, result)
    result["creature_solver_ms"] = _creature_goal_cost(H)
    result["host"] = f"Blender {bpy.app.version_string}"
    with open(out_path, "w") as f:
        json.dump(result, f)
    print("GOALS_BENCH", out_path)


# -- outside -------------------------------------------------------------------------------------------------
def _plot(result, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.2, 3.6), dpi=100)
    t = [i / 24.0 for i in range(1, SECONDS * 24 + 1)]
    ax.plot(t, result[PLAIN]["angle"], "k--", lw=1, label=PLAIN)
    styles = {OPDEFORM[0][0]: "tab:red", OPDEFORM[1][0]: "tab:blue", OPDEFORM[2][0]: "tab:green",
              SOFT_BODY[0][0]: "tab:purple", SOFT_BODY[1][0]: "tab:orange"}
    for label, color in styles.items():
        ax.plot(t, result[label]["angle"], color=color, lw=1.2, ls=":" if "Soft" in label else "-", label=label)
    ax.set(xlabel="time (s)", ylabel="tip angle (degrees)", xlim=(0, 4),
           title="2 m tail, root bone swings 60° in 0.5 s and stops (Blender 3.4)")
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(png)


def _report(result):
    from .common import table
    rows = []
    for label in [PLAIN] + [o[0] for o in OPDEFORM] + [s[0] for s in SOFT_BODY]:
        r = result[label]
        settle = "not in 6 s" if r["settle_frame"] is None else f"{r['settle_frame']} ({r['settle_frame'] / 24:.1f} s)"
        handler = "" if r["handler_ms"] is None else f"{r['handler_ms']:.2f}"
        rows.append((label, r["vertices_shown"], f"{r['ms']:.2f}", f"{r['wall_ms']:.2f}", f"{r['ratio']:.2f}",
                     handler, f"{r['lag_m']:.3g}", f"{r['overshoot_deg']:.1f}", settle))
    print(result["host"], "(one process, -t 1, frames interleaved; ms = process time of scene.frame_set, wall ms its "
          "wall time; handler ms: the add-on's own timing, wall)")
    table(rows, ["variant", "vertices", "ms/frame", "wall ms", "x plain", "handler ms", "tip lag m", "overshoot deg",
                 "settled (frame)"])
    c = result["creature_solver_ms"]
    print(f"creature, solver ms per frame (the add-on's own timing, wall): goal off {c['NoGoal']:.2f}, goal 0.5 "
          f"{c['Goal']:.2f} ({c['Goal'] / c['NoGoal']:.2f}x)")


def run(args):
    from .common import blender_json, out_dir
    png = args[args.index("--png") + 1] if "--png" in args else os.path.join(out_dir("goals"), "goal_tail.png")
    data = os.path.join(out_dir("goals"), "goals.json")
    result = blender_json(HERE, "GOALS_BENCH", data)
    if result is None:
        return
    _report(result)
    _plot(result, png)
    print("plot:", png)


if __name__ == "__main__" and "--inside" in sys.argv:
    _inside_blender(sys.argv[sys.argv.index("--inside") + 1])
