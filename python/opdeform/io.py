"""OBJ and PLY files.

``read_obj`` / ``read_ply`` return ``(vertices, triangles)``: float64 (V,3) and int32 (T,3), polygons
fan-triangulated, other data (normals, texture coordinates, colours) skipped. ``write_obj`` writes text with
17 significant digits (exact round trip), ``write_ply`` binary little-endian PLY (float64 vertices).
``read`` and ``write`` pick the format from the file name. Parsing and formatting run in the C core with
the GIL released; a malformed file raises ValueError naming the file and the problem, and so does anything
but a regular file (a FIFO, a device such as /dev/zero, a directory) and a coordinate that is not finite
(nan, inf, 1e400); the writers refuse non-finite vertices. OBJ is ASCII or UTF-8 text with LF,
CRLF or old-Mac CR line ends; UTF-16 or binary data (a NUL byte) is refused.

PC2 point caches (``PC2Writer``, ``read_pc2``, ``write_pc2``, ``pc2_header``) and ``atomic_path`` (a file appears
under its name only when complete) are in the last section.
"""

import contextlib
import os
import secrets
import socket
import struct
import stat
from collections.abc import Iterator
from types import TracebackType
from typing import IO, Any, Literal

import numpy as np

from . import _core
from ._arguments import ArrayLike, Floats, Ints, as_array, integer

__all__ = ["read", "read_obj", "read_ply", "read_regular", "write", "write_obj", "write_ply", "OutputBusy",
           "PC2Writer", "atomic_path", "exclusive", "lock_name", "partial_files", "partial_name", "pc2_header",
           "read_pc2", "write_pc2"]

FilePath = str | os.PathLike[str]  # a file's name: a str or a pathlib.Path
Mesh = tuple[Floats, Ints]  # (vertices (V,3) float64, triangles (T,3) int32)
Format = Literal["obj", "ply"]


def read_regular(path: FilePath) -> bytes:
    """The bytes of a regular file; ValueError naming it for anything else. Opened without blocking (a FIFO
    would wait for a writer forever) and checked before reading: only a regular file has an end (/dev/zero
    would fill the memory)."""
    not_regular = f"{os.fspath(path)}: not a regular file (a directory, FIFO, socket or device)"
    if os.path.isdir(path):  # Windows opens no directory (PermissionError)
        raise ValueError(not_regular)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError(not_regular)
        with os.fdopen(fd, "rb", closefd=False) as f:
            return f.read()
    finally:
        os.close(fd)


def _read(path: FilePath, fmt: Format) -> Mesh:
    try:
        vertices, triangles = _core.parse_mesh(read_regular(path), fmt)
    except ValueError as exc:
        raise ValueError(f"{os.fspath(path)}: {exc}") from None
    points = np.frombuffer(vertices, np.float64).reshape(-1, 3)
    bad = np.flatnonzero(~np.isfinite(points).all(axis=1))
    if len(bad):  # nan, inf, or a number past float64 (1e400)
        raise ValueError(f"{os.fspath(path)}: vertex {bad[0]} (from 0) is not finite: {points[bad[0]].tolist()}")
    return points, np.frombuffer(triangles, np.int32).reshape(-1, 3)


def _finite(name: str, array: Floats) -> Floats:
    bad = np.flatnonzero(~np.isfinite(array).all(axis=1))
    if len(bad):
        raise ValueError(f"{name}[{bad[0]}] is not finite: {array[bad[0]].tolist()}")
    return array


def _write(path: FilePath, vertices: ArrayLike, triangles: ArrayLike, fmt: Format) -> None:
    points = _finite("vertices", as_array("vertices", vertices, (None, 3)))
    faces = as_array("triangles", triangles, (None, 3), np.int32)
    data = _core.format_mesh(fmt, points, faces)
    with open(path, "wb") as f:
        f.write(data)


def read_obj(path: FilePath) -> Mesh:
    """(vertices (V,3) float64, triangles (T,3) int32) of an OBJ file."""
    return _read(path, "obj")


def read_ply(path: FilePath) -> Mesh:
    """(vertices (V,3) float64, triangles (T,3) int32) of an ascii or binary PLY file."""
    return _read(path, "ply")


def write_obj(path: FilePath, vertices: ArrayLike, triangles: ArrayLike) -> None:
    _write(path, vertices, triangles, "obj")


def write_ply(path: FilePath, vertices: ArrayLike, triangles: ArrayLike) -> None:
    _write(path, vertices, triangles, "ply")


def _format_of(path: FilePath) -> Format:
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in (".obj", ".ply"):
        raise ValueError(f"{os.fspath(path)}: the file name must end in .obj or .ply")
    return "obj" if ext == ".obj" else "ply"


def read(path: FilePath) -> Mesh:
    """read_obj or read_ply, by the file name's extension."""
    return _read(path, _format_of(path))


def write(path: FilePath, vertices: ArrayLike, triangles: ArrayLike) -> None:
    """write_obj or write_ply, by the file name's extension."""
    _write(path, vertices, triangles, _format_of(path))


