"""Jiggle that rides the animation (issue 24), inside Blender (run by tests/test_addon_character.py through
runner.py, in Debian's Blender and in the bpy module): the rigged, hopping character of character_scene.py
with OPDeform enabled as an artist does it (Goal on, the "follow" group picked, every other setting at its
default), measured against the armature-only pose (character_measure.py). The follow-1 core stays on the
rig; the loose parts (ear tips, belly front, tail tip) jiggle during the hops and settle after the motion
stops; nothing stretches, nothing goes through the floor, the mesh itself is never written, and a bake
plays back what live playback showed."""

import os

import bpy
import numpy as np

import character_measure as M
import character_scene as C
import helpers as H

CORE_MM = 1.0  # the follow-1 region from the armature-only pose
SECONDARY = 0.02  # the loose parts' motion during the hops, share of the body's size
STRETCH = 1.5  # longest edge over its armature-only length
FLOOR_MM = 1.0  # the lowest vertex may be this far under the floor (rounding), no more


def _played():
    """The character at the defaults played through its clip; (measure, summary)."""
    m = M.shot()
    return m, M.play(m)


def test_core_stays_on_the_rig():
    _, s = _played()
    assert 1e3 * s["core"] <= CORE_MM, f"the follow-1 core is {1e3 * s['core']:.2f} mm off the rig"


def test_loose_parts_jiggle_then_settle():
    _, s = _played()
    assert s["secondary"] >= SECONDARY, \
        f"secondary motion {100 * s['secondary']:.2f} % of the body's size during the hops (>= {100 * SECONDARY:g} %)"
    assert s["settled_after_1s"], \
        f"not within {1e3 * M.SETTLED:g} mm of the rig 1 s after the motion stopped (settles after {s['settle_s']} s)"


def test_no_edge_stretched():
    _, s = _played()
    assert s["stretch"] <= STRETCH, f"an edge is {s['stretch']:.2f}x its animated length"


def test_no_floor_penetration():
    _, s = _played()
    assert 1e3 * s["lowest"] >= -FLOOR_MM, f"a vertex is {-1e3 * s['lowest']:.1f} mm under the floor"


def test_base_mesh_untouched():
    m, s = _played()
    assert s["base_kept"]
    np.testing.assert_array_equal(H.base_positions(m.obj), H.base_positions(m.twin))  # the twin is the original


def test_bake_equals_playback():
    m = M.shot()
    obj, scene = m.obj, bpy.context.scene
    live = {}
    for f in range(1, C.FRAMES + 1):
        scene.frame_set(f)
        live[f] = H.positions(obj)
    assert not obj.opdeform.error, obj.opdeform.error
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(H.tmpdir(), "character.blend"))
    bpy.ops.opdeform.bake(object=obj.name)
    assert obj.opdeform.baked and not obj.opdeform.error, obj.opdeform.error
    for f in (1, C.MOTION_END // 2, C.MOTION_END, C.FRAMES):
        scene.frame_set(f)
        np.testing.assert_array_equal(H.positions(obj), live[f])
