"""PC2 point cache files (the format Blender's Mesh Cache modifier reads).

Layout, little-endian: char[12] "POINTCACHE2\\0", int32 version (1), int32 point count, float32 start frame,
float32 sample rate (frames per sample), int32 sample count; then, for every sample, point count x 3 float32.
"""

import os
import struct

import numpy as np

MAGIC = b"POINTCACHE2\0"
HEADER = struct.Struct("<12siiffi")
_COUNT_OFFSET = HEADER.size - 4


class PC2Writer:
    """Writes frames one at a time; the header's sample count is kept up to date after every frame, so that
    a bake stopped at any point (ESC, an error) leaves a valid file with the frames written so far."""

    def __init__(self, path, n_points, start=1.0, rate=1.0):
        self.path = path
        self.n_points = int(n_points)
        self.count = 0
        folder = os.path.dirname(path)
        if folder:
            os.makedirs(folder, exist_ok=True)
        self._file = open(path, "wb")
        self._file.write(HEADER.pack(MAGIC, 1, self.n_points, float(start), float(rate), 0))

    def write(self, points):
        pts = np.ascontiguousarray(points, dtype="<f4")
        if pts.size != 3 * self.n_points:
            raise ValueError(f"PC2 frame has {pts.size // 3} points, the file {self.n_points}")
        f = self._file
        f.seek(HEADER.size + self.count * self.n_points * 12)
        f.write(pts.tobytes())
        self.count += 1
        f.seek(_COUNT_OFFSET)
        f.write(struct.pack("<i", self.count))
        f.flush()

    def close(self):
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def read_header(path):
    """(point count, start frame, sample rate, sample count)."""
    with open(path, "rb") as f:
        raw = f.read(HEADER.size)
    if len(raw) < HEADER.size:
        raise ValueError(f"{path}: too short for a PC2 header")
    magic, version, n, start, rate, count = HEADER.unpack(raw)
    if magic != MAGIC or version != 1:
        raise ValueError(f"{path}: not a PC2 file (version 1)")
    return n, start, rate, count


def read(path):
    """(start frame, sample rate, frames as float32 array (samples, points, 3))."""
    n, start, rate, count = read_header(path)
    data = np.fromfile(path, dtype="<f4", offset=HEADER.size, count=count * n * 3)
    if data.size != count * n * 3:
        raise ValueError(f"{path}: truncated ({data.size // 3} points of {count * n})")
    return start, rate, data.reshape(count, n, 3)
