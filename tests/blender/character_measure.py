"""How well OPDeform's result rides the character's animation (issue 24), measured frame by frame against the
armature-only pose of a twin without OPDeform (character_scene.armature_only):

- core: the largest distance of a vertex with follow >= 0.99 from its armature-only position (mm);
- ear, belly, tail: the same over the vertices of region_ear_tips, region_belly_front, region_tail_tip;
- stretch: the longest edge over its armature-only length;
- lowest: the lowest shown vertex above the floor (mm; negative: under it);
- settle: seconds after the motion stops (frame MOTION_END) until every vertex stays within 2 mm of the
  armature-only pose to the end of the clip (None: not within the clip);
- secondary: the loose parts' motion during the hops (frames 1..MOTION_END) around where they end up: the
  largest |offset(f) - offset(last frame)| of a region vertex, offset = shown - armature-only, as a share of
  the body's size (the rest mesh's largest bounding-box extent, 2.43 m);
- base: whether the mesh's own vertices are unchanged after the clip.
The largest over the clip's frames except where said. As a script, one row per setting:

    blender -b --factory-startup --python-exit-code 1 -P tests/blender/character_measure.py -- [OPTIONS]
    <python with bpy> tests/blender/character_measure.py [OPTIONS]

OPTIONS: --strengths 0.5 0.7 (goal strengths, each a row; default 0.5 0.7 0.9 1.0), --no-group (the follow
group not picked), --no-collision (the floor without its Collision modifier), --set NAME=VALUE (any
obj.opdeform property, e.g. --set particles=200; repeatable).
$OPDEFORM_PYTHONPATH names the built module's folder (tests/test_addon*.py and scripts/bench set it).
"""

import json
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import character_scene as C  # noqa: E402
import helpers as H  # noqa: E402

SETTLED = 2e-3  # m
CORE_FOLLOW = 0.99
HEADERS = ("setting", "core mm", "ear mm", "belly mm", "tail mm", "stretch", "lowest mm", "settle s",
           "secondary %", "base kept")


def world_positions(obj, depsgraph):
    """What obj shows in this depsgraph, in world space (float64)."""
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", out)
    ev.to_mesh_clear()
    m = np.array(ev.matrix_world)
    return out.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]


def _edges(mesh):
    e = np.empty(2 * len(mesh.edges), dtype=np.int64)
    mesh.edges.foreach_get("vertices", e)
    return e.reshape(-1, 2)


class Measure:
    """Frame by frame, one simulated character against its armature-only twin."""

    def __init__(self, obj, twin, floor_z=0.0):
        self.obj, self.twin, self.floor_z = obj, twin, floor_z
        self.core, self.regions = self.parts()
        self.loose = np.concatenate(list(self.regions.values()))
        self.edges = _edges(obj.data)
        self.base = H.base_positions(obj)
        rest = self.base @ np.array(obj.matrix_world)[:3, :3].T  # in world units (an object or rig scaled)
        self.size = float((rest.max(0) - rest.min(0)).max())
        self.frames, self.rows, self.offsets = [], [], []

    def parts(self):
        """(the core's vertex indices, {region: vertex indices}) from the character's painted groups."""
        groups = C.skin_weights(self.obj, ["follow"] + ["region_" + r for r in C.REGIONS])
        regions = {r: np.where(groups["region_" + r] > 0.0)[0] for r in C.REGIONS}
        return np.where(groups["follow"] >= CORE_FOLLOW)[0], regions

    def record(self, frame, shown, animated):
        """One frame: the character's and the twin's world positions (world_positions)."""
        d = np.linalg.norm(shown - animated, axis=1)
        a, b = self.edges.T
        stretch = np.linalg.norm(shown[a] - shown[b], axis=1) / np.linalg.norm(animated[a] - animated[b], axis=1)
        row = dict(core=d[self.core].max(), all=d.max(), stretch=stretch.max(),
                   lowest=shown[:, 2].min() - self.floor_z)
        row.update({r: d[i].max() for r, i in self.regions.items()})
        self.frames.append(frame)
        self.rows.append(row)
        self.offsets.append((shown - animated)[self.loose])

    def summary(self):
        """The figures over the frames recorded (see the module's docstring); lengths in metres."""
        col, common = self.common()
        return dict(common, ear=col["ear_tips"].max(), belly=col["belly_front"].max(), tail=col["tail_tip"].max())

    def common(self):
        """(each recorded figure by frame, the figures that do not name a region)."""
        col = {k: np.array([r[k] for r in self.rows]) for k in self.rows[0]}
        frames = np.array(self.frames)
        after = np.where(frames >= C.MOTION_END)[0]
        unsettled = [i for i in after if col["all"][i] > SETTLED]
        settle = None
        if not unsettled:
            settle = 0.0
        elif unsettled[-1] + 1 < len(frames):
            settle = (frames[unsettled[-1] + 1] - C.MOTION_END) / C.FPS
        hops = np.where(frames <= C.MOTION_END)[0]
        last = self.offsets[-1]
        secondary = max(np.linalg.norm(self.offsets[i] - last, axis=1).max() for i in hops)
        return col, dict(core=col["core"].max(), stretch=col["stretch"].max(), lowest=col["lowest"].min(),
                         settle_s=settle, secondary=secondary / self.size, size=self.size,
                         base_kept=bool(np.array_equal(H.base_positions(self.obj), self.base)),
                         settled_after_1s=bool(col["all"][after[C.FPS:]].max() <= SETTLED) if len(after) > C.FPS
                         else None)


