"""OBJ and PLY files.

``read_obj`` / ``read_ply`` return ``(vertices, triangles)``: float64 (V,3) and int32 (T,3), polygons
fan-triangulated, other data (normals, texture coordinates, colours) skipped. ``write_obj`` writes text with
17 significant digits (exact round trip), ``write_ply`` binary little-endian PLY (float64 vertices).
``read`` and ``write`` pick the format from the file name. Parsing and formatting run in the C core with
the GIL released; a malformed file raises ValueError naming the file and the problem.
"""

import os

import numpy as np

from . import _core
from ._arguments import as_array

__all__ = ["read", "read_obj", "read_ply", "write", "write_obj", "write_ply"]


def _read(path, fmt):
    with open(path, "rb") as f:
        data = f.read()
    try:
        vertices, triangles = _core.parse_mesh(data, fmt)
    except ValueError as exc:
        raise ValueError(f"{os.fspath(path)}: {exc}") from None
    return np.frombuffer(vertices, np.float64).reshape(-1, 3), np.frombuffer(triangles, np.int32).reshape(-1, 3)


def _write(path, vertices, triangles, fmt):
    vertices = as_array("vertices", vertices, (None, 3))
    triangles = as_array("triangles", triangles, (None, 3), np.int32)
    data = _core.format_mesh(fmt, vertices, triangles)
    with open(path, "wb") as f:
        f.write(data)


def read_obj(path):
    """(vertices (V,3) float64, triangles (T,3) int32) of an OBJ file."""
    return _read(path, "obj")


def read_ply(path):
    """(vertices (V,3) float64, triangles (T,3) int32) of an ascii or binary PLY file."""
    return _read(path, "ply")


def write_obj(path, vertices, triangles):
    _write(path, vertices, triangles, "obj")


def write_ply(path, vertices, triangles):
    _write(path, vertices, triangles, "ply")


def _format_of(path):
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in (".obj", ".ply"):
        raise ValueError(f"{os.fspath(path)}: the file name must end in .obj or .ply")
    return ext[1:]


def read(path):
    """read_obj or read_ply, by the file name's extension."""
    return _read(path, _format_of(path))


def write(path, vertices, triangles):
    """write_obj or write_ply, by the file name's extension."""
    _write(path, vertices, triangles, _format_of(path))
