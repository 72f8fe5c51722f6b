"""The loose-parts check of issue 12, bpy-free, shared by tests/test_loose_parts.py (the core) and
tests/blender/suite_goals.py (the add-on in Blender): a mesh's connected pieces, and while a mesh with a head
and small pieces (Suzanne's eyes) moves, its worst triangle-edge stretch and the worst offset of an eye from
where its socket carries it."""

import numpy as np


def mesh_pieces_of_vertices(n_vertices, triangles):
    """The connected piece of each vertex, numbered by first triangle (as the graph numbers them)."""
    label = np.arange(n_vertices)
    while True:  # label propagation to the smallest vertex of each piece
        new = label.copy()
        np.minimum.at(new, triangles.ravel(), np.repeat(label[triangles].min(axis=1), 3))
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    _, first = np.unique(label[triangles[:, 0]], return_index=True)
    order = label[triangles[np.sort(first), 0]]
    return np.searchsorted(order, label, sorter=np.argsort(order)).astype(np.int32)


def kabsch(a, b):
    """The rotation r and translation x that best map the points a onto b."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, wt = np.linalg.svd((a - ca).T @ (b - cb))
    r = (u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ wt))]) @ wt).T
    return r, cb - r @ ca


class DropCheck:
    """Feed it the deformed vertices of each frame (update); it keeps the worst edge stretch (length over rest
    length, any triangle edge) and the worst eye offset (an eye's centre from where the rigid motion of its
    socket, the head vertices within two eye radii, carries it) over the head's size."""
    STRETCH = 3.0  # the bound on the stretch
    EYE = 0.05  # the bound on the eye offset

    def __init__(self, vertices, triangles):
        v, t = np.asarray(vertices, dtype=np.float64), np.asarray(triangles)
        edges = np.unique(np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1), axis=0)
        rest = np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1)
        self.edges, self.rest = edges[rest > 0.0], rest[rest > 0.0]
        piece = mesh_pieces_of_vertices(len(v), t)
        head = piece == np.argmax(np.bincount(piece))
        self.size = np.linalg.norm(v[head].max(axis=0) - v[head].min(axis=0))
        self.rest_vertices, self.eyes = v, []
        for q in np.unique(piece[~head]):
            centre = v[piece == q].mean(axis=0)
            radius = np.linalg.norm(v[piece == q] - centre, axis=1).max()
            self.eyes.append((piece == q, centre, head & (np.linalg.norm(v - centre, axis=1) < 2.0 * radius)))
        self.stretch = self.offset = 0.0

    def update(self, p):
        e = self.edges
        self.stretch = max(self.stretch, (np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1) / self.rest).max())
        for rows, centre, socket in self.eyes:
            r, x = kabsch(self.rest_vertices[socket], p[socket])
            self.offset = max(self.offset, np.linalg.norm(p[rows].mean(axis=0) - (r @ centre + x)) / self.size)
