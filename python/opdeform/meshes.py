"""Procedural test bodies, built in code: each returns ``(vertices (V,3) float64, triangles (T,3) int32)``
with outward-facing (counter-clockwise) triangles.

- ``bar``: the paper's bar (Figs. 1-2) as a closed box mesh along +x, its cross-section centred on the axis.
- ``capsule``: a closed cylinder with hemispherical ends along +x.
- ``sheet``: an open rectangle of triangles in the z = 0 plane.
- ``strand``: an open ribbon, long and narrow, along +x (a strand of hair or a rope of triangles).
- ``creature``: a closed four-legged body with neck, head and tail standing on z = 0 (the paper's dinosaur,
  Figs. 3-4), the smooth union of capsules meshed by surface nets.
- ``character``: a closed upright body with belly, head, ears, tail and feet, 2.43 m tall (issue 24's rigged
  hopping shot, tests/blender/character_scene.py), meshed the same way.
- ``subdivide``: four triangles for each, to make large meshes (benchmarks).
"""

from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["bar", "capsule", "character", "creature", "sheet", "strand", "subdivide"]

Array = npt.NDArray[Any]
Mesh = tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]  # (vertices (V,3) float64, triangles (T,3) int32)
# a tapered capsule: (start, end, radius at start, radius at end)
Part = tuple[tuple[float, float, float], tuple[float, float, float], float, float]


def _grid_triangles(rows: int, cols: int, offset: int = 0) -> Array:
    """Two triangles per quad of a rows x cols vertex grid (row-major), facing (row step) x (column step)."""
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    a = offset + i * cols + j
    b, c, d = a + 1, a + cols + 1, a + cols
    return np.concatenate([np.stack([a, d, c], -1).reshape(-1, 3), np.stack([a, c, b], -1).reshape(-1, 3)])


def _weld(vertices: Array, triangles: Array, decimals: int = 9) -> Mesh:
    """Merges vertices that coincide to ``decimals`` places (shared edges of separately built faces)."""
    keys = np.round(vertices, decimals)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # keep the first occurrence order
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return vertices[first[order]], rank[inverse.reshape(-1)][triangles].astype(np.int32)


def _finish(vertices: npt.ArrayLike, triangles: npt.ArrayLike) -> Mesh:
    return np.ascontiguousarray(vertices, np.float64), np.ascontiguousarray(triangles, np.int32)


def bar(length: float = 2.0, width: float = 0.2, segments: int = 20, cross: int = 2) -> Mesh:
    """The bar along +x: x in [0, length], y and z in [-width/2, width/2]; ``segments`` divisions along its
    length and ``cross`` across each side face."""
    size = np.array([length, width, width], float)
    lo = np.array([0.0, -width / 2, -width / 2])
    div = np.array([segments, cross, cross])
    vertices: list[Array] = []
    triangles: list[Array] = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (0, 1):
            s = np.linspace(0.0, 1.0, div[u] + 1)
            t = np.linspace(0.0, 1.0, div[v] + 1)
            if side == 0:  # the -axis face: swap the grid directions to face outwards
                s, t, u, v = t, s, v, u
            ss, tt = np.meshgrid(s, t, indexing="ij")
            p = np.empty(ss.shape + (3,))
            p[..., axis] = lo[axis] + side * size[axis]
            p[..., u] = lo[u] + ss * size[u]
            p[..., v] = lo[v] + tt * size[v]
            triangles.append(_grid_triangles(len(s), len(t), sum(len(x) for x in vertices)))
            vertices.append(p.reshape(-1, 3))
            if side == 0:
                u, v = v, u
    return _finish(*_weld(np.concatenate(vertices), np.concatenate(triangles)))


