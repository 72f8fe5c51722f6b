"""Files from elsewhere (issue 28, left from the last round): opdeform.mpm.read_ply on a FIFO and on damaged
headers is a ValueError naming the file (before: blocked forever; bare int() errors, MemoryError); io.read_obj
refuses non-finite coordinates and write_obj / write_ply refuse to write them."""

import os
import threading

import numpy as np
import pytest

from opdeform import io, mpm


def test_mpm_read_ply_of_a_fifo_is_refused_without_blocking(tmp_path):
    path = tmp_path / "fifo.ply"
    os.mkfifo(path)
    result = []
    reader = threading.Thread(target=lambda: result.append(_error(mpm.read_ply, path)), daemon=True)
    reader.start()
    reader.join(5)
    assert result and "not a regular file" in result[0] and str(path) in result[0]


def _error(call, *args):
    try:
        call(*args)
    except ValueError as exc:
        return str(exc)
    return "no error"


@pytest.mark.parametrize("count, problem", [("-3", "vertex count"), ("1.5", "vertex count"),
                                            (str(2 ** 62), "truncated"), ("x", "vertex count"),
                                            ("2", "truncated")])
def test_mpm_read_ply_of_a_damaged_header_names_the_file(tmp_path, count, problem):
    path = tmp_path / "a.ply"
    mpm.write_ply(path, np.zeros((1, 3)), np.tile([1.0, 0, 0, 0], (1, 1)))
    path.write_bytes(path.read_bytes().replace(b"element vertex 1", f"element vertex {count}".encode()))
    message = _error(mpm.read_ply, path)
    assert str(path) in message and problem in message, message


def test_mpm_read_ply_of_binary_junk_names_the_file(tmp_path):
    path = tmp_path / "b.ply"
    path.write_bytes(b"ply\n\xff\xfe" + b"\x00" * 100)
    assert str(path) in _error(mpm.read_ply, path)


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e400"])
def test_read_obj_refuses_non_finite_coordinates(tmp_path, value):
    path = tmp_path / "a.obj"
    path.write_text(f"v 0 0 0\nv 1 0 0\nv 0 {value} 0\nf 1 2 3\n")
    message = _error(io.read_obj, path)
    assert str(path) in message and "vertex 2" in message and "not finite" in message, message


@pytest.mark.parametrize("writer", [io.write_obj, io.write_ply])
def test_writers_refuse_non_finite_coordinates(tmp_path, writer):
    path = tmp_path / "a.out"
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]])
    message = _error(writer, path, vertices, [[0, 1, 2]])
    assert "vertices" in message and "not finite" in message and not path.exists(), message


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_elements_without_properties_are_skipped_at_once(tmp_path, fmt):
    # 14 elements of 715,827,882 items (the largest count) and no property: ~500 bytes that made io.read_ply
    # loop 10^10 times (6.4 s here, 9-142 s in issue 28); such an element holds no data in either format
    path = tmp_path / f"{fmt}.ply"
    empty = "".join(f"element e{k} 715827882\n" for k in range(14))
    body = (b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" if fmt == "ascii"
            else np.array([0, 0, 0, 1, 0, 0, 0, 1, 0], "<f4").tobytes() + b"\x03" + np.arange(3, dtype="<i4").tobytes())
    path.write_bytes(f"ply\nformat {fmt} 1.0\n{empty}element vertex 3\nproperty float x\nproperty float y\n"
                     f"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                     .encode() + body)
    result = []
    reader = threading.Thread(target=lambda: result.append(io.read_ply(path)), daemon=True)
    reader.start()
    reader.join(2)
    assert result, "still reading after 2 s"
    vertices, triangles = result[0]
    assert vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]] and triangles.tolist() == [[0, 1, 2]]
