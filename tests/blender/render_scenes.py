"""Headless regression renders (run by scripts/render in Debian's Blender or in a bpy module):

    blender -b --factory-startup --python-exit-code 1 -P render_scenes.py -- --out DIR [--update] [--docs DIR]
    <python with bpy> render_scenes.py --out DIR [--update] [--docs DIR]

Builds two scenes in code with the add-on, bakes them, renders chosen frames with Cycles on the CPU (fixed
seed and sample count, no denoiser, 160 x 120) and compares them with this Blender version's references,
tests/reference/<major.minor>/*.png (Cycles renders differ between Blender versions); compares the baked
vertex positions at those frames with tests/reference/*_vertices.npz, shared by every version (the bake is
opdeform's, the same everywhere). --update rewrites this version's images and the shared vertices.
--docs also renders the documentation figures (larger, the ellipsoids drawn as geometry) into DIR.

Scenes: "creature" (opdeform.meshes.creature(), 100 particles, falls on a floor with friction) and "bar"
(opdeform.meshes.bar(), pinned at one end face, its other end twisted by 180 degrees and lifted by a handle).
"""

import argparse
import math
import os
import shutil
import sys

import bpy
import numpy as np
from mathutils import Matrix, Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.environ["OPDEFORM_PYTHONPATH"])  # the opdeform the add-on loads (scripts/render sets it)
import helpers as H  # noqa: E402
# the Cycles settings, lights, camera and tolerances of every regression render: python -m opdeform render's
from opdeform.blender_render import RESOLUTION, SAMPLES, SEED, camera, material, setup_render  # noqa: E402
from opdeform.render import IMAGE_FRACTION, IMAGE_MEAN, PIXEL, VERTEX_TOLERANCE, image_difference  # noqa: E402

REFERENCE = os.path.join(H.ROOT, "tests", "reference")  # the baked vertices, shared by every version
VERSION = "%d.%d" % tuple(bpy.app.version[:2])
REFERENCE_IMAGES = os.path.join(REFERENCE, VERSION)  # Cycles differs between versions: one set per version
SCENES = {
    "creature": dict(frames=(1, 20, 60), end=60),
    "bar": dict(frames=(1, 24, 48), end=48),
}


def floor_plane(scene, size=8.0, height=0.0):
    s = size / 2
    obj = H.mesh_object("Floor", [(-s, -s, height), (s, -s, height), (s, s, height), (-s, s, height)],
                        [(0, 1, 2, 3)])
    obj.data.materials.append(material("Floor", (0.8, 0.8, 0.78)))
    return obj


def build_creature(scene):
    from opdeform import meshes
    v, t = meshes.creature()
    v = np.asarray(v, float)
    v = v - [0.5 * (v[:, 0].min() + v[:, 0].max()), 0.5 * (v[:, 1].min() + v[:, 1].max()), v[:, 2].min()]
    size = float(np.linalg.norm(v.max(0) - v.min(0)))
    v[:, 2] += 0.4 * size  # dropped from 0.4 x its size
    # tilt it so that it lands on one side and rolls a little
    c, s = math.cos(0.25), math.sin(0.25)
    centre = v.mean(0)
    v = (v - centre) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T + centre
    obj = H.mesh_object("Creature", v, t)
    obj.data.materials.append(material("Creature", (0.85, 0.35, 0.12)))
    for p in obj.data.polygons:
        p.use_smooth = True
    st = obj.opdeform
    st.particles, st.graph_mode = 100, "auto"
    st.stiffness, st.density, st.damping = 2e7, 1000.0, 0.01
    st.use_floor, st.floor_height, st.floor_friction = True, 0.0, 0.5
    st.iterations = 10
    floor_plane(scene, size=6 * size)
    lo, hi = v.min(0), v.max(0)
    camera(scene, ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0.4 * size), (1.0, -1.6, 0.7), 1.6 * size)
    return obj