def _revolve(x: Array, r: Array, segments: int) -> Mesh:
    """The closed surface of revolution about +x of the profile (x, r), whose ends have r = 0 (poles)."""
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack([np.zeros(segments), np.cos(phi), np.sin(phi)], -1)
    inner = len(x) - 2
    rings = [np.array([[x[0], 0.0, 0.0]])]
    for k in range(1, len(x) - 1):
        rings.append(ring * r[k] + [x[k], 0.0, 0.0])
    rings.append(np.array([[x[-1], 0.0, 0.0]]))
    vertices = np.concatenate(rings)
    j = np.arange(segments)
    jn = (j + 1) % segments
    tris = [np.stack([np.zeros(segments, int), 1 + jn, 1 + j], -1)]
    for k in range(inner - 1):
        a, b = 1 + k * segments, 1 + (k + 1) * segments
        tris.append(np.stack([a + j, a + jn, b + jn], -1))
        tris.append(np.stack([a + j, b + jn, b + j], -1))
    last, pole = 1 + (inner - 1) * segments, len(vertices) - 1
    tris.append(np.stack([np.full(segments, pole), last + j, last + jn], -1))
    return _finish(vertices, np.concatenate(tris))


def capsule(radius: float = 0.1, length: float = 1.0, segments: int = 32, rings: int = 8,
            body: int = 8) -> Mesh:
    """A capsule along +x centred at the origin: a cylinder of ``length`` and ``radius`` with hemispherical
    caps (``rings`` latitude steps each), ``segments`` around and ``body`` divisions along the cylinder."""
    theta = np.linspace(-np.pi / 2, 0.0, rings + 1)
    cap_x, cap_r = radius * np.sin(theta), radius * np.cos(theta)
    x = np.concatenate([cap_x - length / 2, np.linspace(-length / 2, length / 2, body + 1)[1:-1],
                        -cap_x[::-1] + length / 2])
    r = np.concatenate([cap_r, np.full(body - 1, radius), cap_r[::-1]])
    return _revolve(x, r, segments)


def sheet(size: Sequence[float] = (1.0, 1.0), resolution: Sequence[int] = (20, 20)) -> Mesh:
    """An open size[0] x size[1] rectangle in z = 0 centred at the origin, resolution quads per side."""
    nx, ny = resolution[0] + 1, resolution[1] + 1
    xx, yy = np.meshgrid(np.linspace(-size[0] / 2, size[0] / 2, nx), np.linspace(-size[1] / 2, size[1] / 2, ny),
                         indexing="ij")
    vertices = np.stack([xx, yy, np.zeros_like(xx)], -1).reshape(-1, 3)
    return _finish(vertices, _grid_triangles(nx, ny))


def strand(length: float = 1.0, width: float = 0.02, segments: int = 50, sag: float = 0.0) -> Mesh:
    """An open ribbon of ``segments`` quads along +x from 0 to ``length``, ``width`` wide in y, bowed down
    by ``sag`` in the middle (a parabola)."""
    x = np.linspace(0.0, length, segments + 1)
    z = -sag * 4.0 * (x / length) * (1.0 - x / length)
    side = np.array([-width / 2, width / 2])
    vertices = np.stack([np.repeat(x, 2), np.tile(side, segments + 1), np.repeat(z, 2)], -1)
    return _finish(vertices, _grid_triangles(segments + 1, 2))


# -- the creature --------------------------------------------------------------------------------------------

# (start, end, radius at start, radius at end) of the capsules of the creature, in metres; feet at z = 0.
_CREATURE_PARTS: list[Part] = [
    ((-0.35, 0.0, 0.58), (0.35, 0.0, 0.6), 0.2, 0.2),        # body
    ((0.35, 0.0, 0.62), (0.58, 0.0, 0.88), 0.1, 0.08),       # neck
    ((0.56, 0.0, 0.92), (0.8, 0.0, 0.88), 0.11, 0.07),       # head
    ((-0.4, 0.0, 0.58), (-0.95, 0.0, 0.42), 0.1, 0.03),      # tail
    ((0.25, 0.12, 0.5), (0.3, 0.24, 0.06), 0.075, 0.06),     # legs, splayed for a stable stance
    ((0.25, -0.12, 0.5), (0.3, -0.24, 0.06), 0.075, 0.06),
    ((-0.25, 0.12, 0.5), (-0.28, 0.24, 0.06), 0.075, 0.06),
    ((-0.25, -0.12, 0.5), (-0.28, -0.24, 0.06), 0.075, 0.06),
]


