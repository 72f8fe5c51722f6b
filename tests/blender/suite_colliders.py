"""Collision modifiers and force fields in the add-on (run by tests/blender/runner.py inside Blender; see
tests/test_addon_colliders.py). A blob (an icosphere, 0.6 m across) falls on a UV sphere and slides down a
30-degree ramp that carry Blender's Collision modifier; wind fields push it and the tumbling flakes."""

import math
import os

import bpy
import numpy as np

import helpers as H

BLOB = 0.6  # the blob's size (diameter), m


def collider(kind="sphere", friction=5.0, name=None, wave=0.0):
    """A UV sphere (radius 1 at the origin) or a 30-degree ramp (an 8 m plane through the origin, tilted about
    y so that it falls toward +x) with a Collision modifier (after a Wave of this height: a deforming one)."""
    if kind == "sphere":
        bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, segments=48, ring_count=24)
    else:
        bpy.ops.mesh.primitive_grid_add(x_subdivisions=16, y_subdivisions=16, size=8.0,
                                        rotation=(0.0, math.radians(30.0), 0.0))
    obj = bpy.context.active_object
    obj.name = name or kind.title()
    if wave:
        obj.modifiers.new("Wave", 'WAVE').height = wave
    obj.modifiers.new("Collision", 'COLLISION')
    obj.collision.cloth_friction = friction
    obj.collision.thickness_outer = 0.02
    return obj


def blob(location=(0.0, 0.0, 1.6), name="Blob", particles=60, **settings):
    bpy.ops.mesh.primitive_ico_sphere_add(radius=BLOB / 2, subdivisions=3, location=location)
    obj = bpy.context.active_object
    obj.name = name
    s = obj.opdeform
    s.particles, s.stiffness = particles, 1e5
    for k, v in settings.items():
        setattr(s, k, v)
    bpy.ops.opdeform.enable(object=obj.name)
    assert s.enabled and s.built and not s.error, s.error
    return obj


def world(obj):
    m = np.array(obj.matrix_world)
    return H.positions(obj) @ m[:3, :3].T + m[:3, 3]


def play_world(obj, frames):
    out = {}
    for f in frames:
        bpy.context.scene.frame_set(f)
        assert not obj.opdeform.error, obj.opdeform.error
        out[f] = world(obj)
    return out


def test_blob_rests_on_a_collision_sphere():
    collider("sphere")
    obj = blob()
    frames = play_world(obj, range(1, 49))
    deepest = max(1.0 - np.linalg.norm(v, axis=1).min() for v in frames.values())
    assert deepest < 0.02 * BLOB, f"the skinned mesh sank {deepest / BLOB:.1%} of its size into the sphere"
    assert frames[48][:, 2].mean() > 1.1, "the blob does not rest on the sphere"
    rt = H.runtime().get(obj)
    touching = __import__(H.ADDON + ".core.colliders", fromlist=["x"]).contact_points(
        rt.engine.sim, *rt.engine.shown_state[:1], rt.engine.graph.radii)
    assert len(touching) > 0, "no contact points for the overlay"
    print("OPDEFORM_RESULT sphere_penetration_percent", round(100 * max(deepest, 0.0) / BLOB, 3))


def test_the_skin_rests_a_quarter_into_the_outer_thickness_and_on_the_floor():
    """The skin is a lone body's contact shape (docs/contact.md, "Contact on the skin"): the blob's shown mesh
    rests a quarter into the Collision's Thickness Outer zone (0.5 cm at Blender's default 2 cm) from a sphere,
    and on the Floor, in its second second: 0.48 and 0.00 cm; the particles' ellipsoids kept it 1.82 and 1.51
    cm away (bpy 5.2, at 0.5 cm)."""
    sphere = collider("sphere")
    assert abs(sphere.collision.thickness_outer - 0.02) < 1e-6
    obj = blob()
    frames = play_world(obj, range(1, 49))
    sim = H.runtime().get(obj).engine.sim
    gap = min(sim.collider_distances(frames[f].astype(np.float64)).min() for f in range(25, 49))
    assert -1e-6 < gap < 0.0051, f"the skin rests {100 * gap:.2f} cm from the sphere"
    H.fresh()
    obj = blob(location=(0.0, 0.0, BLOB), use_floor=True)
    low = min(play_world(obj, range(1, 49))[f][:, 2].min() for f in range(25, 49))
    assert -1e-6 < low < 0.001, f"the skin rests {100 * low:.2f} cm from the floor"
    print("OPDEFORM_RESULT skin_gap_cm sphere", round(100 * gap, 3), "floor", round(100 * low, 3))