def action_fcurves(action):
    """The F-curves of an action: Action.fcurves up to 4.x, the layered action's channel bags from 4.4 (the only
    way in 5.0, where Action.fcurves is gone)."""
    if hasattr(action, "layers") and action.layers:
        return [fc for layer in action.layers for strip in layer.strips for bag in strip.channelbags
                for fc in bag.fcurves]
    return list(action.fcurves)


def build_bar(scene):
    from opdeform import meshes
    v, t = meshes.bar()
    v = np.asarray(v, float)
    obj = H.mesh_object("Bar", v, t)
    obj.data.materials.append(material("Bar", (0.15, 0.4, 0.85)))
    x0 = v[:, 0].min()
    group = obj.vertex_groups.new(name="Pin")
    group.add([int(i) for i in np.where(v[:, 0] < x0 + 1e-6)[0]], 1.0, 'REPLACE')
    st = obj.opdeform
    st.pin_group = "Pin"
    st.particles, st.graph_mode = 20, "chain"
    st.stiffness, st.density, st.damping = 1e8, 1000.0, 0.02
    st.iterations = 10
    length = float(v[:, 0].max() - x0)
    tip = (float(v[:, 0].max()), float((v[:, 1].min() + v[:, 1].max()) / 2),
           float((v[:, 2].min() + v[:, 2].max()) / 2))
    handle = bpy.data.objects.new("Tip", None)
    handle.empty_display_type = 'ARROWS'
    handle.location = tip
    scene.collection.objects.link(handle)
    for f, angle, offset in ((1, 0.0, (0, 0, 0)), (SCENES["bar"]["end"] - 8, math.pi, (-0.15 * length, 0, 0.25 * length))):
        handle.location = Vector(tip) + Vector(offset)
        handle.rotation_euler = (angle, 0.0, 0.0)
        handle.keyframe_insert("location", frame=f)
        handle.keyframe_insert("rotation_euler", frame=f)
    fcurves = action_fcurves(handle.animation_data.action)
    assert fcurves, "the handle's keys were not found"
    for fc in fcurves:
        for k in fc.keyframe_points:
            k.interpolation = 'LINEAR'
    scene.frame_set(1)
    st.handles.add().target = handle
    camera(scene, (x0 + 0.5 * length, 0.0, 0.1 * length), (0.6, -1.5, 0.7), 1.35 * length)
    floor_plane(scene, size=4 * length, height=-0.6 * length)
    return obj


def bake(obj, out_dir, end):
    obj.opdeform.frame_start, obj.opdeform.frame_end = 1, end
    obj.opdeform.cache_directory = os.path.join(out_dir, "cache")
    bpy.ops.opdeform.enable(object=obj.name)
    bpy.ops.opdeform.bake(object=obj.name)
    assert obj.opdeform.baked and not obj.opdeform.error, obj.opdeform.error
    return H.pc2().read_pc2(bpy.path.abspath(obj.modifiers["OPDeform Cache"].filepath))[2]


def read_png(path):
    img = bpy.data.images.load(path, check_existing=False)
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)[:, :, :3]


def compare_image(path, ref):
    try:
        mean, frac = image_difference(read_png(path), read_png(ref))
    except ValueError as exc:
        return False, str(exc)
    ok = mean <= IMAGE_MEAN and frac <= IMAGE_FRACTION
    return ok, f"mean |diff| {mean:.5f} (<= {IMAGE_MEAN}), pixels off by > {PIXEL}: {100 * frac:.3f}% " \
               f"(<= {100 * IMAGE_FRACTION}%)"


def add_ellipsoids(obj, frame):
    """The particles of the shown state as real geometry (documentation figures: the overlay, rendered)."""
    rt = H.runtime().get(obj)
    rt.engine.goto(frame, None)
    pos, rot = rt.engine.shown_state
    g = rt.engine.graph
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=1.0)
    proto = bpy.context.object
    mesh = proto.data
    bpy.data.objects.remove(proto)
    mat = material("Particle", (0.1, 0.75, 0.95))
    mesh.materials.append(mat)
    for i in range(g.n_particles):
        e = bpy.data.objects.new(f"Particle {i}", mesh)
        frame_m = rot[i] @ g.axes[i] @ np.diag(g.radii[i])
        m = Matrix.Identity(4)
        for r in range(3):
            for c in range(3):
                m[r][c] = frame_m[r, c]
            m[r][3] = pos[i, r]
        e.matrix_world = m
        bpy.context.scene.collection.objects.link(e)


