"""Settings an artist can use and the add-on's bounds (issues 14 and 15, items 4 and 5), run by
tests/test_addon_settings.py through runner.py in Debian's Blender and in the bpy module: presets and material
units, versioning of older files, the Quality report and plot, the warnings, the Suzanne drop at default
settings; far cache ranges and far jumps (bounded time and memory); bakes that fail before changing anything,
Free Bake of files the bake did not write, a rename during a bake, a second bake."""

import importlib
import os
import sys

import bpy
import numpy as np

import helpers as H

sys.path.insert(0, os.path.dirname(H.HERE))  # tests/: the drop check shared with the core's tests
from suzanne_check import DropCheck  # noqa: E402


def _module(name):
    return importlib.import_module(f"{H.ADDON}.{name}")


def _tail(name="Tail", particles=100, mode="auto", length=2.0):
    """The 2 m x 0.2 m tail (or ``length`` long) with its root face in "Pin", enabled as an artist would: no
    setting touched."""
    v, t = H.box_mesh((0.0, -0.1, -0.1), (length, 0.1, 0.1), (21, 5, 5))
    obj = H.mesh_object(name, v, t)
    group = obj.vertex_groups.new(name="Pin")
    group.add([int(i) for i in np.where(v[:, 0] < 1e-9)[0]], 1.0, 'REPLACE')
    s = obj.opdeform
    s.pin_group, s.particles, s.graph_mode = "Pin", particles, mode
    bpy.ops.opdeform.enable(object=obj.name)
    assert s.enabled and not s.error, s.error
    return obj


def _tip_z(obj):
    p = H.positions(obj)
    return float(p[np.argmax(H.base_positions(obj)[:, 0]), 2])


def test_enable_gives_the_default_preset():
    obj = _tail()
    s, presets = obj.opdeform, _module("blender.presets")
    assert s.settings_version == _version() and not s.use_solver_units
    assert presets.current_name(s) == "Rubber" and s.density == 1100.0 and s.modulus == 15.0
    assert s.use_frame_rate_substeps and presets.substeps(s, 24.0) == 10 and presets.substeps(s, 60.0) == 4
    bpy.ops.opdeform.apply_preset(object=obj.name, preset="Jelly")
    assert presets.current_name(s) == "Jelly" and abs(s.modulus - 3.0) < 1e-9
    s.modulus = 4.0
    assert presets.current_name(s) == "Custom"
    H.expect_error(lambda: bpy.ops.opdeform.apply_preset(object=obj.name, preset="Steel"), "no preset")
    s.stiffness = 2e7  # a script written for k: solver units
    assert s.use_solver_units and presets.current_name(s) == "Solver Units"


def test_default_tail_droops_about_10_percent_and_jiggles():
    """Rubber at 100 particles, released straight: the pinned 2 m tail droops ~10 % of its length (the tip's
    mean over seconds 3 to 6) and jiggles visibly (the tip's travel in the first second over 5 cm, still over
    1 cm in the third)."""
    obj = _tail()
    rest = _tip_z(obj)
    tips = []
    for f in range(1, 6 * 24 + 1):
        bpy.context.scene.frame_set(f)
        tips.append(_tip_z(obj))
    droop = (rest - np.mean(tips[72:])) / 2.0
    travel = (np.ptp(tips[:24]), np.ptp(tips[48:72]))
    print(f"tail droop={droop:.3f} travel={travel[0]:.3f} {travel[1]:.3f}")
    # 9.7 % (the core's static droop of this mesh at 100 particles: 9.9 %); 17.7 % when the pins kept the
    # weight of the solver units the object is built in (test_addon_settings_core.py)
    assert 0.07 < droop < 0.14 and travel[0] > 0.05 and travel[1] > 0.01, (droop, travel)


