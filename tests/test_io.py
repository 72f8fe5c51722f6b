"""opdeform.io: OBJ and PLY in the forms exporters write them, exact round trips, and clear errors."""

import struct

import numpy as np
import pytest

import opdeform
from opdeform import io, meshes


@pytest.mark.parametrize("ext", ["obj", "ply"])
def test_round_trip_is_exact(tmp_path, ext):
    v, t = meshes.creature()
    v = v + np.random.default_rng(0).normal(0, 1e-3, v.shape)  # digits that need all 17
    path = tmp_path / f"creature.{ext}"
    io.write(path, v, t)
    rv, rt = io.read(path)
    assert rv.dtype == np.float64 and rt.dtype == np.int32
    np.testing.assert_array_equal(rv, v)
    np.testing.assert_array_equal(rt, t)
    rv[0] = 0.0  # the arrays are the caller's, writable


def test_obj_polygons_indices_and_skipped_lines(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text(
        "# a comment\n"
        "mtllib x.mtl\n"
        "o thing\n"
        "v 0 0 0\n"
        "v 1 0 0 1.0\n"  # optional w
        "v 1 1 0\n"
        "v 0 1 0\n"
        "vt 0 0\n"
        "vn 0 0 1\n"
        "v\t0.5 0.5 1e-1\n"
        "usemtl red\ns off\n"
        "f 1/1/1 2/1/1 3//1 4\n"  # a quad with texture/normal indices
        "f -5 -4 -1\r\n"  # relative indices, CRLF
        "l 1 2\n"
    )
    v, t = io.read_obj(path)
    np.testing.assert_array_equal(v, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0.1]])
    np.testing.assert_array_equal(t, [[0, 1, 2], [0, 2, 3], [0, 1, 4]])


def test_ply_ascii_with_extra_properties_and_elements(tmp_path):
    path = tmp_path / "ascii.ply"
    path.write_text(
        "ply\nformat ascii 1.0\ncomment made by hand\n"
        "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty uchar red\n"
        "element face 1\nproperty list uchar int vertex_indices\nproperty int flags\n"
        "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
        "end_header\n"
        "0 0 0 0.5 255\n1 0 0 0.5 255\n1 1 0 0.5 255\n0 1 0 0.5 255\n"
        "4 0 1 2 3 7\n"
        "0 1\n"
    )
    v, t = io.read_ply(path)
    np.testing.assert_array_equal(v, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(t, [[0, 1, 2], [0, 2, 3]])


def test_ply_binary_big_endian(tmp_path):
    path = tmp_path / "big.ply"
    header = ("ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
              "property double z\nproperty ushort value\nelement face 1\nproperty list uchar uint vertex_index\n"
              "end_header\n").encode()
    body = b"".join(struct.pack(">dddH", *p, 9) for p in ([0, 0, 0], [2, 0, 0], [0, 3, 0.25]))
    body += struct.pack(">BIII", 3, 2, 1, 0)
    path.write_bytes(header + body)
    v, t = io.read_ply(path)
    np.testing.assert_array_equal(v, [[0, 0, 0], [2, 0, 0], [0, 3, 0.25]])
    np.testing.assert_array_equal(t, [[2, 1, 0]])


def test_written_ply_is_standard_binary(tmp_path):
    path = tmp_path / "out.ply"
    io.write_ply(path, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    data = path.read_bytes()
    header, body = data.split(b"end_header\n")
    assert b"format binary_little_endian 1.0" in header and b"element vertex 3" in header
    assert struct.unpack("<9d", body[:72])[3] == 1.0
    assert struct.unpack("<B3i", body[72:]) == (3, 0, 1, 2)


MALFORMED = [
    ("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "refers to vertex 3"),
    ("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "line 4"),
    ("short.obj", "v 0 0\n", "line 1"),
    ("edge.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "at least 3"),
    ("noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "end_header"),
    ("noz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
     "x, y or z"),
    ("early.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
     "property float z\nend_header\n0 0 0\n", "ends early"),
    ("notply.ply", "solid stl\n", "start with 'ply'"),
]


# ids by file name: an id holding the contents' newlines did not match across platforms (JUnit XML)
@pytest.mark.parametrize("name,content,message", MALFORMED, ids=[case[0] for case in MALFORMED])
def test_malformed_files_are_value_errors_naming_the_file(tmp_path, name, content, message):
    path = tmp_path / name
    path.write_bytes(content.encode())  # the same bytes on every OS (Windows' text mode writes \r\n)
    with pytest.raises(ValueError, match=message) as info:
        io.read(path)
    assert name in str(info.value)


def test_truncated_binary_ply(tmp_path):
    path = tmp_path / "cut.ply"
    io.write_ply(path, *meshes.capsule())
    path.write_bytes(path.read_bytes()[:-5])
    with pytest.raises(ValueError, match="ends before"):
        io.read_ply(path)


def test_file_names_and_missing_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        io.read_obj(tmp_path / "missing.obj")
    with pytest.raises(ValueError, match=r"\.obj or \.ply"):
        io.read(tmp_path / "mesh.stl")
    with pytest.raises(ValueError, match="refers to vertex"):
        io.write_obj(tmp_path / "bad.obj", np.eye(3), [[0, 1, 3]])


def test_a_read_mesh_feeds_the_whole_pipeline(tmp_path):
    path = tmp_path / "bar.ply"
    io.write_ply(path, *meshes.bar())
    v, t = io.read_ply(path)
    g = opdeform.Graph.from_mesh(v, t, particles=20, mode="chain")
    skin = opdeform.Skin(g, v, triangles=t)
    np.testing.assert_allclose(skin.deform(g.centers, np.tile(np.eye(3), (20, 1, 1))), v, atol=1e-14)
