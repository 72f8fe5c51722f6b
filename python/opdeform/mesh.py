"""Meshes and graphs: graphs built from meshes (``Graph.from_mesh``), linear-blend skinning of a mesh by a
graph (``Skin``), and constraints on mesh vertices (``pin_vertices``, ``add_vertex_direction``).

The C core does the work with the GIL released; this layer checks shapes and dtypes. See docs/mesh.md.
"""

from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from . import _core
from ._arguments import ArrayLike, Floats, Ints, Vector, as_array, integer, number
from ._rebuild import FromArguments
from .graph import MODES, SMALL_PIECES, Graph
from .simulation import Simulation

# an output buffer of deform: float32 (Blender's foreach_set) or float64
Buffer = npt.NDArray[np.floating[Any]]

# The core's numbers for a mesh's small pieces (opdeform/mesh.h, docs/mesh.md): a piece under SMALL_PIECE_RATIO of
# the largest one's voxels is small; a compact or open one with particles of its own has SMALL_PIECE_PARTICLES (all
# of those from at most SMALL_PIECE_SHARE of the count, the next ones' added beyond it up to SMALL_PIECE_EXTRA of
# it), a closed long or flat one up to SHELL_PARTICLES; a card or a beam is linked to its host from its ROOT_LINKS
# particles nearest it.
SMALL_PIECE_RATIO: float = _core.SMALL_PIECE_RATIO
SMALL_PIECE_SHARE: float = _core.SMALL_PIECE_SHARE
SMALL_PIECE_EXTRA: float = _core.SMALL_PIECE_EXTRA
SMALL_PIECE_PARTICLES: int = _core.SMALL_PIECE_PARTICLES
SHELL_PARTICLES: int = _core.SHELL_PARTICLES
ROOT_LINKS: int = _core.ROOT_LINKS

__all__ = ["MODES", "ROOT_LINKS", "SHELL_PARTICLES", "SMALL_PIECES", "SMALL_PIECE_EXTRA", "SMALL_PIECE_PARTICLES",
           "SMALL_PIECE_RATIO", "SMALL_PIECE_SHARE", "Skin", "add_vertex_direction", "graph_from_mesh", "mesh_pieces",
           "pin_vertices"]


def graph_from_mesh(vertices: ArrayLike, triangles: ArrayLike, particles: int = 100, mode: str = "auto",
                    join_pieces: bool = False, voxels_per_particle: int = 100, small_pieces: str = "attach") -> Graph:
    """A graph of ``particles`` ellipsoids covering the mesh (see ``Graph.from_mesh``)."""
    return Graph.from_mesh(vertices, triangles, particles, mode, join_pieces, voxels_per_particle, small_pieces)


def mesh_pieces(graph: Graph) -> tuple[int, Ints | None]:
    """(count, the mesh piece of each particle) of a graph built from a mesh: pieces are the connected pieces
    of the triangle mesh (or groups of them with ``join_pieces``), numbered by their first triangle; a piece
    may have no particles ("attach"). A vertex is skinned only by particles of its own piece, or of the piece
    that carries it. (0, None) for a graph not built from a mesh."""
    count = graph._core.mesh_piece_count()
    return count, graph._read("mesh_pieces", (graph.n_particles,), np.int32) if count else None


def _output(name: str, out: Buffer, n_vertices: int) -> Buffer:
    """Checks a caller's output buffer: float32 or float64, (V,3) or flat (3V,), C-contiguous, writable."""
    if isinstance(out, np.ndarray):
        if out.dtype not in (np.float32, np.float64):
            raise ValueError(f"{name} must be float32 or float64, got {out.dtype}")
        if out.shape not in ((n_vertices, 3), (3 * n_vertices,)):
            raise ValueError(f"{name} must have shape ({n_vertices}, 3) or ({3 * n_vertices},), got {out.shape}")
        if not out.flags.c_contiguous or not out.flags.writeable:
            raise ValueError(f"{name} must be C-contiguous and writable")
    return out


def _rest_normals(normals: ArrayLike, n_vertices: int) -> npt.NDArray[Any]:
    """float32 normals pass as they are (Blender's); anything else becomes float64 (V,3)."""
    arr = np.asarray(normals)
    if arr.dtype == np.float32 and arr.flags.c_contiguous and arr.shape in ((n_vertices, 3), (3 * n_vertices,)):
        return arr
    return as_array("rest_normals", arr.reshape(-1, 3) if arr.ndim == 1 else arr, (n_vertices, 3))


