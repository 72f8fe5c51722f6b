"""OBJ and PLY files.

``read_obj`` / ``read_ply`` return ``(vertices, triangles)``: float64 (V,3) and int32 (T,3), polygons
fan-triangulated, other data (normals, texture coordinates, colours) skipped. ``write_obj`` writes text with
17 significant digits (exact round trip), ``write_ply`` binary little-endian PLY (float64 vertices).
``read`` and ``write`` pick the format from the file name. Parsing and formatting run in the C core with
the GIL released; a malformed file raises ValueError naming the file and the problem, and so does anything
but a regular file (a FIFO, a device such as /dev/zero, a directory). OBJ is ASCII or UTF-8 text with LF,
CRLF or old-Mac CR line ends; UTF-16 or binary data (a NUL byte) is refused.

PC2 point caches (``PC2Writer``, ``read_pc2``, ``write_pc2``, ``pc2_header``) and ``atomic_path`` (a file appears
under its name only when complete) are in the last section.
"""

import contextlib
import os
import struct
import stat

import numpy as np

from . import _core
from ._arguments import as_array, integer

__all__ = ["read", "read_obj", "read_ply", "write", "write_obj", "write_ply",
           "PC2Writer", "atomic_path", "partial_name", "pc2_header", "read_pc2", "write_pc2"]


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


# -- complete-or-nothing files and PC2 point caches ----------------------------------------------------------
# A file written through ``atomic_path`` appears under its name only once complete: it is written to a
# temporary name beside it (same folder, same extension) and renamed. PC2 is the point cache Blender's Mesh
# Cache modifier reads (little-endian: char[12] "POINTCACHE2\0", int32 version 1, int32 points, float32
# start frame, float32 sample rate, int32 samples; then samples x points x 3 float32).

PC2_MAGIC = b"POINTCACHE2\0"
PC2_HEADER = struct.Struct("<12siiffi")


def partial_name(path):
    """The temporary name a file is written under: ``a/b.pc2`` -> ``a/b.part.pc2``."""
    root, ext = os.path.splitext(os.fspath(path))
    return root + ".part" + ext


@contextlib.contextmanager
def atomic_path(path):
    """Yields the temporary name to write ``path`` under (``partial_name`` with this process's id, so that
    two processes writing the same file never rename each other's part); renames it to ``path`` when the
    block completes, removes it when the block raises."""
    root, ext = os.path.splitext(partial_name(path))
    part = f"{root}{os.getpid()}{ext}"
    try:
        yield part
    except BaseException:
        if os.path.exists(part):
            os.remove(part)
        raise
    os.replace(part, path)


class PC2Writer:
    """Writes PC2 frames one at a time, the header's sample count kept current after each, so that a file
    cut short at any frame is valid. ``atomic``: frames go to ``partial_name(path)``, renamed to ``path`` by
    ``close()`` (an exception in a ``with`` block leaves the partial file, for a resume); otherwise straight to
    ``path`` (the add-on's bake, played back while it runs). ``keep``: continue a partial file after its
    first ``keep`` frames."""

    def __init__(self, path, n_points, start=1.0, rate=1.0, atomic=True, keep=0):
        self.path = os.fspath(path)
        self.n_points = integer("n_points", n_points)
        self.count = integer("keep", keep)
        self._target = partial_name(self.path) if atomic else self.path
        folder = os.path.dirname(self.path)
        if folder:
            os.makedirs(folder, exist_ok=True)
        if self.count:
            found = pc2_header(self._target)
            if found[0] != self.n_points or found[3] < self.count:
                raise ValueError(f"{self._target}: holds {found[3]} frames of {found[0]} points, cannot keep "
                                 f"{self.count} of {self.n_points}")
            self._file = open(self._target, "r+b")
            self._file.truncate(PC2_HEADER.size + self.count * self.n_points * 12)
        else:
            self._file = open(self._target, "wb")
            self._file.write(PC2_HEADER.pack(PC2_MAGIC, 1, self.n_points, float(start), float(rate), 0))

    def write(self, points):
        pts = np.ascontiguousarray(points, dtype="<f4")
        if pts.size != 3 * self.n_points:
            raise ValueError(f"points: a PC2 frame of {self.path} has {self.n_points} points, got {pts.size // 3}")
        f = self._file
        f.seek(PC2_HEADER.size + self.count * self.n_points * 12)
        f.write(pts.tobytes())
        self.count += 1
        f.seek(PC2_HEADER.size - 4)
        f.write(struct.pack("<i", self.count))
        f.flush()

    def close(self):
        """Closes the file; an atomic writer's file then takes its name."""
        if self._file is not None:
            self._file.close()
            self._file = None
            if self._target != self.path:
                os.replace(self._target, self.path)

    def __enter__(self):
        return self

    def __exit__(self, kind, value, trace):
        if kind is None:
            self.close()
        elif self._file is not None:
            self._file.close()
            self._file = None


def pc2_header(path):
    """(point count, start frame, sample rate, sample count) of a PC2 file."""
    with open(path, "rb") as f:
        raw = f.read(PC2_HEADER.size)
    if len(raw) < PC2_HEADER.size:
        raise ValueError(f"{os.fspath(path)}: too short for a PC2 header")
    magic, version, n, start, rate, count = PC2_HEADER.unpack(raw)
    if magic != PC2_MAGIC or version != 1:
        raise ValueError(f"{os.fspath(path)}: not a PC2 file (version 1)")
    return n, start, rate, count


def read_pc2(path):
    """(start frame, sample rate, frames float32 (samples, points, 3)) of a PC2 file."""
    n, start, rate, count = pc2_header(path)
    data = np.fromfile(path, dtype="<f4", offset=PC2_HEADER.size, count=count * n * 3)
    if data.size != count * n * 3:
        raise ValueError(f"{os.fspath(path)}: truncated ({data.size // 3} points of {count * n})")
    return start, rate, data.reshape(count, n, 3)


def write_pc2(path, frames, start=1.0, rate=1.0):
    """All frames (samples, points, 3) at once, complete or not at all."""
    frames = as_array("frames", frames, (None, None, 3))
    with PC2Writer(path, frames.shape[1], start, rate) as writer:
        for points in frames:
            writer.write(points)