def row(label, s):
    """A table row (HEADERS) of a summary."""
    return (label, f"{1e3 * s['core']:.1f}", f"{1e3 * s['ear']:.1f}", f"{1e3 * s['belly']:.1f}",
            f"{1e3 * s['tail']:.1f}", f"{s['stretch']:.2f}", f"{1e3 * s['lowest']:.1f}",
            "not in clip" if s["settle_s"] is None else f"{s['settle_s']:.2f}", f"{100 * s['secondary']:.1f}",
            "yes" if s["base_kept"] else "NO")


def print_table(rows, headers=HEADERS):
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) for i, h in enumerate(headers)]
    print("  ".join(str(h).ljust(w) for h, w in zip(headers, widths)))
    for r in rows:
        print("  ".join(str(c).ljust(w) for c, w in zip(r, widths)))


def play(measure, frames=range(1, C.FRAMES + 1)):
    """Plays the frames in the character's scene, recording each; the summary."""
    scene = measure.obj.users_scene[0]
    for f in frames:
        scene.frame_set(f)
        assert not measure.obj.opdeform.error, measure.obj.opdeform.error
        depsgraph = bpy.context.evaluated_depsgraph_get()
        measure.record(f, world_positions(measure.obj, depsgraph), world_positions(measure.twin, depsgraph))
    return measure.summary()


def shot(group=True, collision=True, **settings):
    """A fresh file with the character, its twin and OPDeform enabled with these settings (collision=False: the
    floor without its Collision modifier); the Measure."""
    H.fresh()
    obj = C.build()
    if not collision:
        bpy.data.objects["Floor"].modifiers.clear()
    twin = C.armature_only(obj)
    C.enable(obj, **(settings if group else dict(settings, goal_group="")))
    return Measure(obj, twin)


def _value(text):
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return {"True": True, "False": False}.get(text, text)


def main(argv):
    import argparse
    p = argparse.ArgumentParser()
    p.add_argument("--strengths", type=float, nargs="+", default=[0.5, 0.7, 0.9, 1.0])
    p.add_argument("--no-group", action="store_true")
    p.add_argument("--no-collision", action="store_true")
    p.add_argument("--set", action="append", default=[])
    args = p.parse_args(argv)
    settings = {k: _value(v) for k, v in (s.split("=", 1) for s in args.set)}
    rows = []
    for strength in args.strengths:
        m = shot(group=not args.no_group, collision=not args.no_collision, goal_strength=strength, **settings)
        s = play(m)
        label = f"goal {strength:g}" + (" no group" if args.no_group else "") + \
            (" no collision" if args.no_collision else "") + \
            "".join(f" {k}={v}" for k, v in settings.items())
        rows.append(row(label, s))
        print("CHARACTER_ROW " + json.dumps(dict(s, label=label, host=H.host())), flush=True)
    print(f"{H.host()}: the character ({len(m.base)} vertices, size {m.size:.2f} m), {C.FRAMES} frames")
    print_table(rows)
    H.cleanup()


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:])