# -- complete-or-nothing files and PC2 point caches ----------------------------------------------------------
# A file written through ``atomic_path`` appears under its name only once complete: it is written to a
# temporary name beside it (same folder, same extension) and renamed. PC2 is the point cache Blender's Mesh
# Cache modifier reads (little-endian: char[12] "POINTCACHE2\0", int32 version 1, int32 points, float32
# start frame, float32 sample rate, int32 samples; then samples x points x 3 float32).

PC2_MAGIC = b"POINTCACHE2\0"
PC2_HEADER = struct.Struct("<12siiffi")


def partial_name(path: FilePath) -> str:
    """A temporary name to write ``path`` under, unique to the caller: ``a/b.pc2`` -> ``a/b.part-PID-RANDOM.pc2``
    (the process id and 32 random bits, so that two writers of one file, in two processes or two threads,
    never share a partial file)."""
    root, ext = os.path.splitext(os.fspath(path))
    return f"{root}.part-{os.getpid()}-{secrets.token_hex(4)}{ext}"


def partial_files(path: FilePath) -> list[str]:
    """The partial files of ``path`` in its folder (``partial_name``'s, whoever wrote them)."""
    folder, tail = os.path.split(os.fspath(path))
    root, ext = os.path.splitext(tail)
    found = os.listdir(folder or ".") if os.path.isdir(folder or ".") else []
    return sorted(os.path.join(folder, f) for f in found if f.startswith(root + ".part-") and f.endswith(ext))


@contextlib.contextmanager
def atomic_path(path: FilePath) -> Iterator[str]:
    """Yields the temporary name to write ``path`` under (``partial_name``); renames it to ``path`` when the
    block completes, removes it when the block raises."""
    part = partial_name(path)
    try:
        yield part
    except BaseException:
        if os.path.exists(part):
            os.remove(part)
        raise
    os.replace(part, path)


class OutputBusy(OSError):
    """Another writer holds an output's lock (``exclusive``)."""


def lock_name(path: FilePath) -> str:
    """The lock file of an output: ``a/b.pc2`` -> ``a/.b.pc2.lock``."""
    folder, tail = os.path.split(os.fspath(path))
    return os.path.join(folder, f".{tail}.lock")


@contextlib.contextmanager
def exclusive(path: FilePath, lock: FilePath | None = None) -> Iterator[FilePath]:
    """Holds the lock of an output (``lock``, by default ``lock_name(path)``, created with O_EXCL and holding
    this host's name and process id) for the block; OutputBusy naming the holder when another live writer has
    it. A lock left by a process of this host that has ended (killed mid-bake) is taken over; one from another
    host (whose processes cannot be checked from here) or one that cannot be read stays until removed, and the
    message says which file to delete."""
    lock = lock or lock_name(path)
    for attempt in range(2):
        try:
            fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            break
        except FileExistsError:
            host, pid = _lock_holder(lock)
            if attempt or host != socket.gethostname() or pid is None or _alive(pid):
                raise _busy(path, lock, host, pid) from None
            os.remove(lock)
    try:
        os.write(fd, f"{socket.gethostname()} {os.getpid()}\n".encode())
    finally:
        os.close(fd)
    try:
        yield lock
    finally:
        os.remove(lock)


def _busy(path: FilePath, lock: FilePath, host: str, pid: int | None) -> OutputBusy:
    """OutputBusy naming the output, the lock, its holder and how to clear the lock."""
    if pid is None:
        holder = "a writer whose lock cannot be read"
    elif host != socket.gethostname():
        holder = f"process {pid} on {host}, another host: whether it still runs cannot be checked from here"
    else:
        holder = f"process {pid} on {host}"
    return OutputBusy(f"{os.fspath(path)} is being baked by {holder} (lock {os.fspath(lock)}); if no bake of it "
                      f"runs, delete {os.fspath(lock)} and bake again")


def _lock_holder(lock: FilePath) -> tuple[str, int | None]:
    """(host, pid) written in a lock file; pid None when it cannot be read."""
    try:
        with open(lock, "rb") as f:
            host, pid = f.read(300).decode("utf-8", "replace").split()
        return host, int(pid)
    except (OSError, ValueError):
        return "an unknown host", None


def _alive(pid: int) -> bool:
    """Whether a process of this host runs (a zombie, killed and not yet reaped, does not)."""
    if os.name == "nt":
        return _alive_on_windows(pid)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except (OSError, IndexError):
        return True