def test_beside_another_object_the_skin_still_meets_the_collider_and_the_floor():
    """Two simulated objects in one scene step as a contact group: each keeps its skin for the colliders and the
    floor, as alone (the ellipsoids there left a Suzanne 4.4 cm above a Collision plane beside another object);
    they meet each other with their ellipsoids (docs/contact.md, "Contact on the skin")."""
    collider("sphere")
    on_sphere = blob()
    on_floor = blob(location=(3.0, 0.0, BLOB), name="Beside", use_floor=True)
    sim = H.runtime().get(on_sphere).engine.sim
    gap, low = np.inf, np.inf
    for f in range(1, 49):
        bpy.context.scene.frame_set(f)
        assert not on_sphere.opdeform.error and not on_floor.opdeform.error
        if f > 24:
            gap = min(gap, sim.collider_distances(world(on_sphere).astype(np.float64)).min())
            low = min(low, world(on_floor)[:, 2].min())
    assert H.runtime().get(on_sphere).engine.partners is not None, "the two objects did not step as a group"
    assert -1e-6 < gap < 0.0051 and -1e-6 < low < 0.001, f"the skins rest {100 * gap:.2f} and {100 * low:.2f} cm off"


def _slide(friction):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    H.enable_addon()
    ramp = collider("ramp", friction)
    normal = np.array(ramp.matrix_world)[:3, 2]
    start = normal * (BLOB / 2 + 0.05)
    obj = blob(tuple(start))
    frames = play_world(obj, range(1, 25))
    down = np.array([math.cos(math.radians(30.0)), 0.0, -math.sin(math.radians(30.0))])
    deepest = max(-(v @ normal).min() for v in frames.values())
    assert deepest < 0.02 * BLOB, f"the skinned mesh sank {deepest / BLOB:.1%} of its size into the ramp"
    return float((frames[24].mean(axis=0) - frames[1].mean(axis=0)) @ down), deepest


def test_blob_slides_down_a_ramp_slower_with_friction():
    free, deep_free = _slide(0.0)
    rough, deep_rough = _slide(3.0)  # mu = 0.3
    assert 0.1 < rough < 0.8 * free, (free, rough)
    print("OPDEFORM_RESULT ramp_slide_m", round(free, 3), round(rough, 3), "penetration_percent",
          round(100 * max(deep_free, deep_rough, 0.0) / BLOB, 3))


def test_bake_equals_playback_with_moving_and_deforming_colliders():
    ball = collider("sphere")
    ball.keyframe_insert("location", frame=1)
    ball.location = (0.3, 0.0, 0.4)
    ball.keyframe_insert("location", frame=20)
    collider("ramp", wave=0.1).location = (0.0, 0.0, -1.0)
    wind = _wind(3.0)  # a turning wind with noise and a turbulence field: the core's fields, moved each frame
    wind.field.noise, wind.field.size = 0.5, 0.4
    wind.keyframe_insert("rotation_euler", frame=1)
    wind.rotation_euler = (0.0, math.radians(30.0), 0.0)
    wind.keyframe_insert("rotation_euler", frame=30)
    bpy.ops.object.effector_add(type='TURBULENCE', location=(0.0, 0.0, 1.0))
    bpy.context.active_object.field.strength = 2.0
    obj = blob(frame_end=30)
    live = H.play(range(1, 31))[obj.name]
    again = H.play([12, 3, 30, 25, 1])[obj.name]
    for f, co in again.items():
        np.testing.assert_array_equal(co, live[f])
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(H.tmpdir(), "colliders.blend"))
    bpy.ops.opdeform.bake(object=obj.name)
    frames = H.pc2().read_pc2(bpy.path.abspath(obj.modifiers["OPDeform Cache"].filepath))[2]
    for f in range(1, 31):
        assert np.array_equal(frames[f - 1], live[f]), f"baked frame {f} differs from playback"


def _falls_through(obj):
    frames = play_world(obj, range(1, 25))
    bpy.context.scene.frame_set(1)
    return frames[24][:, 2].mean() < 0.5


def test_colliders_can_be_ignored_per_object_and_collection():
    sphere = collider("sphere")
    obj = blob()
    assert not _falls_through(obj)
    obj.opdeform_contact.use_colliders = False
    assert _falls_through(obj)
    obj.opdeform_contact.use_colliders = True
    others = bpy.data.collections.new("Others")
    obj.opdeform_contact.collision_collection = others
    assert _falls_through(obj)
    others.objects.link(sphere)
    assert not _falls_through(obj)
    sphere.collision.use = False
    assert _falls_through(obj)


def _table_faces(mesh, first):
    """The table's 8 vertices (two tetrahedra with a flat 2 m top at z = 0, A at x -3..-1, B at x 1..3) with the
    4 faces of the one whose vertices start at ``first`` (0: A, 4: B); the other's vertices stay loose."""
    corners = [p for x0 in (-3.0, 1.0) for p in ((x0, -1.0, 0.0), (x0 + 2, -1.0, 0.0), (x0 + 1, 1.0, 0.0),
                                                (x0 + 1, -1 / 3, -1.0))]
    faces = [tuple(first + k for k in f) for f in ((0, 2, 1), (0, 1, 3), (1, 2, 3), (2, 0, 3))]
    mesh.clear_geometry()
    mesh.from_pydata(corners, [], faces)
    mesh.update()
    bpy.context.view_layer.update()


