"""Handle maths: an empty's transform drives one position constraint (its bound vertex follows the empty as if
rigidly attached) and, optionally, three direction constraints (the empty's axes turn the mesh there)."""

import numpy as np


class HandleError(ValueError):
    pass


def check_matrix(name, matrix):
    m = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
    if not np.all(np.isfinite(m)):
        raise HandleError(f"handle {name!r} has a non-finite (NaN or infinite) transform")
    if abs(np.linalg.det(m[:3, :3])) < 1e-12:
        raise HandleError(f"handle {name!r} has a degenerate (zero-scale) transform")
    return m


def rotation_part(m):
    """The proper rotation closest to the 3x3 part of m (scale and shear removed)."""
    u, _, vt = np.linalg.svd(m[:3, :3])
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, -1] = -u[:, -1]
        r = u @ vt
    return r


def nearest_vertex(rest, point):
    """Index of the rest vertex nearest to point."""
    d = rest - np.asarray(point, dtype=np.float64)
    return int(np.argmin(np.einsum("ij,ij->i", d, d)))


def targets(rest_point, rest_matrix, matrix):
    """(4, 3): the position target of the bound rest point, then the targets of the three world axes."""
    m0 = np.asarray(rest_matrix, dtype=np.float64).reshape(4, 4)
    m = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
    p0 = np.append(np.asarray(rest_point, dtype=np.float64), 1.0)
    out = np.empty((4, 3))
    out[0] = (m @ np.linalg.solve(m0, p0))[:3]
    out[1:] = (rotation_part(m) @ rotation_part(m0).T).T  # row a = delta rotation applied to axis a
    return out


def blend(a, b, u):
    """Targets between two sets (H, 4, 3): positions linearly, directions linearly then normalised."""
    out = (1.0 - u) * a + u * b
    d = out[:, 1:]
    n = np.linalg.norm(d, axis=2, keepdims=True)
    out[:, 1:] = np.where(n > 1e-12, d / np.maximum(n, 1e-12), b[:, 1:])
    return out
