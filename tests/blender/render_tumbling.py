"""Renders the seed's two tumbling-particle scenes from the PLY frames scripts/demo_mpm.py wrote (inside
Debian's Blender, headless; run by demo_mpm.run):

    blender -b --factory-startup --python-exit-code 1 -P render_tumbling.py -- DEMO_DIR

DEMO_DIR holds flakes/, plain_flakes/ and car/ (PLY frames). Each chosen frame becomes DEMO_DIR/<scene>_<frame>.png:
the frames go onto a point cloud through the add-on (orientation attribute + Instance on Points of the
add-on's snowflake), with a ground, the car of the car scene, a sun and Cycles on the CPU (400 x 300, 16
samples, no denoiser). Prints "render: <png>" per image.
"""

import glob
import importlib
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import helpers as H  # noqa: E402

SCENES = {"flakes": (18, 36, 54), "plain_flakes": (18, 36, 54), "car": (8, 16, 24)}


def _material(name, color, emission=0.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    if emission and "Emission Strength" in bsdf.inputs:
        bsdf.inputs["Emission"].default_value = (*color, 1.0)
        bsdf.inputs["Emission Strength"].default_value = emission
    return mat


def _stage(name, target, distance):
    scene = bpy.context.scene
    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 400, 300
    world = bpy.data.worlds.new(name)
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.35, 0.45, 0.6, 1.0)
    scene.world = world
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.rotation_euler = (0.6, 0.3, 0.8)
    scene.collection.objects.link(sun)
    ground = H.mesh_object("Ground", [(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)], [(0, 1, 2, 3)])
    ground.data.materials.append(_material("Ground", (0.04, 0.05, 0.07)))
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (target[0] + 0.2 * distance, target[1] - distance, target[2] + 0.45 * distance)
    direction = [t - c for t, c in zip(target, cam.location)]
    from mathutils import Vector
    cam.rotation_euler = Vector(direction).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam


def render(demo_dir):
    H.fresh()
    tumbling = importlib.import_module(H.ADDON + ".blender.tumbling_runtime")
    cloud = importlib.import_module(H.ADDON + ".blender.point_cloud")
    mpm = tumbling.mpm()
    scenes = importlib.import_module(mpm.__name__.rsplit(".", 1)[0] + ".mpm_scenes")
    for name, frames in SCENES.items():
        folder = os.path.join(demo_dir, name)
        if not glob.glob(os.path.join(folder, "*.ply")):
            continue
        H.fresh()
        car = name == "car"
        _stage(name, (2.2, 1.25, 0.3) if car else (2.0, 2.0, 1.2), 4.5 if car else 7.0)
        points = H.mesh_object(f"{name} particles", [])
        flake = cloud.snowflake_object()
        flake.data.materials.append(_material("Flake", (0.95, 0.97, 1.0), emission=0.3))
        cloud.instance_nodes(points, flake, 0.035 if car else 0.05)
        body = None
        if car:
            verts, tris = scenes.car_mesh()
            body = H.mesh_object("Car", verts, tris)
            body.data.materials.append(_material("Car", (0.7, 0.08, 0.05)))
        for frame in frames:
            path = os.path.join(folder, f"{name}_{frame:04d}.ply")
            if not os.path.isfile(path):
                continue
            data = mpm.read_ply(path)
            cloud.show_particles(points, mpm, np.column_stack([data[k] for k in ("x", "y", "z")]),
                                 np.column_stack([data[k] for k in ("qw", "qx", "qy", "qz")]))
            if body is not None:
                body.location = tuple(scenes.car_position(frame))
            out = os.path.join(demo_dir, f"{name}_{frame:04d}.png")
            bpy.context.scene.render.filepath = out
            bpy.ops.render.render(write_still=True)
            print(f"render: {out}", flush=True)


if __name__ == "__main__":
    render(sys.argv[sys.argv.index("--") + 1])