def test_an_edited_static_collider_is_read_again():
    """A collider whose mesh does not deform keeps its triangles between frames (Blender triangulates on every
    read); an edit that keeps the counts (the table's faces moved from tetrahedron A to B) drops them."""
    table = H.mesh_object("Table", [(0, 0, 0)] * 8)
    _table_faces(table.data, 0)
    table.modifiers.new("Collision", 'COLLISION')
    obj = blob(location=(2.0, -0.2, 0.6))  # above tetrahedron B's top

    def height():  # the blob's mean height after 1 s
        z = play_world(obj, range(1, 25))[24][:, 2].mean()
        bpy.context.scene.frame_set(1)
        return z

    assert height() < -1.0  # nothing under it: it falls
    _table_faces(table.data, 4)
    assert 0.05 < height() < 0.5  # it rests on B's top (squashed: 0.16 m)


def _expect_report(obj, *words):
    """The object pauses with an error naming the collider; the frame it showed is kept."""
    before = H.positions(obj)
    bpy.context.scene.frame_set(bpy.context.scene.frame_current + 1)
    text = obj.opdeform.error
    for w in words:
        assert w.lower() in text.lower(), f"{text!r} does not mention {w!r}"
    np.testing.assert_array_equal(H.positions(obj), before)
    bpy.ops.opdeform.reset(object=obj.name)


def test_bad_colliders_and_fields_are_reported():
    obj = blob()
    H.play(range(1, 4))
    flat = H.mesh_object("Flat", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], edges=[(0, 1), (1, 2)])
    flat.modifiers.new("Collision", 'COLLISION')
    _expect_report(obj, "Flat", "no faces")
    bpy.data.objects.remove(flat)
    nan = collider("sphere", name="NanBall")
    nan.data.vertices[0].co = (float("nan"), 0.0, 0.0)
    _expect_report(obj, "NanBall", "non-finite")
    bpy.data.objects.remove(nan)
    ramp = collider("ramp", name="Twisted")
    ramp.data.polygons[0].flip()
    ramp.data.update()
    _expect_report(obj, "Twisted", "normals")
    bpy.data.objects.remove(ramp)
    bpy.ops.object.effector_add(type='WIND')
    wind = bpy.context.active_object
    wind.field.strength = float("nan")
    if not math.isnan(wind.field.strength):
        return  # this Blender clamps NaN: nothing to report
    _expect_report(obj, wind.name, "not finite")


def _wind(strength=20.0):
    bpy.ops.object.effector_add(type='WIND', rotation=(0.0, math.radians(90.0), 0.0))  # blows toward +x
    field = bpy.context.active_object.field
    field.strength, field.flow = strength, 0.0
    return bpy.context.active_object


def test_wind_pushes_the_body():
    bpy.context.scene.use_gravity = False
    obj = blob(location=(0.0, 0.0, 0.0))
    _wind()
    moved = play_world(obj, range(1, 25))
    dx = moved[24][:, 0].mean() - moved[1][:, 0].mean()
    assert 0.5 * 10.0 < dx < 1.2 * 10.0, dx  # a = 20 m/s^2 for 23 frames: 0.5 a t^2 = 9.2 m
    obj.opdeform_contact.effector_weights.wind = 0.0
    still = play_world(obj, range(1, 25))
    assert abs(still[24][:, 0].mean() - still[1][:, 0].mean()) < 1e-6
    print("OPDEFORM_RESULT wind_push_m", round(float(dx), 3))


def _flakes(name, field=None):
    """The flakes' positions at frames 1 and 12 of a bake in a 2 m x 1 m domain, with a field of (type, strength)
    at its centre or none."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    H.enable_addon()
    v, t = H.box_mesh((0.0, 0.0, -0.1), (2.0, 1.0, 1.0), (2, 2, 2))
    domain = H.mesh_object("Domain", v, t)
    bpy.ops.opdeform.tumbling_enable(object=domain.name)
    s = domain.opdeform_tumbling
    s.dx, s.count, s.frame_start, s.frame_end, s.wind = 0.05, 200, 1, 12, "off"
    s.cache_directory = os.path.join(H.tmpdir(), f"flakes_{name}")
    if field == "WIND":
        _wind(5.0)
    elif field is not None:
        bpy.ops.object.effector_add(type=field[0], location=(1.0, 0.5, 0.45))
        bpy.context.active_object.field.strength = field[1]
    bpy.ops.opdeform.tumbling_bake(object=domain.name)
    tumbling = __import__(H.ADDON + ".blender.tumbling_runtime", fromlist=["x"])
    return [tumbling.core.read_frame(tumbling.mpm(), s.baked_folder, f)[0] for f in (1, 12)]


def _drift(frames):
    return float(frames[1][:, 0].mean() - frames[0][:, 0].mean())


def _spread(frames):
    """How much farther from the domain's vertical centre line the flakes are at the end than at the start."""
    return float(np.linalg.norm(frames[1][:, :2] - (1.0, 0.5), axis=1).mean()
                 - np.linalg.norm(frames[0][:, :2] - (1.0, 0.5), axis=1).mean())


