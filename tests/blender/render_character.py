"""The character's frame strip (issue 24): the hopping character at one frame as the armature alone poses it,
with OPDeform (Enable, Goal on, the "follow" group picked, defaults otherwise), with Blender's Soft Body (Goal
from "follow") and, in Blender 5.x, with the bundled Cloth Dynamics node group (pinned by "follow"), side by
side in one PNG, each panel labelled. Rendered headless with Cycles on the CPU (low samples, fixed seed):

    <python with bpy 5.2> tests/blender/render_character.py [--out PNG] [--frame F] [--samples N]
    blender -b --factory-startup --python-exit-code 1 -P tests/blender/render_character.py -- [OPTIONS]

`scripts/bench character --picture` runs it in bpy 5.2 and writes docs/images/character_strip.png (the
default --out). Soft Body and Cloth Dynamics simulate only in the window's scene, so each plays in a fresh
file of its own; every variant plays frames 1..F in order. $OPDEFORM_PYTHONPATH names the built module.
"""

import argparse
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.environ["OPDEFORM_PYTHONPATH"])
import character_measure as M  # noqa: E402
import character_scene as C  # noqa: E402
import helpers as H  # noqa: E402
from opdeform.blender_render import camera, material, setup_render  # noqa: E402

FRAME = 31  # the second hop's rise, a quarter second after the first landing
PANEL = (360, 480)
SAMPLES = 16
VARIANTS = ("armature only", "OPDeform", "Soft Body", "Cloth Dynamics")


def _scene_for(variant):
    """A fresh file with the character; the (scene, object) of the variant, None where the host lacks it."""
    H.fresh()
    obj = C.build()
    obj.data.materials.append(material("Character", (0.85, 0.45, 0.2)))
    bpy.data.objects["Floor"].data.materials.append(material("Floor", (0.8, 0.8, 0.78)))
    if variant == "OPDeform":
        C.enable(obj)
    elif variant == "Soft Body":
        C.soft_body(obj)
    elif variant == "Cloth Dynamics":
        if C.cloth_dynamics_group() is None:
            return None
        C.cloth_dynamics(obj)
    return bpy.context.scene, obj


def _label(scene, text):
    """The panel's title, in front of the camera at its bottom left."""
    font = bpy.data.objects.new("Label", bpy.data.curves.new("Label", 'FONT'))
    font.data.body, font.data.size = text, 0.09
    font.data.materials.append(material("Label", (0.02, 0.02, 0.02)))
    font.parent = scene.camera
    font.location = (-0.36, -0.55, -1.5)
    scene.collection.objects.link(font)


def _panel(variant, frame, samples, path):
    """Renders one variant at the frame to path; False where the host lacks the variant."""
    made = _scene_for(variant)
    if made is None:
        return False
    scene, obj = made
    for f in range(1, frame + 1):
        scene.frame_set(f)
    assert not obj.opdeform.error, obj.opdeform.error
    twin = C.armature_only(obj)
    shown = M.world_positions(twin, bpy.context.evaluated_depsgraph_get())  # frame the rig's pose
    lo, hi = shown.min(0), shown.max(0)
    bpy.data.objects.remove(twin)
    setup_render(scene, PANEL, samples)
    camera(scene, (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.45 * (lo[2] + hi[2])), (1.0, -0.45, 0.3),
           1.8 * (hi[2] - lo[2]))
    _label(scene, variant)
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return True


def _strip(paths, out):
    """The panels side by side in one PNG."""
    images = []
    for p in paths:
        img = bpy.data.images.load(p, check_existing=False)
        px = np.empty(img.size[0] * img.size[1] * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
        images.append(px.reshape(img.size[1], img.size[0], 4))
        bpy.data.images.remove(img)
    strip = np.concatenate(images, axis=1)
    img = bpy.data.images.new("Strip", strip.shape[1], strip.shape[0])
    img.pixels.foreach_set(strip.ravel())
    img.filepath_raw, img.file_format = out, 'PNG'
    img.save()


def main(argv):
    p = argparse.ArgumentParser()
    p.add_argument("--out", default=os.path.join(H.ROOT, "docs", "images", "character_strip.png"))
    p.add_argument("--frame", type=int, default=FRAME)
    p.add_argument("--samples", type=int, default=SAMPLES)
    args = p.parse_args(argv)
    paths = []
    for variant in VARIANTS:
        path = os.path.join(H.tmpdir(), f"character_{len(paths)}.png")
        if _panel(variant, args.frame, args.samples, path):
            paths.append(path)
        else:
            print(f"render: {variant} is not in {H.host()}: left out")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    _strip(paths, os.path.abspath(args.out))
    print(f"render: {args.out}: {len(paths)} panels, frame {args.frame}, {H.host()}, Cycles CPU, {args.samples} "
          "samples")
    H.cleanup()


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:])
