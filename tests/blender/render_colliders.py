"""The documentation pictures of Collision modifiers (docs/blender.md, Collisions and force fields):

    scripts/blender -b --factory-startup -P tests/blender/render_colliders.py -- DIR

Suzanne (subdivided once, 100 particles) dropped on a UV sphere and on a 30-degree ramp, each with a Collision
modifier and nothing else set up; rendered with Cycles on the CPU (render_scenes.py's settings, 480 x 360)
at the frame where it rests on the sphere and halfway down the ramp: DIR/blender_collider_sphere.png and
DIR/blender_collider_ramp.png; and the same Suzanne with Blender's Soft Body (its defaults, no goal) on the
sphere at that frame, for the skin's rest beside Soft Body's: DIR/blender_collider_sphere_soft_body.png.
"""

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import helpers as H  # noqa: E402
import render_scenes as R  # noqa: E402
import suite_colliders as S  # noqa: E402

sys.path.insert(0, os.path.join(H.ROOT, "scripts"))
from benchmarks import colliders as B  # noqa: E402

SPHERE = dict(kind="sphere", frame=36, target=(0.0, 0.0, 1.0), direction=(1.0, -2.2, 0.5), distance=2.2)
SHOTS = {"sphere": dict(SPHERE, solver="opdeform"), "sphere_soft_body": dict(SPHERE, solver="soft body"),
         "ramp": dict(kind="ramp", solver="opdeform", frame=16, target=(0.6, 0.0, 0.0), direction=(0.3, -2.2, 0.8),
                      distance=3.5)}


def suzanne(scene, kind, solver):
    """Suzanne above the collider, deformed by OPDeform (stiffness as the colliders benchmark) or Soft Body."""
    if solver == "soft body":
        return B.soft_body(scene, kind)
    obj = B.suzanne(scene, kind)
    obj.opdeform.stiffness = B.STIFFNESS
    bpy.ops.opdeform.enable(object=obj.name)
    return obj


def shot(name, spec, out):
    H.fresh()
    scene = bpy.context.scene
    collider = S.collider(spec["kind"])
    collider.data.materials.append(R.material("Collider", (0.75, 0.75, 0.72)))
    obj = suzanne(scene, spec["kind"], spec["solver"])
    obj.data.materials.append(R.material("Suzanne", (0.85, 0.35, 0.2)))
    R.setup_render(scene, resolution=(480, 360), samples=32)
    R.camera(scene, spec["target"], spec["direction"], spec["distance"])
    for f in range(1, spec["frame"] + 1):
        scene.frame_set(f)
    assert not obj.opdeform.error, obj.opdeform.error
    scene.render.filepath = os.path.join(out, f"blender_collider_{name}.png")
    bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    target = sys.argv[sys.argv.index("--") + 1]
    for name, spec in SHOTS.items():
        shot(name, spec, target)
    print("render:", ", ".join(f"blender_collider_{k}.png" for k in SHOTS), "in", target)
    H.cleanup()