def test_wind_pushes_the_tumbling_flakes():
    calm, windy = _drift(_flakes("calm")), _drift(_flakes("wind", "WIND"))
    assert windy > calm + 0.05, (calm, windy)
    print("OPDEFORM_RESULT flakes_drift_m", round(calm, 3), round(windy, 3))


def test_a_force_field_gathers_the_flakes():
    gathered = _spread(_flakes("attract", ('FORCE', -5.0)))
    scattered = _spread(_flakes("repel", ('FORCE', 5.0)))
    assert gathered < -0.1 and scattered > 0.1, (gathered, scattered)  # 0.012 m without a field
    print("OPDEFORM_RESULT flakes_spread_m", round(gathered, 3), round(scattered, 3))


def test_flakes_land_on_a_collision_sphere():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    H.enable_addon()
    v, t = H.box_mesh((-1.0, -1.0, -0.1), (1.0, 1.0, 1.5), (2, 2, 2))
    domain = H.mesh_object("Domain", v, t)
    bpy.ops.opdeform.tumbling_enable(object=domain.name)
    s = domain.opdeform_tumbling
    s.dx, s.count, s.frame_start, s.frame_end, s.wind = 0.05, 300, 1, 24, "off"
    s.layer_height, s.layer_thickness = 0.9, 0.05
    s.cache_directory = os.path.join(H.tmpdir(), "flakes_sphere")
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0.0, 0.0, 0.5))
    bpy.context.active_object.modifiers.new("Collision", 'COLLISION')
    bpy.ops.opdeform.tumbling_bake(object=domain.name)
    tumbling = __import__(H.ADDON + ".blender.tumbling_runtime", fromlist=["x"])
    frames = [tumbling.core.read_frame(tumbling.mpm(), s.baked_folder, f)[0] for f in range(1, 25)]
    inside = [int((np.linalg.norm(p - (0.0, 0.0, 0.5), axis=1) < 0.5 - 0.05).sum()) for p in frames]
    assert not any(inside), f"flakes inside the sphere: {inside}"
    landed = frames[11][np.linalg.norm(frames[11][:, :2], axis=1) < 0.2]
    assert len(landed) and landed[:, 2].min() > 0.95, "the flakes over the sphere did not land on its top"


def _gap(upper, lower, radius=0.1):
    """How far the upper mesh's lowest vertex is above the lower one's highest near the vertical axis through
    the lower one's centre (negative: overlapping)."""
    axis = lower.mean(axis=0)[:2]
    near = [m[np.linalg.norm(m[:, :2] - axis, axis=1) < radius, 2] for m in (upper, lower)]
    return float(near[0].min() - near[1].max())


def test_two_blobs_dropped_onto_each_other_do_not_pass_through():
    """The impact, not stacking: soft blobs (k = 1e5) roll off the round lower one within 2-4 s with or without
    contact forces inside the iterations (docs/contact.md); firm ones rest stacked (the next test)."""
    low = blob(location=(0.0, 0.0, 0.3), name="Low", use_floor=True, frame_end=30)
    high = blob(location=(0.0, 0.0, 1.0), name="High", use_floor=True, frame_end=30)
    live = H.play(range(1, 31))
    gaps = []
    for f in range(1, 25):
        bpy.context.scene.frame_set(f)
        assert not (low.opdeform.error or high.opdeform.error), (low.opdeform.error, high.opdeform.error)
        gaps.append(_gap(world(high), world(low)))
    assert min(gaps) > -0.05 * BLOB, f"the blobs overlap {-min(gaps) / BLOB:.1%} of their size"
    assert world(high)[:, 2].mean() > world(low)[:, 2].mean() + 0.2, "the upper blob does not lie on the lower"
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(H.tmpdir(), "two_blobs.blend"))
    bpy.ops.opdeform.bake(object=high.name)  # the group is simulated again: the bake is playback's frames
    frames = H.pc2().read_pc2(bpy.path.abspath(high.modifiers["OPDeform Cache"].filepath))[2]
    for f in range(1, 31):
        assert np.array_equal(frames[f - 1], live[high.name][f]), f"baked frame {f} differs from playback"
    print("OPDEFORM_RESULT blobs_overlap_percent", round(100 * max(-min(gaps), 0.0) / BLOB, 3))