class Skin(FromArguments):
    """A rest mesh bound to a graph: Sumner weights over the ``neighbors`` nearest particles of every vertex
    (METHOD.md, eq. 1), computed once with the GIL released; the vertices of an open sheet of its own beside the
    body (a skirt, in a graph built from a mesh) over half as many again (docs/mesh.md).

    ``triangles`` (T,3) or ``rest_normals`` (V,3) give the rest normals that ``deform`` turns when asked for
    normals (area-weighted vertex normals of the triangles; the normals win when both are given).
    ``threads``: 0..64, 0 = the CPUs this process may use (meshes under 16384 vertices use one thread).
    """

    def __init__(self, graph: Graph, rest_vertices: ArrayLike, neighbors: int = 4, triangles: ArrayLike | None = None,
                 rest_normals: ArrayLike | None = None, threads: int = 0) -> None:
        if not isinstance(graph, Graph):
            raise TypeError("graph must be an opdeform.Graph")
        self.graph = graph
        vertices = as_array("rest_vertices", rest_vertices, (None, 3))
        triangles = None if triangles is None else as_array("triangles", triangles, (None, 3), np.int32)
        normals = None if rest_normals is None else as_array("rest_normals", rest_normals, (len(vertices), 3))
        self._core = _core.Skin(graph._core, vertices, integer("neighbors", neighbors), triangles, normals,
                                integer("threads", threads))
        arrays = tuple(None if a is None else a.copy() for a in (vertices, triangles, normals))
        self._args = (graph, arrays[0], neighbors, *arrays[1:], threads)  # a pickle binds again

    @property
    def n_vertices(self) -> int:
        """The number of skinned vertices."""
        return self._core.n_vertices

    @property
    def neighbors(self) -> int:
        """Columns of ``indices`` and ``weights``: the m asked for, half as many again with a sheet (its vertices
        use them all, the others m and weights 0), or fewer when the graph has fewer particles."""
        return self._core.neighbors

    def _read(self, name: Literal["indices", "weights", "rest_normals"], dtype: npt.DTypeLike,
              width: int) -> npt.NDArray[Any]:
        out = np.empty((self.n_vertices, width), dtype)
        self._core.read(name, out)
        return out

    @property
    def indices(self) -> Ints:
        """(V,m) int32: the bound particles of each vertex, nearest first."""
        return self._read("indices", np.int32, self.neighbors)

    @property
    def weights(self) -> Floats:
        """(V,m) float64: their weights (each row sums to 1)."""
        return self._read("weights", np.float64, self.neighbors)

    @property
    def rest_normals(self) -> Floats | None:
        """(V,3) float64 rest normals given or computed at binding, or None."""
        return self._read("rest_normals", np.float64, 3) if self._core.has_rest_normals else None

    def deform(self, positions: ArrayLike, rotations: ArrayLike, out: Buffer | None = None,
               normals_out: Buffer | None = None, rest_normals: ArrayLike | None = None) -> npt.NDArray[Any]:
        """Deformed vertex positions for particle ``positions`` (n,3) and ``rotations`` (n,3,3), written into
        ``out`` (float32 or float64, (V,3) or flat (3V,), e.g. for Blender's ``foreach_set``; allocated as
        float64 (V,3) when None) and returned. Normals are computed only when ``normals_out`` is given (same
        layouts), from ``rest_normals`` (V,3) or the skin's own rest normals."""
        n, nv = self.graph.n_particles, self.n_vertices
        positions = as_array("positions", positions, (n, 3))
        rotations = as_array("rotations", rotations, (n, 3, 3))
        out = np.empty((nv, 3)) if out is None else _output("out", out, nv)
        if normals_out is not None:
            _output("normals_out", normals_out, nv)
        if rest_normals is not None:
            rest_normals = _rest_normals(rest_normals, nv)
        self._core.deform(positions, rotations, out, normals_out, rest_normals)
        return out

    def shown_offset(self, skinned: Buffer, reference: Buffer | tuple[ArrayLike, ArrayLike], lock: Buffer | None,
                     incoming: Buffer, offset: Buffer, out: Buffer) -> None:
        """What a frame shows of the mesh over its input, in one pass (C): ``offset`` = float32((``skinned`` -
        ``reference``) * ``lock``) and ``out`` = ``incoming`` + ``offset``, added in float32 (``lock`` None: 1).
        skinned, reference and lock are float64, incoming, offset and out float32, each V x 3 values,
        C-contiguous (ValueError otherwise). The same bits as numpy's subtract, multiply, cast and add.
        ``reference`` may instead be particle (positions (n,3), rotations (n,3,3)): their skin, made in the
        same pass and never stored (the same bits as ``deform`` into a float64 array, then this)."""
        if isinstance(reference, tuple):
            n = self.graph.n_particles
            positions, rotations = reference
            reference = (as_array("positions", positions, (n, 3)), as_array("rotations", rotations, (n, 3, 3)))
        self._core.shown_offset(skinned, reference, lock, incoming, offset, out)

    def deform_sim(self, sim: Simulation, out: Buffer | None = None, normals_out: Buffer | None = None,
                   push_out: bool = True) -> npt.NDArray[Any]:
        """``deform`` with the simulation's current positions and rotations; with ``push_out`` the vertices
        inside its colliders or below its floor are moved to their surface (``Simulation.push_out``,
        docs/contact.md)."""
        out = self.deform(sim.positions, sim.rotations, out, normals_out)
        if push_out:
            flat = out.reshape(-1, 3)
            flat[:] = sim.push_out(flat)
        return out

    def __repr__(self) -> str:
        return f"opdeform.Skin(n_vertices={self.n_vertices}, neighbors={self.neighbors})"


