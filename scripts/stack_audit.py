"""Issue 27's stacks as a new user sets them up in the add-on's panel, in either Blender host:

    OPDEFORM_PYTHONPATH=build/python blender -b --factory-startup --python-exit-code 1 -P scripts/stack_audit.py \
        -- [--presets Jelly,Flesh,Rubber,Stiff] [--cases spheres,small,suzannes,monkeys] [--until 13] [--render DIR] \
        [--friction MU]
    OPDEFORM_PYTHONPATH=build/python <python with the bpy module> scripts/stack_audit.py [same options]

Per preset (applied from the panel's menu, every other setting at the panel's defaults, the panel's Floor
ticked): "spheres", two 0.5 m UV spheres, the upper dropped 5 cm onto the lower resting on the Floor; "small", a
0.35 m UV sphere dropped 5 cm onto a 0.5 m one; "suzannes", a Suzanne (subdivided twice, as
tests/blender/suite_colliders.py's) dropped 1 m onto another; "monkeys", the same with Blender's Suzanne as added
(507 vertices). Prints one row per case: how far the upper's centre is aside of the lower's (m) at 3 s and at the
last second (UNTIL), how far above the lower's highest vertex it is then, its creep (how much the distance aside
changed over the last second, m/s), whether it stayed on top (its centre 0.2 m above that vertex every second from
3 s, as the suite's stack tests ask) and any error or NaN. --render DIR writes a Workbench still at the last second
of every case that ends off the top (DIR/stack_PRESET_CASE.png). --friction MU gives both bodies' Floor and their
contact with each other the Coulomb MU (the panel's Floor Friction MU, Object Friction 10 MU; its defaults: 0.5).
"""

import argparse
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "blender"))
import helpers as H  # noqa: E402
import suite_colliders as S  # noqa: E402

CASES = {"spheres": lambda preset: S.sphere_pair(True, preset, 0.5, 1.55),
         "small": lambda preset: S.sphere_pair(True, preset, 0.35, 1.4),
         "suzannes": lambda preset: S.suzanne_pair(True, preset),
         "monkeys": lambda preset: S.suzanne_pair(True, preset, levels=0)}
FIRST = 3  # s: from here the upper must be on top


def play(low, high, until):
    """Frames 1 to ``until`` s: {second: (aside, above)} each second from FIRST, whether the upper stayed on top,
    the first error or non-finite vertex (None when none)."""
    figures, on_top = {}, True
    bpy.context.scene.frame_end = until * H.FPS  # the add-on steps no frame past it
    for f in range(1, until * H.FPS + 1):
        bpy.context.scene.frame_set(f)
        error = low.opdeform.error or high.opdeform.error
        if error:
            return figures, False, error
        if f % H.FPS or f < FIRST * H.FPS:
            continue
        shown = S.world(low), S.world(high)
        if not all(np.isfinite(s).all() for s in shown):
            return figures, False, f"NaN at {f // H.FPS} s"
        figures[f // H.FPS] = S.stack_figures(*shown)[::-1]
        on_top = on_top and figures[f // H.FPS][1] > 0.2
    return figures, on_top, None


def set_friction(objects, mu):
    """Coulomb ``mu`` for the objects' Floor and their contact with each other (Object Friction is 10 mu)."""
    for obj in objects:
        obj.opdeform.floor_friction = mu
        obj.opdeform_contact.object_friction = 10.0 * mu


def still(path, low, high):
    """A Workbench render of the pair on a 6 m square (the Floor, drawn), the camera aimed at their middle from
    the side of the line between them."""
    from opdeform.blender_render import camera
    H.mesh_object("Ground", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], [(0, 1, 2, 3)])
    scene = bpy.context.scene
    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.render.resolution_x, scene.render.resolution_y = 480, 360
    lower, upper = S.world(low), S.world(high)
    apart = upper.mean(axis=0)[:2] - lower.mean(axis=0)[:2]  # look across the line between them
    side = (-apart[1], apart[0]) / np.linalg.norm(apart) if np.linalg.norm(apart) > 0.1 else (0.0, -1.0)
    camera(scene, tuple(np.concatenate([lower, upper]).mean(axis=0)), (*side, 0.45), 7.0)
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def header(until):
    return (f"{'host':<14}{'preset':<8}{'case':<10}{f'aside {FIRST} s':>10}{f'aside {until} s':>11}"
            f"{f'above {until} s':>11}{'creep':>7}  on top  error")


def row(host, preset, case, figures, on_top, error, until):
    """One line of the table ("-" for a second not reached)."""
    cells = [figures[s][0] if s in figures else None for s in (FIRST, until)]
    last = [figures[until][1], abs(figures[until][0] - figures[until - 1][0])] if until in figures else [None] * 2
    cells = ["-" if c is None else f"{c:.3f}" for c in cells + last]
    return (f"{host:<14}{preset:<8}{case:<10}{cells[0]:>10}{cells[1]:>11}{cells[2]:>11}{cells[3]:>7}  "
            f"{'yes' if on_top else 'NO':<6}  {error or ''}")


def main(argv):
    ap = argparse.ArgumentParser()
    ap.add_argument("--presets", default="Jelly,Flesh,Rubber,Stiff")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--until", type=int, default=13, help="the last second")
    ap.add_argument("--render", default=None)
    ap.add_argument("--friction", type=float, default=None,
                    help="Coulomb mu of both bodies' Floor and Object Friction (default: the panel's)")
    args = ap.parse_args(argv)
    host = ("Blender " if bpy.app.binary_path else "bpy ") + "%d.%d.%d" % tuple(bpy.app.version)
    print(header(args.until), flush=True)
    for preset in args.presets.split(","):
        for case in args.cases.split(","):
            H.fresh()
            low, high = CASES[case](preset)
            if args.friction is not None:
                set_friction((low, high), args.friction)
            figures, on_top, error = play(low, high, args.until)
            print(row(host, preset, case, figures, on_top, error, args.until), flush=True)
            if args.render and not on_top and not error:
                os.makedirs(args.render, exist_ok=True)
                still(os.path.join(args.render, f"stack_{preset}_{case}.png"), low, high)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:])