def _cube_tail(particles):
    """A 2 m x 0.2 m tail made as an artist would: the default cube scaled, the scale applied, subdivided (9
    cuts), its root face in "Pin"; enabled with no setting touched."""
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(1.0, 0.0, 0.0))
    obj = bpy.context.active_object
    obj.scale = (1.0, 0.1, 0.1)
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    bpy.ops.mesh.subdivide(number_cuts=9)
    bpy.ops.object.mode_set(mode='OBJECT')
    v = H.base_positions(obj)
    obj.vertex_groups.new(name="Pin").add([int(i) for i in np.where(v[:, 0] < 1e-6)[0]], 1.0, 'REPLACE')
    obj.opdeform.pin_group, obj.opdeform.particles = "Pin", particles
    bpy.ops.opdeform.enable(object=obj.name)
    assert not obj.opdeform.error, obj.opdeform.error
    return obj


def test_the_default_tail_droops_the_same_at_any_particle_count():
    """Issue 14: the same settings give the same droop at 50 to 400 particles (measured 9.50 / 9.61 / 9.34 /
    9.91 %, 1.06x; the tip's mean over seconds 3 to 6)."""
    droop = []
    for particles in (50, 100, 200, 400):
        H.fresh()
        obj = _cube_tail(particles)
        rest = _tip_z(obj)
        tips = []
        for f in range(1, 6 * 24 + 1):
            bpy.context.scene.frame_set(f)
            tips.append(_tip_z(obj))
        droop.append((rest - np.mean(tips[72:])) / 2.0)
    print("OPDEFORM_RESULT droop_by_count", [round(d, 4) for d in droop])
    assert max(droop) / min(droop) < 1.1 and 0.07 < min(droop), droop


def test_old_file_keeps_its_raw_stiffness():
    obj = _tail()
    s = obj.opdeform
    s.stiffness, s.damping = 2e7, 0.01
    s.use_solver_units, s.settings_version = False, 0  # as a file saved before material units
    path = os.path.join(H.tmpdir(), "old.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Tail"]
    s = obj.opdeform
    assert s.use_solver_units and s.settings_version == _version() and s.stiffness == 2e7
    bpy.context.scene.frame_set(2)
    rt = H.runtime().get(obj)
    assert rt.engine.sim.params["stiffness"] == 2e7 and abs(rt.engine.sim.params["damping"] - 0.01) < 1e-8
    assert rt.engine.sim.tolerance == 0.0


