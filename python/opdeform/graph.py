"""The rest graph of ellipsoid particles (``opdeform.Graph``), given directly or built from a mesh."""

from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from . import _core
from ._arguments import ArrayLike, Floats, Ints, Vector, as_array, choice, integer, vector

__all__ = ["Graph", "MODES", "SMALL_PIECES"]

MODES = ("auto", "volume", "surface", "chain")
SMALL_PIECES = ("attach", "own")  # the order of od_SmallPieces


class Graph:
    """Rest graph of ellipsoid particles.

    centers (n,3); radii (n,3) > 0; edges (m,2) undirected particle pairs; axes (n,3,3) rest frames whose
    columns are the ellipsoid axes (proper rotations; default identity).
    """

    def __init__(self, centers: ArrayLike, radii: ArrayLike, edges: ArrayLike,
                 axes: ArrayLike | None = None) -> None:
        centers = as_array("centers", centers, (None, 3))
        n = centers.shape[0]
        radii = as_array("radii", radii, (n, 3))
        edges = as_array("edges", edges, (None, 2), np.int32)
        axes = None if axes is None else as_array("axes", axes, (n, 3, 3))
        self._core = _core.Graph(centers, radii, edges, axes)
        # the core keeps a checked copy (axes orthonormalised, a mesh's pieces) with no way back in: a pickle
        # holds what the graph was made from and makes it again, to the same bits
        made = tuple(None if a is None else a.copy() for a in (centers, radii, edges, axes))
        self._made: tuple[str, tuple[Any, ...]] = ("arrays", made)

    @classmethod
    def from_mesh(cls, vertices: ArrayLike, triangles: ArrayLike, particles: int = 100, mode: str = "auto",
                  join_pieces: bool = False, voxels_per_particle: int = 100, small_pieces: str = "attach") -> "Graph":
        """A graph of ``particles`` ellipsoids covering a triangle mesh (vertices (V,3), triangles (T,3)):
        through the volume of closed pieces, along the surface of open or thin ones (``mode="auto"``), or
        forced: "volume", "surface", or "chain" (a 1-D chain along each piece's principal axis). Frames and
        radii are the principal axes of the part of the body each particle stands for. Each connected piece
        gets its own connected graph unless ``join_pieces``. ``small_pieces``: what becomes of a piece with
        fewer voxels than a tenth of the largest piece's (an eye, a tooth, a button): "attach" gives it no
        particles, and the particles of the large piece nearest to it skin it rigidly; "own" gives it particles
        of its own, joined by edges to that piece: at least 4 from ``particles`` when compact (an eye) or open
        (a shell with a boundary), those 4s at most half of ``particles`` together (largest pieces first), the
        next pieces' 4s added beyond ``particles`` up to half of it again, the rest attached; when closed and long
        or flat (a trunk, an ear plate) its share and, where that is under 16, particles added beyond
        ``particles`` up to 16 (``n_particles`` counts them). Deterministic. See opdeform.mesh."""
        vertices = as_array("vertices", vertices, (None, 3))
        triangles = as_array("triangles", triangles, (None, 3), np.int32)
        graph = cls.__new__(cls)
        graph._core = _core.graph_from_mesh(vertices, triangles, integer("particles", particles),
                                            choice("mode", mode, MODES), bool(join_pieces),
                                            integer("voxels_per_particle", voxels_per_particle),
                                            choice("small_pieces", small_pieces, SMALL_PIECES))
        graph._made = ("from_mesh", (vertices.copy(), triangles.copy(), particles, mode, join_pieces,
                                     voxels_per_particle, small_pieces))
        return graph

    def __getstate__(self) -> tuple[str, tuple[Any, ...]]:
        return self._made

    def __setstate__(self, made: tuple[str, tuple[Any, ...]]) -> None:
        """Made again through the constructor or ``from_mesh`` (checked as any call); ``pickle.loads`` runs
        whatever a crafted pickle names before this, so unpickle only trusted files (else store the arrays the
        graph was made from and make it again)."""
        kind, args = made
        self.__dict__.update((Graph.from_mesh(*args) if kind == "from_mesh" else Graph(*args)).__dict__)

    @property
    def n_particles(self) -> int:
        """The number of particles."""
        return self._core.n_particles

    @property
    def n_edges(self) -> int:
        """The number of edges."""
        return self._core.n_edges

    def _read(self, name: Literal["centers", "radii", "axes", "edges", "pieces", "mesh_pieces"],
              shape: tuple[int, ...], dtype: npt.DTypeLike = np.float64) -> npt.NDArray[Any]:
        out = np.empty(shape, dtype)
        self._core.read(name, out)
        return out

    @property
    def centers(self) -> Floats:
        """(n, 3) rest centres, a copy."""
        return self._read("centers", (self.n_particles, 3))

    @property
    def radii(self) -> Floats:
        """(n, 3) ellipsoid radii along each particle's axes, a copy."""
        return self._read("radii", (self.n_particles, 3))

    @property
    def axes(self) -> Floats:
        """(n, 3, 3) rest frames, a copy (the axes are the columns)."""
        return self._read("axes", (self.n_particles, 3, 3))

    @property
    def edges(self) -> Ints:
        """(e, 2) int32 particle pairs, a copy."""
        return self._read("edges", (self.n_edges, 2), np.int32)

    @property
    def volumes(self) -> Floats:
        """(n,) ellipsoid volumes, 4/3 pi r0 r1 r2."""
        r = self.radii
        return 4.0 / 3.0 * np.pi * r[:, 0] * r[:, 1] * r[:, 2]

    def pieces(self) -> tuple[int, Ints]:
        """(count, label of each particle) of the connected pieces."""
        return self._core.piece_count(), self._read("pieces", (self.n_particles,), np.int32)

    def skin_weights(self, point: Vector, m: int = 4) -> tuple[Ints, Floats]:
        """Indices and Sumner weights of the m nearest particles of a rest-space point."""
        m = integer("m", m)
        idx = np.empty(m, np.int32)
        w = np.empty(m)
        count = self._core.skin_weights(vector("point", point), m, idx, w)
        return idx[:count], w[:count]

    def __repr__(self) -> str:
        return f"opdeform.Graph(n_particles={self.n_particles}, n_edges={self.n_edges})"