def run(args):
    os.makedirs(args.out, exist_ok=True)
    failures, lines = [], []
    for name, spec in SCENES.items():
        H.fresh()
        scene = bpy.context.scene
        scene.render.fps = 24
        setup_render(scene)
        obj = (build_creature if name == "creature" else build_bar)(scene)
        frames = bake(obj, args.out, spec["end"])
        rest = H.positions(obj)
        diag = float(np.linalg.norm(rest.max(0) - rest.min(0)))
        chosen = np.stack([frames[f - 1] for f in spec["frames"]])
        ref_vertices = os.path.join(REFERENCE, f"{name}_vertices.npz")
        if args.update:
            os.makedirs(REFERENCE, exist_ok=True)
            np.savez_compressed(ref_vertices, frames=np.array(spec["frames"]), vertices=chosen)
        ref = np.load(ref_vertices)
        if ref["vertices"].shape != chosen.shape:
            failures.append(f"{name}: vertices {chosen.shape} vs reference {ref['vertices'].shape}")
        else:
            err = float(np.abs(ref["vertices"] - chosen).max())
            ok = err <= VERTEX_TOLERANCE * diag
            lines.append(f"{name} vertices at frames {spec['frames']}: max |diff| {err:.3e} m "
                         f"(<= {VERTEX_TOLERANCE * diag:.3e}) {'ok' if ok else 'FAIL'}")
            if not ok:
                failures.append(lines[-1])
        for f in spec["frames"]:
            scene.frame_set(f)
            path = os.path.join(args.out, f"{name}_{f:03d}.png")
            scene.render.filepath = path
            bpy.ops.render.render(write_still=True)
            ref_png = os.path.join(REFERENCE_IMAGES, f"{name}_{f:03d}.png")
            if args.update:
                os.makedirs(REFERENCE_IMAGES, exist_ok=True)
                shutil.copyfile(path, ref_png)
            if not os.path.exists(ref_png):
                ok, text = False, f"no reference for Blender {VERSION} ({ref_png}: scripts/render --update " \
                                  "in this host makes them)"
            else:
                ok, text = compare_image(path, ref_png)
            lines.append(f"{name} frame {f}: {text} {'ok' if ok else 'FAIL'}")
            if not ok:
                failures.append(lines[-1])
        if args.docs:
            os.makedirs(args.docs, exist_ok=True)
            setup_render(scene, resolution=(480, 360), samples=32)
            f = spec["frames"][1]
            scene.frame_set(f)
            scene.render.filepath = os.path.join(args.docs, f"{name}_render.png")
            bpy.ops.render.render(write_still=True)
            for m in obj.data.materials:
                bsdf = m.node_tree.nodes.get("Principled BSDF")
                bsdf.inputs["Alpha"].default_value = 0.25
                if hasattr(m, "blend_method"):
                    m.blend_method = 'BLEND'
            add_ellipsoids(obj, f)
            scene.render.filepath = os.path.join(args.docs, f"{name}_particles.png")
            bpy.ops.render.render(write_still=True)
    for line in lines:
        print("render:", line)
    if failures:
        print(f"render: {len(failures)} comparison(s) FAILED (tolerance above; scripts/render --update "
              "rewrites the references after an intended change)")
        return 1
    print(f"render: all {len(lines)} comparisons within tolerance ({H.host()}, references {VERSION}, Cycles CPU, "
          f"{SAMPLES} samples, seed {SEED}, {RESOLUTION[0]}x{RESOLUTION[1]})")
    return 0


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--out", default=os.path.join(H.ROOT, "out", "render"))
    p.add_argument("--update", action="store_true")
    p.add_argument("--docs", default=None)
    status = run(p.parse_args(argv))
    H.cleanup()
    sys.exit(status)
