"""The panel's warnings (issue 14), free of bpy, on top of ``opdeform.materials``: a driven handle too fast for
the steps (per frame, from the handle targets), and too few particles across the mesh's thinnest part (at
Build; the stretch beyond twice the rest length is in each frame's Report, core/frame_report.py)."""

import numpy as np

THIN_PART_BUDGET = 2e7  # vertices x triangles: about 2 s of rays on one core; larger meshes are not checked


def handle_motion(before, after, fps):
    """(the fastest handle's speed m/s, its fastest turn rad/s) between two frames' targets (H, 4, 3: a point
    and three axes each)."""
    a, b = np.asarray(before, dtype=np.float64), np.asarray(after, dtype=np.float64)
    speed = np.linalg.norm(b[:, 0] - a[:, 0], axis=1).max() * fps
    cos = ((a[:, 1:] * b[:, 1:]).sum(axis=(1, 2)) - 1.0) / 2.0  # trace of the relative rotation
    return float(speed), float(np.arccos(np.clip(cos, -1.0, 1.0)).max() * fps)


def handle(materials, sim, before, after, substeps, fps):
    """(the fastest handle's travel in one step / the body's size, too fast for the steps); (0, False) without
    handles or a previous frame."""
    if before is None or after is None or len(after) == 0:
        return 0.0, False
    speed, turn = handle_motion(before, after, fps)
    return materials.handle_warning(sim, speed, turn, substeps, fps)


def thin_part(materials, graph, vertices, triangles):
    """(the thinnest part, the particle spacing, too few particles across), or None for a mesh too large to
    check in about two seconds."""
    if len(vertices) * len(triangles) > THIN_PART_BUDGET:
        return None
    return materials.thin_part_warning(graph, vertices, triangles)