def test_two_firm_blobs_dropped_onto_each_other_come_to_rest_stacked():
    """Contact forces inside the iterations (docs/contact.md): firm blobs (k = 1e7) rest stacked after 4 s, their
    skinned meshes apart; a bake of the upper one (the group simulated again) equals playback bit for bit."""
    import opdeform

    low = blob(location=(0.0, 0.0, 0.3), name="Low", use_floor=True, frame_end=100, stiffness=1e7)
    high = blob(location=(0.0, 0.0, 1.0), name="High", use_floor=True, frame_end=100, stiffness=1e7)
    live = H.play(range(1, 98))
    shown = {}
    for f in range(1, 98):
        bpy.context.scene.frame_set(f)
        assert not (low.opdeform.error or high.opdeform.error), (low.opdeform.error, high.opdeform.error)
        shown[f] = (world(low), world(high))
    lower, upper = shown[97]
    assert upper[:, 2].mean() > lower[:, 2].mean() + 0.5, "the upper blob does not lie on the lower"
    aside = float(np.linalg.norm(upper[:, :2].mean(axis=0) - lower[:, :2].mean(axis=0)))
    assert aside < 0.05, f"the upper blob is {aside:.3f} m aside"
    speed = max(np.abs(a - b).max() for a, b in zip(shown[97], shown[96])) * bpy.context.scene.render.fps
    assert speed < 0.05, f"the blobs still move at {speed:.3f} m/s"
    triangles = np.array([p.vertices[:] for p in low.data.polygons], np.int32)
    worst = 0.0
    for f in range(1, 98, 4):
        probe = opdeform.Simulation(opdeform.Graph.from_mesh(shown[f][0], triangles, particles=20), 1e6)
        probe.add_collider("mesh", vertices=shown[f][0], triangles=triangles, resolution=64)
        worst = max(worst, -float(probe.collider_distances(shown[f][1]).min()))
    assert worst < 0.02 * BLOB, f"the skinned meshes overlap {worst / BLOB:.1%} of their size"
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(H.tmpdir(), "firm_blobs.blend"))
    bpy.ops.opdeform.bake(object=high.name)
    frames = H.pc2().read_pc2(bpy.path.abspath(high.modifiers["OPDeform Cache"].filepath))[2]
    for f in range(1, 98):
        assert np.array_equal(frames[f - 1], live[high.name][f]), f"baked frame {f} differs from playback"
    print("OPDEFORM_RESULT firm_blobs_aside_m", round(aside, 4), "speed_m_s", round(speed, 4),
          "overlap_percent", round(100 * max(worst, 0.0) / BLOB, 3))


def _suzanne(name, levels=2):
    """Blender's Suzanne with a Subdivision of ``levels`` applied (none at 0)."""
    bpy.ops.mesh.primitive_monkey_add()
    obj = bpy.context.active_object
    obj.name = name
    if levels:
        obj.modifiers.new("Subdivision", 'SUBSURF').levels = levels
        bpy.ops.object.modifier_apply(modifier="Subdivision")
    return obj


def stack_figures(lower, upper):
    """How far (m) the upper's centre is above the lower's highest vertex and aside of the lower's centre, from
    their vertices in world space."""
    above = float(upper[:, 2].mean() - lower[:, 2].max())
    aside = float(np.linalg.norm(upper[:, :2].mean(axis=0) - lower[:, :2].mean(axis=0)))
    return above, aside


def _play_stack(low, high, label, widest=None):
    """Plays two objects stacked to 13 s; from 3 s to 13 s the upper's centre stays above the lower's highest vertex
    (and within ``widest`` m aside of the lower's centre, where given), every vertex at rest."""
    bpy.context.scene.frame_end = 13 * H.FPS
    before = None  # the frame before each whole second's
    for f in range(1, 13 * H.FPS + 1):
        bpy.context.scene.frame_set(f)
        assert not (low.opdeform.error or high.opdeform.error), (low.opdeform.error, high.opdeform.error)
        if f >= 3 * H.FPS - 1 and f % H.FPS in (0, H.FPS - 1):
            shown = world(low), world(high)
            if f % H.FPS == H.FPS - 1:
                before = shown
                continue
            above, aside = stack_figures(*shown)
            speed = max(np.abs(a - b).max() for a, b in zip(shown, before)) * H.FPS
            print("OPDEFORM_RESULT", label, f // H.FPS, "s above_top_m", round(above, 3), "aside_m", round(aside, 3),
                  "speed_m_s", round(speed, 4))
            assert above > 0.2, f"at {f // H.FPS} s the upper's centre is {above:.3f} m above the lower's top"
            assert widest is None or aside < widest, f"at {f // H.FPS} s the upper's centre is {aside:.3f} m aside"
            assert speed < 0.05, f"at {f // H.FPS} s a vertex moves at {speed:.3f} m/s"


def _collision_plane():
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    bpy.context.active_object.modifiers.new("Collision", 'COLLISION')


def _stack_member(obj, on_floor, preset):
    """The panel's Floor ticked (on_floor) or not, a preset applied (where given), the object enabled."""
    obj.opdeform.use_floor = on_floor
    if preset:
        bpy.ops.opdeform.apply_preset(preset=preset, object=obj.name)
    bpy.ops.opdeform.enable(object=obj.name)
    assert obj.opdeform.enabled and not obj.opdeform.error, obj.opdeform.error
    return obj