# The character's capsules by name (metres, facing -y; the feet reach z = -0.005 before it is stood on z = 0).
CHARACTER_PARTS: dict[str, Part] = {
    "body": ((0.0, 0.05, 0.55), (0.0, 0.05, 1.2), 0.42, 0.33),
    "belly": ((0.0, -0.2, 0.78), (0.0, -0.2, 0.8), 0.36, 0.36),
    "head": ((0.0, 0.0, 1.62), (0.0, -0.06, 1.74), 0.28, 0.26),
    "ear.L": ((0.12, 0.02, 1.88), (0.26, 0.08, 2.38), 0.085, 0.05),
    "ear.R": ((-0.12, 0.02, 1.88), (-0.26, 0.08, 2.38), 0.085, 0.05),
    "tail": ((0.0, 0.38, 0.62), (0.0, 1.08, 0.9), 0.09, 0.05),
    "leg.L": ((0.2, 0.08, 0.45), (0.22, 0.0, 0.14), 0.14, 0.11),
    "leg.R": ((-0.2, 0.08, 0.45), (-0.22, 0.0, 0.14), 0.14, 0.11),
    "foot.L": ((0.22, 0.05, 0.08), (0.24, -0.2, 0.08), 0.085, 0.085),
    "foot.R": ((-0.22, 0.05, 0.08), (-0.24, -0.2, 0.08), 0.085, 0.085),
}


def _capsules_distance(p: Array, parts: Iterable[Part], blend: float = 0.06) -> Array:
    """Signed distance (approximate) of points p (..., 3) to a smooth union of tapered capsules
    ``(start, end, radius at start, radius at end)``."""
    d: Any = None
    for start, end, ra, rb in parts:
        a, b = np.array(start), np.array(end)
        ab = b - a
        t = np.clip(((p - a) @ ab) / (ab @ ab), 0.0, 1.0)
        part = np.linalg.norm(p - (a + t[..., None] * ab), axis=-1) - (ra + (rb - ra) * t)
        if d is None:
            d = part
        else:  # polynomial smooth minimum
            h = np.clip(0.5 + 0.5 * (part - d) / blend, 0.0, 1.0)
            d = part + (d - part) * h - blend * h * (1.0 - h)
    return d


def _surface_nets(f: Array, origin: Array, h: float) -> Mesh:
    """A closed triangle mesh of the zero level of samples f (nx, ny, nz) on a grid of spacing h (negative
    inside, positive on the grid's border): one vertex per cell that the surface crosses (the mean of its
    edge crossings), one quad (two triangles) per grid edge that crosses it."""
    inside = f < 0.0
    cell_shape = tuple(np.array(f.shape) - 1)
    total = np.zeros(cell_shape + (3,))
    count = np.zeros(cell_shape)
    edges = []
    for a in range(3):
        u, v = (a + 1) % 3, (a + 2) % 3
        lo, hi = [slice(None)] * 3, [slice(None)] * 3
        lo[a], hi[a] = slice(0, -1), slice(1, None)
        fa, fb = f[tuple(lo)], f[tuple(hi)]
        cross = inside[tuple(lo)] != inside[tuple(hi)]
        point = np.moveaxis(np.indices(fa.shape, dtype=float), 0, -1)  # grid coordinates of the crossings
        point[..., a] += np.where(cross, fa / np.where(cross, fa - fb, 1.0), 0.0)
        for du in (0, 1):  # the cell (p_a, p_u - du, p_v - dv) touches the edge p
            for dv in (0, 1):
                src = [slice(None)] * 3
                src[u], src[v] = slice(du, du + cell_shape[u]), slice(dv, dv + cell_shape[v])
                c = cross[tuple(src)]
                total += np.where(c[..., None], point[tuple(src)], 0.0)
                count += c
        edges.append((cross, inside[tuple(lo)]))
    active = count > 0
    index = np.full(cell_shape, -1, np.int64)
    index[active] = np.arange(active.sum())
    vertices = origin + h * (total[active] / count[active][:, None])
    quads = []
    for a, (cross, first_inside) in enumerate(edges):
        u, v = (a + 1) % 3, (a + 2) % 3
        p = np.argwhere(cross)
        cells = []
        for du, dv in ((-1, -1), (0, -1), (0, 0), (-1, 0)):  # counter-clockwise about +a
            c = p.copy()
            c[:, u] += du
            c[:, v] += dv
            cells.append(index[c[:, 0], c[:, 1], c[:, 2]])
        q = np.stack(cells, -1)
        outward_minus = ~first_inside[p[:, 0], p[:, 1], p[:, 2]]  # the inside is at the edge's far end
        q[outward_minus] = q[outward_minus][:, ::-1]
        quads.append(q)
    q = np.concatenate(quads)
    # split each quad along its shorter diagonal
    short02 = (np.linalg.norm(vertices[q[:, 0]] - vertices[q[:, 2]], axis=1)
               <= np.linalg.norm(vertices[q[:, 1]] - vertices[q[:, 3]], axis=1))[:, None]
    t1 = np.where(short02, q[:, [0, 1, 2]], q[:, [0, 1, 3]])
    t2 = np.where(short02, q[:, [0, 2, 3]], q[:, [1, 2, 3]])
    return _finish(vertices, np.concatenate([t1, t2]))


