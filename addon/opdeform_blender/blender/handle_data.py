"""Handles: empties bound to their nearest rest vertex, whose transforms become the targets of the engine's
constraints each frame (core/handles.py does the maths). Bad transforms raise AddonError."""

import numpy as np

from ..core import handles as handle_math
from .compiled import AddonError


def handle_matrix(item, depsgraph=None):
    target = item.target
    if depsgraph is not None:
        target = target.evaluated_get(depsgraph)
    return np.array(target.matrix_world, dtype=np.float64)


def active_handles(settings):
    return [h for h in settings.handles if h.target is not None]


def bind_handle(item, rest_world, depsgraph=None):
    m = handle_math.check_matrix(item.target.name, handle_matrix(item, depsgraph))
    item.vertex = handle_math.nearest_vertex(rest_world, m[:3, 3])
    item.rest_matrix = m.T.reshape(-1)  # column-major like Blender's matrices
    item.bound_name = item.target.name


def _rest_matrix(item):
    return np.array(item.rest_matrix, dtype=np.float64).reshape(4, 4).T


def handle_targets(rt, settings, depsgraph=None):
    """(H, 4, 3) targets of the handles now, or None without handles. Raises AddonError on a NaN or degenerate
    handle transform."""
    hs = active_handles(settings)
    if not hs:
        rt.handle_matrices = b""
        return None
    rest = rt.engine.rest
    out = np.empty((len(hs), 4, 3))
    seen = []
    for i, h in enumerate(hs):
        try:
            m = handle_math.check_matrix(h.target.name, handle_matrix(h, depsgraph))
        except handle_math.HandleError as exc:
            raise AddonError(str(exc)) from None
        seen.append(m)
        out[i] = handle_math.targets(rest[h.vertex], _rest_matrix(h), m)
    rt.handle_matrices = np.array(seen).tobytes()
    return out


def handle_signature(settings, depsgraph=None):
    hs = active_handles(settings)
    if not hs:
        return b""
    return np.array([handle_matrix(h, depsgraph) for h in hs]).tobytes()


def bind_new_handles(rt, settings, depsgraph=None):
    """Binds handles seen for the first time (or given another empty) to their nearest rest vertex."""
    rest = rt.engine.rest
    for h in active_handles(settings):
        if h.vertex < 0 or h.bound_name != h.target.name or h.vertex >= len(rest):
            try:
                bind_handle(h, rest, depsgraph)
            except handle_math.HandleError as exc:
                raise AddonError(str(exc)) from None