def suzanne_pair(on_floor, preset=None, levels=2):
    """Two Suzannes (subdivided ``levels`` times), the lower resting on the panel's Floor (on_floor: its lowest
    vertex at 0) or on a Collision plane (5 mm above it), the upper 1 m above its head: (lower, upper)."""
    if not on_floor:
        _collision_plane()
    low, high = placed_suzannes(levels, 0.0 if on_floor else 0.005)
    return tuple(_stack_member(obj, on_floor, preset) for obj in (low, high))


def placed_suzannes(levels, ground):
    """Two Suzannes (subdivided ``levels`` times), the lower's lowest vertex at ``ground``, the upper 1 m above its
    head: (lower, upper), not enabled."""
    low, high = _suzanne("Low", levels), _suzanne("High", levels)
    z = np.array([v.co.z for v in low.data.vertices])
    low.location.z = ground - z.min()
    high.location.z = low.location.z + z.max() + 1.0 - z.min()
    return low, high


def sphere_pair(on_floor, preset, upper=0.5, high=2.0, suffix=""):
    """Two UV spheres, the lower of radius 0.5 m resting on the panel's Floor (on_floor) or on a Collision plane
    (5 mm above it), the upper of radius ``upper`` with its centre at ``high``: (lower, upper)."""
    if not on_floor:
        _collision_plane()
    spheres = []
    for name, z, radius in (("Low", 0.5 if on_floor else 0.505, 0.5), ("High", high, upper)):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=(0.0, 0.0, z))
        obj = bpy.context.active_object
        obj.name = name + suffix
        spheres.append(_stack_member(obj, on_floor, preset))
    return tuple(spheres)


def _suzanne_stack(on_floor, preset=None, widest=None):
    """Two subdivided Suzannes at the panel's defaults (a preset applied, where given), the lower resting on the
    panel's Floor (on_floor: its lowest vertex at 0) or on a Collision plane (5 mm above it, the plane's Thickness
    Outer in the engine's tests), the upper dropped 1 m onto its head; from 3 s to 13 s the upper's centre stays
    above the lower's highest vertex (fallen off, it lies 0.8 m below it) and within ``widest`` m aside of the
    lower's centre (where given), every vertex at rest."""
    low, high = suzanne_pair(on_floor, preset)
    label = " ".join(["suzanne_stack", "floor" if on_floor else "plane"] + ([preset] if preset else []))
    _play_stack(low, high, label, widest)


def test_a_suzanne_dropped_on_another_stays_on_top():
    """Issue 27's stack as a user makes it, on a Collision plane (docs/contact.md, "Stacks", tenth round: 0.10-0.11
    m aside in Blender 3.4.1, 0.26-0.29 m in bpy 5.2.3; before the rolling couple between members, in bpy 5.2.3,
    0.58 m aside and sliding at 0.18 m/s at 3 s; since stop 37, collpatch, the plane's patch rolling the lower
    back: 0.13-0.15 and 0.12-0.13 m; since stop 38, jellysuz, the members' inelastic impact, where the upper lands:
    0.45-0.52 m, creeping at 0.012 m/s, and 0.50 m)."""
    _suzanne_stack(on_floor=False)


def test_a_suzanne_dropped_on_another_on_the_floor_stays_on_top():
    """The same stack on the panel's Floor (docs/contact.md, "Stacks", twelfth round: the objects meet it with
    their skins and each other with their ellipsoids, so it holds neither inside the iterations and steps as the
    Collision plane; before, the upper one was thrown off at its landing)."""
    _suzanne_stack(on_floor=True)


def test_a_jelly_suzanne_dropped_on_another_stays_on_top():
    """The same stack with the Jelly preset, on the panel's Floor, then on a Collision plane: from 3 s to 13 s the
    upper rests on the back of the lower's head (the lower tips over before the landing), within 0.8 m aside of the
    lower's centre (docs/contact.md, "Left": 0.40 / 0.39 m at 13 s in Blender 3.4.1 / bpy 5.2.3 at stop 43; "Stacks",
    stop 38, jellysuz: 0.75-0.76 m in both hosts; before, it bounced off the members' contact and lay beside the
    lower, 2.66 / 2.72 m aside at 3 s on the Floor in Blender 3.4.1 / bpy 5.2.3)."""
    for on_floor in (True, False):
        for obj in list(bpy.data.objects):
            bpy.data.objects.remove(obj)
        _suzanne_stack(on_floor, preset="Jelly", widest=0.8)