def _is_closed_manifold(triangles: Array) -> bool:
    """Every edge in exactly two triangles, once in each direction."""
    a, b = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]).T.astype(np.int64)
    n = int(triangles.max()) + 1
    forward, backward = np.sort(a * n + b), np.sort(b * n + a)
    return bool(np.all(forward[1:] != forward[:-1]) and np.array_equal(forward, backward))


def _closed_surface(distance: Callable[[Array], Array], lo: Array, hi: Array, h: float) -> Mesh:
    """Surface nets of the zero level of ``distance`` (points -> signed distance) over the box lo..hi at spacing
    h, standing on z = 0."""
    # A saddle of the level set on a cell face makes an edge of four triangles; a shifted grid avoids it.
    for shift in (0.0, 0.31, 0.57, 0.83):
        start = lo - shift * h
        axes = [start[k] + h * np.arange(int(np.ceil((hi[k] - start[k]) / h)) + 1) for k in range(3)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
        vertices, triangles = _surface_nets(distance(grid), start, h)
        if _is_closed_manifold(triangles):
            break
    vertices[:, 2] -= vertices[:, 2].min()
    return vertices, triangles


def creature(resolution: int = 48) -> Mesh:
    """The creature: about 1.9 m long, standing on z = 0, facing +x; ``resolution`` grid cells along its
    length (48 gives about 4,000 triangles, 130 about 28,000; ``subdivide`` for more)."""
    lo = np.array([-1.05, -0.4, -0.1])
    hi = np.array([0.95, 0.4, 1.1])
    return _closed_surface(lambda p: _capsules_distance(p, _CREATURE_PARTS), lo, hi, (hi[0] - lo[0]) / resolution)


def character(resolution: int = 70) -> Mesh:
    """The hopping character of issue 24: one closed shell 2.43 m tall standing on z = 0, facing -y (Blender's
    front view): a body with a forward belly, a head, two 0.5 m ears, a 0.75 m tail and two feet;
    ``resolution`` grid cells along its height (70 gives about 5,800 vertices). ``CHARACTER_PARTS`` names
    its capsules (tests/blender/character_scene.py rigs it)."""
    lo = np.array([-0.6, -0.7, -0.1])
    hi = np.array([0.6, 1.2, 2.5])
    return _closed_surface(lambda p: _capsules_distance(p, CHARACTER_PARTS.values(), blend=0.08), lo, hi,
                           (hi[2] - lo[2]) / resolution)


def subdivide(vertices: npt.ArrayLike, triangles: npt.ArrayLike, levels: int = 1) -> Mesh:
    """Splits every triangle into four at its edge midpoints, ``levels`` times (the shape is unchanged;
    a closed mesh stays closed)."""
    vertices, triangles = _finish(vertices, triangles)
    for _ in range(levels):
        edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = len(vertices) + inverse.reshape(3, -1).T  # midpoints of edges (01, 12, 20) of each triangle
        vertices = np.concatenate([vertices, 0.5 * (vertices[unique[:, 0]] + vertices[unique[:, 1]])])
        a, b, c = triangles.T
        m01, m12, m20 = mid.T
        triangles = np.concatenate([np.stack(t, -1) for t in ((a, m01, m20), (m01, b, m12), (m20, m12, c),
                                                              (m01, m12, m20))]).astype(np.int32)
    return vertices, triangles
