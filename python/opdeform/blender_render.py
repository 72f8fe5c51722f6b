"""Runs inside Blender for ``opdeform.render`` (not imported by the package outside Blender):

    blender -b --factory-startup --disable-autoexec [FILE.blend] --python-exit-code 1 -P blender_render.py -- JOB

JOB (JSON): ``pc2`` (the baked shot), ``frames`` to render, ``out`` (PNG files ``NAME_FRAME.png``), ``name``;
``object`` (a .blend shot: that object of the open file, its opdeform modifiers replaced by a Mesh Cache
modifier reading the PC2, the file's camera and lights kept) or ``mesh`` (an .npz of vertices and triangles:
a scene made here, framed by ``bounds``, with a floor at ``floor``). Cycles on the CPU with a fixed seed and
sample count and no denoiser (``setup_render``), what tests/blender/render_scenes.py uses too. No add-on is
needed: the Mesh Cache modifier plays the PC2.
"""

import json
import math
import sys
from collections.abc import Sequence
from typing import Any

import bpy
import numpy as np
from mathutils import Vector

RESOLUTION = (160, 120)
SAMPLES = 16
SEED = 0


def material(name: str, color: Sequence[float], alpha: float = 1.0) -> Any:
    """A Principled material of a colour (and alpha)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.6
    if alpha < 1.0:
        bsdf.inputs["Alpha"].default_value = alpha
        if hasattr(mat, "blend_method"):
            mat.blend_method = 'BLEND'
    return mat


def cycles(scene: Any, resolution: tuple[int, int] = RESOLUTION, samples: int = SAMPLES) -> None:
    """Reproducible Cycles settings: CPU, fixed seed and samples, no denoiser, no adaptive sampling, PNG."""
    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.samples = samples
    scene.cycles.seed = SEED
    scene.cycles.use_denoising = False
    if hasattr(scene.cycles, "use_adaptive_sampling"):
        scene.cycles.use_adaptive_sampling = False
    scene.cycles.max_bounces = 4
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'PNG'
    scene.render.image_settings.color_mode = 'RGB'
    scene.render.threads_mode = 'FIXED'
    scene.render.threads = 2


def lights(scene: Any) -> None:
    """A grey-blue world and a sun."""
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.55, 0.6, 0.7, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = 3.0
    sun.data.angle = math.radians(10)
    sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
    scene.collection.objects.link(sun)


def setup_render(scene: Any, resolution: tuple[int, int] = RESOLUTION, samples: int = SAMPLES) -> None:
    """Cycles settings, world and sun of the regression renders."""
    cycles(scene, resolution, samples)
    lights(scene)


def camera(scene: Any, target: Sequence[float], direction: Sequence[float], distance: float,
           lens: float = 35) -> None:
    """The scene's camera at ``target + distance * direction``, looking at ``target``."""
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = lens
    d = Vector(direction).normalized()
    cam.location = Vector(target) + d * distance
    cam.rotation_euler = (-d).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam


def mesh_object(scene: Any, name: str, vertices: Sequence[Sequence[float]], faces: Sequence[Sequence[int]]) -> Any:
    """A new mesh object linked to the scene."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, v)) for v in vertices], [], [tuple(map(int, f)) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def mesh_cache(obj: Any, pc2: str, start: float, index: int | None = None) -> None:
    """A Mesh Cache modifier playing ``pc2`` from frame ``start`` (the add-on's axes), at ``index`` in the stack."""
    mod = obj.modifiers.new("Baked Shot", 'MESH_CACHE')
    mod.cache_format, mod.filepath, mod.frame_start = 'PC2', pc2, start
    mod.time_mode, mod.play_mode, mod.deform_mode = 'FRAME', 'SCENE', 'OVERWRITE'
    mod.forward_axis, mod.up_axis = 'POS_Y', 'POS_Z'
    if index is not None:
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=index)


def blend_scene(scene: Any, job: dict[str, Any]) -> None:
    """The .blend shot's object plays the PC2 where its opdeform modifiers were; lights when the file has none."""
    obj = bpy.data.objects[job["object"]]
    ours = [k for k, m in enumerate(obj.modifiers) if m.name.startswith("OPDeform")]
    for k in reversed(ours):
        obj.modifiers.remove(obj.modifiers[k])
    mesh_cache(obj, job["pc2"], job["start"], ours[0] if ours else 0)
    if scene.camera is None:
        frame_camera(scene, job["bounds"])
    if scene.world is None or not any(o.type == 'LIGHT' for o in scene.objects):
        lights(scene)


def mesh_scene(job: dict[str, Any]) -> None:
    """A new scene for a mesh shot: the mesh playing the PC2, a floor when the shot has one, camera, lights."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    data = np.load(job["mesh"])
    obj = mesh_object(scene, job["name"], data["vertices"], data["triangles"])
    obj.data.materials.append(material("Shot", (0.85, 0.35, 0.12)))
    mesh_cache(obj, job["pc2"], job["start"])
    lo, hi = np.array(job["bounds"])
    if job["floor"] is not None:
        s = 4 * float(np.linalg.norm(hi - lo))
        c, z = (lo + hi) / 2, job["floor"]
        floor = mesh_object(scene, "Floor", [(c[0] - s, c[1] - s, z), (c[0] + s, c[1] - s, z),
                                             (c[0] + s, c[1] + s, z), (c[0] - s, c[1] + s, z)], [(0, 1, 2, 3)])
        floor.data.materials.append(material("Floor", (0.8, 0.8, 0.78)))
    frame_camera(scene, job["bounds"])
    lights(scene)


def frame_camera(scene: Any, bounds: Sequence[Sequence[float]]) -> None:
    """A camera looking at the box ``bounds`` (every baked frame) from the front right, above."""
    lo, hi = np.array(bounds)
    camera(scene, (lo + hi) / 2, (1.0, -1.6, 0.7), 1.3 * float(np.linalg.norm(hi - lo)) + 1e-3)


def main(job: dict[str, Any]) -> None:
    if job.get("object"):
        blend_scene(bpy.context.scene, job)
    else:
        mesh_scene(job)
    scene = bpy.context.scene
    cycles(scene)
    for frame in job["frames"]:
        scene.frame_set(frame)
        scene.render.filepath = f"{job['out']}/{job['name']}_{frame:04d}.png"
        bpy.ops.render.render(write_still=True)
        print(f"OPDEFORM_RENDERED {frame}", flush=True)


if __name__ == "__main__":
    with open(sys.argv[sys.argv.index("--") + 1]) as f:
        main(json.load(f))
