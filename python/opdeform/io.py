"""OBJ and PLY files.

``read_obj`` / ``read_ply`` return ``(vertices, triangles)``: float64 (V,3) and int32 (T,3), polygons
fan-triangulated, other data (normals, texture coordinates, colours) skipped. ``write_obj`` writes text with
17 significant digits (exact round trip), ``write_ply`` binary little-endian PLY (float64 vertices).
``read`` and ``write`` pick the format from the file name. Parsing and formatting run in the C core with
the GIL released; a malformed file raises ValueError naming the file and the problem, and so does anything
but a regular file (a FIFO, a device such as /dev/zero, a directory). OBJ is ASCII or UTF-8 text with LF,
CRLF or old-Mac CR line ends; UTF-16 or binary data (a NUL byte) is refused.
"""

import os
import stat

import numpy as np

from . import _core
from ._arguments import as_array

__all__ = ["read", "read_obj", "read_ply", "write", "write_obj", "write_ply"]


def _read(path, fmt):
    # Opened without blocking (a FIFO would wait for a writer forever) and checked before reading: only a
    # regular file has an end (/dev/zero would fill the memory).
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError(f"{os.fspath(path)}: not a regular file (a directory, FIFO, socket or device)")
        with os.fdopen(fd, "rb", closefd=False) as f:
            data = f.read()
    finally:
        os.close(fd)
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