def pin_vertices(sim: Simulation, rest_vertices: ArrayLike, indices: ArrayLike, weights: ArrayLike | None = None,
                 weight: float | None = None) -> list[int]:
    """Pins mesh vertices where they are now: one position constraint per vertex of ``indices``, of weight
    ``weight`` (default: ``sim.default_weight()``) times the vertex's entry of ``weights`` (e.g. a painted
    vertex group; default 1). A vertex of weight 0 is not pinned. Returns the ids of the constraints added,
    in the order of ``indices``. All or nothing: when one vertex is refused, none stays pinned."""
    if not isinstance(sim, Simulation):
        raise TypeError("sim must be an opdeform.Simulation")
    vertices = as_array("rest_vertices", rest_vertices, (None, 3))
    idx = as_array("indices", indices, (None,), np.int64)
    bad = np.flatnonzero((idx < 0) | (idx >= len(vertices)))
    if bad.size:
        raise ValueError(f"indices[{bad[0]}] = {idx[bad[0]]} is out of range: there are {len(vertices)} vertices")
    points = vertices[idx]
    scale = np.ones(len(points)) if weights is None else as_array("weights", weights, (len(points),))
    bad = np.flatnonzero(~(scale >= 0.0) | ~np.isfinite(scale))
    if bad.size:
        raise ValueError(f"weights[{bad[0]}] = {scale[bad[0]]} must be finite and >= 0")
    base = sim.default_weight("position") if weight is None else number("weight", weight)
    ids = []
    try:
        for p, w in zip(points, scale):
            if w > 0.0:
                ids.append(sim.add_position_constraint(p, None, base * float(w)))
    except BaseException:  # all or nothing: a refused vertex (or Ctrl-C) takes back the pins added before it
        for cid in ids:
            sim.remove_constraint(cid)
        raise
    return ids


def add_vertex_direction(sim: Simulation, rest_vertices: ArrayLike, index: int, direction: Vector,
                         target: Vector | None = None, weight: float | None = None) -> int:
    """A direction constraint at mesh vertex ``index`` on the rest ``direction`` (e.g. its normal): turns it
    towards ``target`` (None: keeps where it points now). Returns the constraint id."""
    if not isinstance(sim, Simulation):
        raise TypeError("sim must be an opdeform.Simulation")
    vertices = as_array("rest_vertices", rest_vertices, (None, 3))
    index = integer("index", index)
    if not 0 <= index < len(vertices):
        raise ValueError(f"index = {index} is out of range: there are {len(vertices)} vertices")
    return sim.add_direction_constraint(vertices[index], direction, target, weight)