def test_an_object_far_from_another_simulates_as_alone():
    """Two subdivided Suzannes (2.7 m wide) dropped onto the panel's Floor 10 m apart (the scene's objects one
    contact group): the first's shot is the same bits with the second there or not (docs/contact.md, "Members far
    apart step as alone", stop 41: farther apart than the larger is long). 6 m apart they still step together, as
    every group did before at any distance: the first's vertices are up to 0.43 m off its shot alone at frame 36."""
    shots = []
    for others in ((), ((10.0, 0.0, 2.0),)):
        H.fresh()
        for name, location in (("Near", (0.0, 0.0, 1.5)),) + tuple(("Far", where) for where in others):
            obj = _suzanne(name)
            obj.location = location
            obj.opdeform.use_floor = True
            bpy.ops.opdeform.enable(object=name)
            assert obj.opdeform.enabled and not obj.opdeform.error, obj.opdeform.error
        for f in range(1, 37):
            bpy.context.scene.frame_set(f)
        near = bpy.data.objects["Near"]
        assert not near.opdeform.error, near.opdeform.error
        shots.append(world(near))
    assert shots[0][:, 2].min() < 0.05, shots[0][:, 2].min()  # landed
    np.testing.assert_array_equal(shots[1], shots[0])


def _sphere_stacks(on_floor, upper=0.5, high=2.0, widest=0.2):
    """Two UV spheres, the lower of radius 0.5 m, the upper of radius ``upper``, a preset applied (Jelly, then
    Flesh), the lower resting on the panel's Floor (on_floor) or on a Collision plane (5 mm above it), the upper's
    centre at ``high``; from 3 s to 13 s the upper rests on top within ``widest`` m aside."""
    for preset in ("Jelly", "Flesh"):
        for obj in list(bpy.data.objects):
            bpy.data.objects.remove(obj)
        spheres = sphere_pair(on_floor, preset, upper, high, suffix=preset)
        _play_stack(*spheres, f"sphere_stack {upper:g} " + ("floor " if on_floor else "plane ") + preset, widest=widest)


def test_soft_spheres_stacked_on_the_floor_stay_on_top():
    """Issue 27's spheres as a new user stacks them: two UV spheres of radius 0.5 m, the panel's Floor ticked, a
    preset applied, the lower resting on the Floor, the upper's centre at 2 m; from 3 s to 13 s the upper rests on
    top within 0.2 m aside (docs/contact.md, "Stacks", stop 37, skinfloor: before, Jelly and Flesh tipped over as
    one and rolled off, 1.38 / 0.86 m aside at 3 s)."""
    _sphere_stacks(on_floor=True)


def test_a_smaller_sphere_dropped_on_a_larger_stays_on_top():
    """Issue 27's audit scene: a UV sphere of radius 0.35 m dropped 5 cm onto one of 0.5 m on the panel's Floor, a
    preset applied (Jelly, Flesh); from 3 s to 13 s the upper rests on top within 0.1 m aside (docs/contact.md,
    "Stacks", stop 40, onepair (c): 2.9 times its mass, the two were not comparable at the panel's 240 steps a
    second and toppled as one, Jelly 1.98, Flesh 1.50 m aside at 13 s in Blender 3.4.1)."""
    _sphere_stacks(on_floor=True, upper=0.35, high=1.4, widest=0.1)


def test_soft_spheres_stacked_on_a_collision_plane_stay_on_top():
    """The same spheres on a Collision plane (docs/contact.md, "Stacks", stop 37, collpatch: before, Jelly and
    Flesh tipped over as one and rolled off, 1.38-1.39 / 0.86 m aside at 3 s)."""
    _sphere_stacks(on_floor=False)



def test_two_rubber_spheres_stacked_on_their_skins_stay_on_top():
    """Object Shape Skin: two UV spheres (radius 0.5 m, Blender's default) at the panel's defaults (Rubber), the
    lower on the Floor, the upper's centre 2 m up; from 3 to 13 s it rests on top within 0.1 m aside
    (docs/contact.md, "Stacks", stop 37, skinstack; before it, they tipped over as one and the upper lay 1.7 m
    aside)."""
    balls = []
    for name, z in (("LowBall", 0.5), ("HighBall", 2.0)):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0.0, 0.0, z))
        obj = bpy.context.active_object
        obj.name = name
        obj.opdeform.use_floor = True
        obj.opdeform_contact.object_shape = 'SKIN'
        bpy.ops.opdeform.enable(object=obj.name)
        assert obj.opdeform.enabled and not obj.opdeform.error, obj.opdeform.error
        balls.append(obj)
    _play_stack(*balls, "skin_spheres", widest=0.1)

def box(location, name, shape, **settings):
    """A 0.6 m cube, its faces cut in 8 x 8 (a skin to rest on), enabled with the panel's defaults and these, its
    Object Shape ``shape``."""
    bpy.ops.mesh.primitive_cube_add(size=BLOB, location=location)
    obj = bpy.context.active_object
    obj.name = name
    cut = obj.modifiers.new("Cut", 'SUBSURF')
    cut.subdivision_type, cut.levels = 'SIMPLE', 3
    bpy.ops.object.modifier_apply(modifier=cut.name)
    for k, v in settings.items():
        setattr(obj.opdeform, k, v)
    obj.opdeform_contact.object_shape = shape
    bpy.ops.opdeform.enable(object=obj.name)
    assert obj.opdeform.built and not obj.opdeform.error, obj.opdeform.error
    return obj


