"""Viewport overlay: the particles' ellipsoids (three principal ellipses each) and the graph's edges, drawn
from the state the mesh shows, carried by the object's current transform; hidden while baked. Toggled per object (Show Particles, Edges). Nothing is drawn in background
mode."""

import math

import bpy
import numpy as np
from mathutils import Matrix

from ..core.colliders import contact_points
from . import playback, state

SEGMENTS = 16
_handle = {"draw": None}
_batches = {}


def ellipse_lines(centers, frames, radii, segments=SEGMENTS):
    """(n * 3 * segments * 2, 3) line-segment end points: three principal ellipses per particle.
    frames: (n, 3, 3) current frames (columns are the axes); radii (n, 3)."""
    t = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    c, s = np.cos(t), np.sin(t)
    out = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        ua = frames[:, :, a] * radii[:, a:a + 1]
        ub = frames[:, :, b] * radii[:, b:b + 1]
        ring = centers[:, None, :] + c[None, :, None] * ua[:, None, :] + s[None, :, None] * ub[:, None, :]
        seg = np.stack([ring[:, :-1], ring[:, 1:]], axis=2)  # (n, segments, 2, 3)
        out.append(seg.reshape(-1, 3))
    return np.concatenate(out).astype(np.float32)


def edge_lines(centers, edges):
    return centers[edges.reshape(-1)].astype(np.float32)


def _shader():
    import gpu
    for name in ("UNIFORM_COLOR", "3D_UNIFORM_COLOR"):
        try:
            return gpu.shader.from_builtin(name)
        except (ValueError, TypeError):
            continue
    return None


def _draw():
    try:
        import gpu
        from gpu_extras.batch import batch_for_shader
        shader = _shader()
        if shader is None:
            return
        context = bpy.context
        view_layer = context.view_layer
        for k, rt in state.items():
            obj = next((o for o in view_layer.objects if state.key(o) == k), None)
            if obj is None or not obj.opdeform.show_particles or not obj.visible_get() or not playback.is_live(obj):
                continue  # hidden while baked: the Mesh Cache modifier shows frames the particles no longer hold
            e = rt.engine
            pos, rot = e.shown_state
            show_contacts = obj.opdeform_contact.show_contacts
            stamp = (id(pos), id(rot), obj.opdeform.show_edges, show_contacts)
            cached = _batches.get(k)
            if cached is None or cached[0] != stamp:
                g = e.graph
                frames = np.einsum("nij,njk->nik", rot, g.axes)
                lines = ellipse_lines(pos, frames, g.radii)
                batches = [(batch_for_shader(shader, 'LINES', {"pos": lines}), (0.2, 0.8, 1.0, 0.9))]
                if obj.opdeform.show_edges and g.n_edges:
                    batches.append((batch_for_shader(shader, 'LINES', {"pos": edge_lines(pos, g.edges)}),
                                    (1.0, 0.6, 0.1, 0.9)))
                touching = contact_points(e.sim, pos, g.radii) if show_contacts else pos[:0]
                if len(touching):  # the particles near or inside a collider (docs/blender.md, Collisions)
                    batches.append((batch_for_shader(shader, 'POINTS', {"pos": touching.astype(np.float32)}),
                                    (1.0, 0.1, 0.3, 1.0)))
                cached = (stamp, batches)
                _batches[k] = cached
            gpu.state.depth_test_set('LESS_EQUAL')
            gpu.state.line_width_set(1.5)
            gpu.state.point_size_set(8.0)
            shader.bind()
            with gpu.matrix.push_pop():
                gpu.matrix.multiply_matrix(Matrix(e.overlay_matrix(np.array(obj.matrix_world)).tolist()))
                for batch, color in cached[1]:
                    shader.uniform_float("color", color)
                    batch.draw(shader)
            gpu.state.depth_test_set('NONE')
    except Exception as exc:  # drawing must never break the viewport
        print(f"opdeform overlay: {type(exc).__name__}: {exc}")


classes = ()


def register():
    if _handle["draw"] is None and not bpy.app.background:
        _handle["draw"] = bpy.types.SpaceView3D.draw_handler_add(_draw, (), 'WINDOW', 'POST_VIEW')


def unregister():
    if _handle["draw"] is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle["draw"], 'WINDOW')
        _handle["draw"] = None
    _batches.clear()
