"""opdeform.meshes.character(), the body of issue 24's rigged shot (tests/blender/character_scene.py): one closed
shell of the documented size, standing on the floor, built the same way every time."""

import numpy as np

import opdeform
from opdeform import meshes


def test_one_closed_shell_of_its_size():
    v, t = meshes.character()
    assert meshes._is_closed_manifold(t)
    assert 5500 <= len(v) <= 6000, len(v)
    assert v[:, 2].min() == 0.0 and 2.4 <= v[:, 2].max() <= 2.45, (v[:, 2].min(), v[:, 2].max())
    assert v[:, 1].min() < -0.55  # the belly reaches forward (-y)
    g = opdeform.Graph.from_mesh(v, t, particles=100)
    assert g.pieces()[0] == 1


def test_same_character_bit_for_bit():
    a, b = meshes.character(), meshes.character()
    assert a[0].tobytes() == b[0].tobytes() and np.array_equal(a[1], b[1])