def _box_gaps(low, high):
    """The gap between the upper box's lowest and the lower box's highest vertex at each of frames 1-48."""
    gaps = []
    for f in range(1, 49):
        bpy.context.scene.frame_set(f)
        assert not (low.opdeform.error or high.opdeform.error), (low.opdeform.error, high.opdeform.error)
        gaps.append(float(world(high)[:, 2].min() - world(low)[:, 2].max()))
    return gaps


def test_a_box_dropped_on_a_box_rests_skin_on_skin():
    """Object Shape Skin (docs/blender.md, "Contact between objects"): a box dropped 0.2 m on a box on the Floor
    rests with their skins within the Object Distance (5 mm), never in it; switched to the default Particles, the
    frames are simulated again and the ellipsoids hold it about 5 cm above."""
    low = box((0.0, 0.0, BLOB / 2), "LowBox", 'SKIN', use_floor=True, frame_end=48)
    high = box((0.05, 0.0, 1.5 * BLOB + 0.2), "HighBox", 'SKIN', use_floor=True, frame_end=48)
    skin = _box_gaps(low, high)
    assert min(skin) > -0.002, f"the upper box's skin went {-min(skin):.4f} m into the lower one's"
    assert skin[-1] < 0.01, f"the upper box rests {skin[-1]:.4f} m above the lower one's skin"
    for obj in (low, high):
        obj.opdeform_contact.object_shape = 'PARTICLES'
    particles = _box_gaps(low, high)
    assert particles[-1] > 0.02, f"on the particles the upper box rests {particles[-1]:.4f} m above"
    print("OPDEFORM_RESULT box_gap_m skin", round(skin[-1], 4), "particles", round(particles[-1], 4))


def hook_mesh(step=0.1, half=0.1, neck=0.7, body=2.0, tail=1.6):
    """A square bar bent as a hook in the xz plane: its body along x on the ground, a neck up at x = 0 and a tail
    back over the body."""
    corners = np.array([[body, 0.0], [0.0, 0.0], [0.0, neck], [tail, neck]])
    pts, normals = [], []
    for a, b in zip(corners[:-1], corners[1:]):
        n = int(round(np.linalg.norm(b - a) / step))
        pts += [a + (b - a) * k / n for k in range(n)]
    pts.append(corners[-1])
    pts = np.array(pts)
    t = np.gradient(pts, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    seg = np.diff(pts, axis=0); seg /= np.linalg.norm(seg, axis=1, keepdims=True)
    nrm = np.stack([-t[:, 1], t[:, 0]], 1)
    segn = np.stack([-seg[:, 1], seg[:, 0]], 1)
    scale = 1.0 / np.abs(np.einsum("ij,ij->i", nrm, np.vstack([segn, segn[-1:]])))
    verts = []
    for p, n, s in zip(pts, nrm, scale):
        for dn, dy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            q = p + dn * half * s * n
            verts.append((q[0], dy * half, q[1]))
    faces = []
    m = len(pts)
    for i in range(m - 1):
        for j in range(4):
            a, b = 4 * i + j, 4 * i + (j + 1) % 4
            faces += [(a, b, b + 4), (a, b + 4, a + 4)]
    faces += [(0, 2, 1), (0, 3, 2), (4 * m - 4, 4 * m - 3, 4 * m - 2), (4 * m - 4, 4 * m - 2, 4 * m - 1)]
    return np.array(verts), np.array(faces)


def _tail_lowest(self_collision):
    """The lowest point of a hook's tail over 1 s: its body (pinned, top at z = 0.1) under the tail."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    H.enable_addon()
    v, f = hook_mesh()
    obj = H.mesh_object("Hook", v, f)
    group = obj.vertex_groups.new(name="Body")
    group.add([int(i) for i in np.where((v[:, 0] > 0.3) & (v[:, 2] < 0.15))[0]], 1.0, 'REPLACE')
    s = obj.opdeform
    s.particles, s.stiffness, s.substeps, s.pin_group = 100, 1e4, 4, "Body"
    obj.opdeform_contact.use_self_collision = self_collision
    obj.opdeform_contact.self_distance = 0.01
    bpy.ops.opdeform.enable(object=obj.name)
    assert s.enabled and s.built and not s.error, s.error
    tail = (v[:, 2] > 0.5) & (v[:, 0] > 0.6)
    return min(float(m[tail, 2].min()) for m in play_world(obj, range(1, 25)).values())


def test_a_tail_does_not_pass_through_its_own_body():
    """A hook whose tail falls onto its own pinned body: through it without Self Collision, on it with. (Held
    for 1 s; stiffer or longer, the tail slides off the body's side, as the core's stacking does.)"""
    through, held = _tail_lowest(False), _tail_lowest(True)
    assert through < -0.5, through
    assert held > 0.1 - 0.02 * 2.0, f"the tail sank {0.1 - held:.3f} m into the body"
    print("OPDEFORM_RESULT tail_lowest_m", round(through, 3), round(held, 3))