def _alive_on_windows(pid: int) -> bool:
    """OpenProcess and GetExitCodeProcess (on Windows os.kill(pid, 0) would end the process)."""
    import ctypes
    kernel32 = ctypes.WinDLL("kernel32", use_last_error=True)  # type: ignore[attr-defined]  # Windows only
    kernel32.OpenProcess.restype = ctypes.c_void_p
    handle = kernel32.OpenProcess(0x1000, False, pid)  # PROCESS_QUERY_LIMITED_INFORMATION
    if not handle:
        # ERROR_ACCESS_DENIED: another user's live process
        return bool(ctypes.get_last_error() == 5)  # type: ignore[attr-defined]
    code = ctypes.c_ulong()
    try:
        known = kernel32.GetExitCodeProcess(ctypes.c_void_p(handle), ctypes.byref(code))
    finally:
        kernel32.CloseHandle(ctypes.c_void_p(handle))
    return bool(not known or code.value == 259)  # STILL_ACTIVE


class PC2Writer:
    """Writes PC2 frames one at a time, the header's sample count kept current after each, so that a file
    cut short at any frame is valid. ``atomic``: frames go to ``partial`` (a ``partial_name`` of this writer's
    own), renamed to ``path`` by ``close()`` (an exception in a ``with`` block leaves the partial file, for a
    resume); otherwise straight to ``path`` (the add-on's bake, played back while it runs). ``keep``: continue
    the partial file ``resume`` (an earlier writer's, taken over: renamed to this writer's) after its first
    ``keep`` frames."""

    def __init__(self, path: FilePath, n_points: int, start: float = 1.0, rate: float = 1.0, atomic: bool = True,
                 keep: int = 0, resume: FilePath | None = None) -> None:
        self.path = os.fspath(path)
        self.n_points = integer("n_points", n_points)
        self.count = integer("keep", keep)
        self.partial = partial_name(self.path) if atomic else self.path
        self._file: IO[bytes] | None
        folder = os.path.dirname(self.path)
        if folder:
            os.makedirs(folder, exist_ok=True)
        if self.count:
            self._resume(os.fspath(resume) if resume is not None else self.partial)
        else:
            self._file = open(self.partial, "wb")
            self._file.write(PC2_HEADER.pack(PC2_MAGIC, 1, self.n_points, float(start), float(rate), 0))

    def _resume(self, earlier: str) -> None:
        found = pc2_header(earlier)
        if found[0] != self.n_points or found[3] < self.count:
            raise ValueError(f"{earlier}: holds {found[3]} frames of {found[0]} points, cannot keep "
                             f"{self.count} of {self.n_points}")
        if earlier != self.partial:
            os.replace(earlier, self.partial)
        self._file = open(self.partial, "r+b")
        self._file.truncate(PC2_HEADER.size + self.count * self.n_points * 12)

    def write(self, points: ArrayLike) -> None:
        pts = np.ascontiguousarray(points, dtype="<f4")
        if pts.size != 3 * self.n_points:
            raise ValueError(f"points: a PC2 frame of {self.path} has {self.n_points} points, got {pts.size // 3}")
        f = self._file
        if f is None:
            raise ValueError(f"{self.path}: the PC2 writer is closed")
        f.seek(PC2_HEADER.size + self.count * self.n_points * 12)
        f.write(pts.tobytes())
        self.count += 1
        f.seek(PC2_HEADER.size - 4)
        f.write(struct.pack("<i", self.count))
        f.flush()

    def close(self) -> None:
        """Closes the file; an atomic writer's file then takes its name."""
        if self._file is not None:
            self._file.close()
            self._file = None
            if self.partial != self.path:
                os.replace(self.partial, self.path)

    def __enter__(self) -> "PC2Writer":
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 trace: TracebackType | None) -> None:
        if kind is None:
            self.close()
        elif self._file is not None:
            self._file.close()
            self._file = None


def pc2_header(path: FilePath) -> tuple[int, float, float, int]:
    """(point count, start frame, sample rate, sample count) of a PC2 file."""
    with open(path, "rb") as f:
        raw = f.read(PC2_HEADER.size)
    if len(raw) < PC2_HEADER.size:
        raise ValueError(f"{os.fspath(path)}: too short for a PC2 header")
    magic, version, n, start, rate, count = PC2_HEADER.unpack(raw)
    if magic != PC2_MAGIC or version != 1:
        raise ValueError(f"{os.fspath(path)}: not a PC2 file (version 1)")
    return n, start, rate, count


def read_pc2(path: FilePath) -> tuple[float, float, np.ndarray[Any, np.dtype[np.float32]]]:
    """(start frame, sample rate, frames float32 (samples, points, 3)) of a PC2 file."""
    n, start, rate, count = pc2_header(path)
    data = np.fromfile(path, dtype="<f4", offset=PC2_HEADER.size, count=count * n * 3)
    if data.size != count * n * 3:
        raise ValueError(f"{os.fspath(path)}: truncated ({data.size // 3} points of {count * n})")
    return start, rate, data.reshape(count, n, 3)


def write_pc2(path: FilePath, frames: ArrayLike, start: float = 1.0, rate: float = 1.0) -> None:
    """All frames (samples, points, 3) at once, complete or not at all."""
    samples = as_array("frames", frames, (None, None, 3))
    with PC2Writer(path, samples.shape[1], start, rate) as writer:
        for points in samples:
            writer.write(points)
