"""Jiggle that rides the animation (issue 24), inside Blender (run by tests/test_addon_character.py through
runner.py, in Debian's Blender and in the bpy module): the rigged, hopping character of character_scene.py
with OPDeform enabled as an artist does it (Goal on, the "follow" and "softness" groups picked, every other
setting at its default), measured against the armature-only pose (character_measure.py), at the default
particle count and at 1,000. The follow-1 core stays on the rig; the loose parts (ear tips, belly front, tail
tip) jiggle during the hops and settle after the motion stops; nothing stretches, nothing goes through the
floor, the mesh itself is never written, and a bake plays back what live playback showed.

Measured (3.4.1 and 5.2.3 alike): defaults (100 particles): core 0.16 mm, ear 27 mm, belly 17 mm, tail 106 mm,
stretch 1.14, settled 0.58 s after the motion stops, secondary motion 4.4 % of the 2.44 m body; 1,000
particles: core 0.0 mm, ear 48 mm, belly 6.3 mm, tail 147 mm, stretch 1.17, settled after 0.67 s, 6.1 %."""

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
PARTICLES_HIGH = 1000


_SUMMARIES = {}  # particle count -> summary: one play serves every check (nothing of bpy kept)


def _played(particles=None):
    """The summary of the character played through its clip at the defaults (or this particle count), with
    ``twin_base``: whether its mesh equals the armature-only twin's (the twin is the original)."""
    if particles not in _SUMMARIES:
        _SUMMARIES[particles] = summary(M.shot(**({} if particles is None else {"particles": particles})))
    return _SUMMARIES[particles]


def summary(measure):
    """A Measure played through its clip: its summary with ``twin_base``."""
    s = M.play(measure)
    s["twin_base"] = bool(np.array_equal(H.base_positions(measure.obj), H.base_positions(measure.twin)))
    return s


def check_core(s):
    assert 1e3 * s["core"] <= CORE_MM, f"the follow-1 core is {1e3 * s['core']:.2f} mm off the rig"


def check_jiggle_then_settle(s):
    assert s["secondary"] >= SECONDARY, \
        f"secondary motion {100 * s['secondary']:.2f} % of the body's size during the hops (>= {100 * SECONDARY:g} %)"
    assert s["settled_after_1s"], \
        f"not within {1e3 * M.SETTLED:g} mm of the rig 1 s after the motion stopped (settles after {s['settle_s']} s)"


def check_stretch(s):
    assert s["stretch"] <= STRETCH, f"an edge is {s['stretch']:.2f}x its animated length"


def check_floor(s):
    assert 1e3 * s["lowest"] >= -FLOOR_MM, f"a vertex is {-1e3 * s['lowest']:.1f} mm under the floor"


def check_base(s):
    assert s["base_kept"] and s["twin_base"], "the character's mesh was written"


CHECKS = (check_core, check_jiggle_then_settle, check_stretch, check_floor, check_base)


def test_core_stays_on_the_rig():
    check_core(_played())


def test_loose_parts_jiggle_then_settle():
    check_jiggle_then_settle(_played())


def test_no_edge_stretched():
    check_stretch(_played())


def test_no_floor_penetration():
    check_floor(_played())


def test_base_mesh_untouched():
    check_base(_played())


def test_every_check_at_1000_particles():
    s = _played(PARTICLES_HIGH)
    for check in CHECKS:
        check(s)


def _worm(units=1.0, y_up=False):
    """other_rig.py's worm played through its clip, its mesh and bones in 1/units m, along y with ``y_up``
    (cached as _played)."""
    if ("worm", units, y_up) not in _SUMMARIES:
        import other_rig
        _SUMMARIES["worm", units, y_up] = summary(other_rig.shot(units, y_up))
    return _SUMMARIES["worm", units, y_up]


def test_every_check_on_another_rig():
    """The same checks on a rig the defaults were not tuned on (other_rig.py: a worm swaying on a 4-bone chain,
    two loose eyeballs, a Follow Group painted by height)."""
    s = _worm()
    for check in CHECKS:
        check(s)


def test_a_rig_in_centimetres_moves_as_in_metres():
    """The worm built in centimetres along +y under an armature object scaled 0.01 and turned 90 degrees about x
    (as an FBX from Maya or Mixamo comes in): the same motion in the world, within 1 % (41.18 against 41.05 mm
    at the top)."""
    metres, centimetres = _worm(), _worm(100.0, True)
    for key in ("top", "eyes", "secondary"):
        assert abs(centimetres[key] - metres[key]) <= 0.01 * metres[key], (key, centimetres[key], metres[key])
    assert centimetres["core"] <= 1e-3 * CORE_MM


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


def test_thin_parts_with_too_few_particles_are_named():
    """At the default 100 particles the ears and tail have 1-2 particles each and turn nearly rigidly: the
    panel names them and the count that gives them three; at 1,000 particles it says nothing."""
    m = M.shot()
    text = H.labels(H.draw_panels())
    assert "thin parts with under 3 particles along" in text and "raise Particles to about" in text, text
    m = M.shot(particles=PARTICLES_HIGH)
    text = H.labels(H.draw_panels())
    assert "thin part" not in text, text
    assert m.obj.opdeform.built