def test_version_1_file_keeps_its_look():
    """A file saved in material units before the bending calibration (settings version 1): its modulus is
    tripled on load, so its Rubber (5 MPa then) is Rubber (15 MPa) now; appended without a load, it is read so."""
    obj = _tail()
    s, presets = obj.opdeform, _module("blender.presets")
    s.modulus, s.settings_version = 5.0, 1  # version 1's Rubber
    assert presets.current_name(s) == "Rubber" and presets.units(s, 24.0).modulus == 15.0
    path = os.path.join(H.tmpdir(), "v1.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    s = bpy.data.objects["Tail"].opdeform
    assert s.settings_version == _version() and not s.use_solver_units and s.modulus == 15.0
    assert presets.current_name(s) == "Rubber"


def test_version_3_file_keeps_its_shells_painted_follow():
    """A file saved before Shell Min (settings version 3): its detached shells keep their painted Follow (Shell Min
    0) unless Shell Min was set; its goal's mapping is not touched."""
    kept = {}
    for name, shell_min in (("Unset", None), ("Set", 0.5)):
        s = _tail(name).opdeform
        s.goal_min, s.goal_max, s.sag = 0.2, 0.9, 0.25
        if shell_min is not None:
            s.shell_follow_min = shell_min
        s.settings_version = 3
        kept[name] = shell_min
    path = os.path.join(H.tmpdir(), "v3.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    for name, shell_min in kept.items():
        s = bpy.data.objects[name].opdeform
        assert s.settings_version == _version(), (name, s.settings_version)
        assert s.shell_follow_min == (0.0 if shell_min is None else shell_min), (name, s.shell_follow_min)
        assert (round(s.goal_min, 6), round(s.goal_max, 6), round(s.sag, 6)) == (0.2, 0.9, 0.25), name
    s = _tail("New").opdeform
    assert s.settings_version == _version() and abs(s.shell_follow_min - _module("core.settings").SHELL_FOLLOW_MIN) < 1e-6


def test_goal_looks_the_same_at_any_size_and_older_files_keep_their_scaling():
    """Settings version 5 (issue 24, docs/settings.md "Size"): an object following its animation (Goal on, Dynamic
    mode) acts with E = modulus x size^2 / 2.43 m and Sag's share of gravity times size / 2.43 m (materials' "goal"
    rule: the same look at any size), without a Goal with E = modulus x size ("froude"); a file saved before
    version 5 keeps the "froude" rule (Physical Scaling on after the load), a new object has it off."""
    for name, version in (("New", None), ("Old", 4)):
        s = _tail(name, length=4.0).opdeform  # above GOAL_REFERENCE_SIZE, where the rules differ
        s.use_goal, s.sag = True, 0.5
        if version is not None:
            s.settings_version = version
    path = os.path.join(H.tmpdir(), "v4.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    m = _module("blender.presets").materials()
    for name, goal, scaling in (("New", True, "goal"), ("Old", True, "froude"), ("New", False, "froude")):
        obj = bpy.data.objects[name]
        s = obj.opdeform
        s.use_goal = goal
        assert s.settings_version == _version() and s.use_physical_scaling == (name == "Old"), name
        bpy.context.scene.frame_set(1)
        bpy.context.scene.frame_set(2)
        sim, graph = H.runtime().get(obj).engine.sim, H.runtime().get(obj).engine.graph
        params, scale = sim.params, sim.stiffness_scale
        size = m.body_size(graph)
        k = m.stiffness_for(graph, s.modulus * 1e6, size, scaling=scaling)
        sag = s.sag if goal else 1.0
        gravity = m.acting_gravity([sag * g for g in bpy.context.scene.gravity], size, scaling)
        assert np.allclose(params["stiffness"] * (1.0 if scale is None else scale), k, rtol=1e-9), (name, goal)
        assert np.allclose(params["gravity"], gravity, rtol=1e-6), (name, goal, params["gravity"], gravity)
    assert abs(size - 4.0) < 0.02 and m.acting_modulus(1.0, size, "goal") == size * size / m.GOAL_REFERENCE_SIZE


def test_version_5_file_gets_its_looks_jiggle():
    """A file saved before the looks set Jiggle (Hz) (settings version 5, the property never set): an object whose
    other values are a look's gets that look's jiggle on load, and its look is named again; a Jiggle the user set,
    and an object of no look, keep theirs; what was set is printed."""
    looks = _module("core.settings").LOOKS
    for name, look, jiggle in (("Fleshy", "Fleshy", None), ("Floppy", "Floppy", None), ("Set", "Subtle", 0.5),
                               ("Custom", "Fleshy", None)):
        obj = _tail(name)
        bpy.ops.opdeform.apply_preset(object=obj.name, preset=look)
        s = obj.opdeform
        s.property_unset("jiggle_hz")  # as saved before the property: never set
        if jiggle is not None:
            s.jiggle_hz = jiggle
        if name == "Custom":
            s.modulus = 4.0
        s.settings_version = 5
    presets = _module("blender.presets")
    assert presets.current_look(bpy.data.objects["Fleshy"].opdeform) == "Custom"  # what the artist saw
    path = os.path.join(H.tmpdir(), "v5.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    for name, jiggle, look in (("Fleshy", looks["Fleshy"]["jiggle_hz"], "Fleshy"),
                               ("Floppy", looks["Floppy"]["jiggle_hz"], "Floppy"), ("Set", 0.5, "Custom"),
                               ("Custom", 0.0, "Custom")):
        s = bpy.data.objects[name].opdeform
        assert s.settings_version == _version() and abs(s.jiggle_hz - jiggle) < 1e-6, (name, s.jiggle_hz)
        assert presets.current_look(s) == look, (name, presets.current_look(s))
    lines = _module("blender.versioning").upgrade(bpy.data.objects)
    assert lines == [], lines  # stamped: a second load changes nothing
    obj = _tail("Old")
    obj.opdeform.settings_version = 5
    obj.opdeform.property_unset("jiggle_hz")
    bpy.ops.opdeform.apply_preset(object=obj.name, preset="Subtle")
    obj.opdeform.property_unset("jiggle_hz")
    lines = _module("blender.versioning").upgrade([obj])
    assert obj.opdeform.jiggle_hz == looks["Subtle"]["jiggle_hz"] and len(lines) == 1 and "Subtle" in lines[0], lines


def _version():
    return _module("core.settings").SETTINGS_VERSION


def test_quality_report_plot_and_panel():
    obj = _tail(particles=50)
    for f in range(1, 13):
        bpy.context.scene.frame_set(f)
    rt = H.runtime().get(obj)
    rep = rt.engine.reports.get(12)
    assert 0.0 <= rep.error <= obj.opdeform.tolerance / 100.0 and rep.iterations >= 1, rep
    text = H.labels(H.draw_panels())
    assert "Frame 12: error" in text and "iterations a step" in text, text
    shown = H.positions(obj)  # the mesh's edges in the frame shown against the rest mesh: what the artist sees
    e = np.array([tuple(edge.vertices) for edge in obj.data.edges])
    rest = H.base_positions(obj)
    ratio = (np.linalg.norm(shown[e[:, 0]] - shown[e[:, 1]], axis=1) / np.linalg.norm(rest[e[:, 0]] - rest[e[:, 1]],
                                                                                      axis=1)).max()
    assert f"Largest stretch (mesh edges) {ratio:.2f}x" in text and "Largest stretch (particles)" in text, text
    p = _module("blender.error_plot").preview(rt, 12, obj.opdeform.tolerance / 100.0)
    assert tuple(p.image_size) == _module("blender.error_plot").SIZE
    pixels = np.array(p.image_pixels_float[:]).reshape(-1, 4)
    assert len(np.unique(pixels.round(3), axis=0)) >= 3  # background, grid or tolerance, and the curve


def test_warnings_stretch_thin_part_and_fast_handle():
    obj = _tail(particles=20)
    s = obj.opdeform
    s.modulus, s.use_frame_rate_substeps, s.substeps = 0.001, False, 1  # far too soft: it stretches
    for f in range(1, 25):
        bpy.context.scene.frame_set(f)
    text = H.labels(H.draw_panels())
    assert "Mesh edges stretched" in text and "Thinnest part" in text, text
    bpy.context.scene.unit_settings.scale_length = 0.01  # modelled in centimetres: its lengths read in them
    thin = [t for t in _module("blender.panels").warnings(H.runtime().get(obj), 24) if t.startswith("Thinnest")]
    bpy.context.scene.unit_settings.scale_length = 1.0
    part = H.runtime().get(obj).engine.thin_part[0]
    shown = bpy.utils.units.to_string('METRIC', 'LENGTH', 0.01 * part, precision=3)  # 0.2 units: "2 mm"
    assert thin and thin[0].startswith(f"Thinnest part {shown},") and shown.endswith(" mm"), (thin, part)
    s.modulus = 15.0
    bpy.ops.opdeform.handle_add(object=obj.name, location=(2.0, 0.0, 0.0))
    handle = s.handles[0].target
    bpy.ops.opdeform.build(object=obj.name)
    bpy.context.scene.frame_set(1)
    handle.location.z = 1.0  # a metre in one frame
    bpy.context.scene.frame_set(2)
    assert "A handle moves" in H.labels(H.draw_panels())


def test_suzanne_drop_at_defaults():
    """Suzanne (2 subdivision levels) dropped on the floor at default settings: every triangle edge under 3x
    its rest length at 100 and 1,000 particles (2 s at 24 fps)."""
    for particles in (100, 1000):
        H.fresh()
        _, check = H.suzanne_drop(particles)  # nothing else set: the defaults
        print(f"suzanne defaults particles={particles} stretch={check.stretch:.3f} eye={check.offset:.4f}")
        assert check.stretch < DropCheck.STRETCH and check.offset < DropCheck.EYE, (check.stretch, check.offset)


# -- issue 15, item 4: bounded time and memory ----------------------------------------------------------
def test_cache_range_from_minus_2_to_the_31_is_refused():
    obj = _tail(particles=20)
    s = obj.opdeform
    s.use_scene_range = False
    s.frame_start = -2 ** 31
    bpy.context.scene.frame_set(5)
    assert "at most 100,000" in s.error, s.error


def test_far_jump_is_bounded():
    """A jump to frame 3,000 simulates every frame (background) with the cache held to its size; going back
    to a dropped frame replays it bit for bit; in the UI a jump stops at the time budget, shows the last frame
    reached and says how far it is behind."""
    scene = bpy.context.scene
    scene.frame_end = 100_000
    obj = _tail(particles=20)
    obj.opdeform.use_frame_rate_substeps = False
    scene.frame_set(1)
    H.play(range(2, 40))
    early = H.positions(obj)
    rt = H.runtime().get(obj)
    rt.engine.cache.max_bytes = 200 * 1024  # ~200 frames of this tail
    scene.frame_set(3000)
    assert rt.shown == ("frame", 3000) and len(rt.engine.cache) < 260, len(rt.engine.cache)
    assert rt.engine.cache.bytes <= rt.engine.cache.max_bytes
    scene.frame_set(39)
    np.testing.assert_array_equal(H.positions(obj), early)
    rt.budget = 0.05
    scene.frame_set(100_000)
    assert 0 < rt.engine.behind < 100_000 - 39 and rt.shown[1] == 100_000 - rt.engine.behind
    assert "Catching up" in H.labels(H.draw_panels())
    assert not obj.opdeform.error


# -- issue 15, item 5: bakes -------------------------------------------------------------------------------
def _bake(obj):
    bpy.ops.opdeform.bake(object=obj.name)
    return H.runtime().cache_modifier(obj)


def test_bake_into_a_folder_that_cannot_be_made_changes_nothing():
    obj = _tail(particles=20)
    bpy.context.scene.frame_end = 10
    obj.opdeform.cache_directory = H.tmpdir() + "/good"
    old = _bake(obj)
    assert old is not None and obj.opdeform.baked
    blocker = os.path.join(H.tmpdir(), "a_file")
    open(blocker, "w").close()
    obj.opdeform.cache_directory = blocker + "/sub"
    H.expect_error(lambda: bpy.ops.opdeform.bake(object=obj.name), "cannot create the cache folder")
    mod = H.runtime().cache_modifier(obj)
    assert mod is not None and mod.filepath.endswith("good/Tail.pc2") and obj.opdeform.baked


def test_free_bake_deletes_only_what_the_bake_wrote():
    obj = _tail(particles=20)
    bpy.context.scene.frame_end = 10
    obj.opdeform.cache_directory = H.tmpdir() + "/own"
    mod = _bake(obj)
    path = bpy.path.abspath(mod.filepath)
    foreign = os.path.join(H.tmpdir(), "foreign.pc2")
    with open(path, "rb") as f, open(foreign, "wb") as g:
        g.write(f.read())
    mod.filepath = foreign  # the user points the modifier at another file
    bpy.ops.opdeform.free_bake(object=obj.name)
    assert os.path.isfile(foreign) and H.runtime().cache_modifier(obj) is None
    mod = _bake(obj)
    bpy.ops.opdeform.free_bake(object=obj.name)
    assert not os.path.exists(path) and not os.path.exists(path + ".opdeform")


def test_rename_during_bake_and_a_second_bake():
    obj = _tail(particles=20)
    bpy.context.scene.frame_end = 12
    obj.opdeform.cache_directory = H.tmpdir() + "/rename"
    rt = H.runtime()
    job = rt.BakeJob(obj, bpy.context.scene)
    for _ in range(3):
        job.step()
    H.expect_error(lambda: bpy.ops.opdeform.bake(object=obj.name), "being baked already")
    obj.name = "Renamed"
    while not job.done:
        job.step()
    assert job.finish() == 12
    assert rt.cache_modifier(obj) is not None and obj.opdeform.baked
    _bake(obj)
    assert [m.type for m in obj.modifiers].count('MESH_CACHE') == 1
