"""Shared set-up for the add-on tests that run inside Blender (tests/blender/*.py)."""

import os
import shutil
import sys
import tempfile
import traceback

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
ADDON_DIR = os.path.join(ROOT, "addon")
ADDON = "opdeform_blender"
if ADDON_DIR not in sys.path:
    sys.path.insert(0, ADDON_DIR)

_tmp = {"dir": None}


def tmpdir():
    if _tmp["dir"] is None:
        _tmp["dir"] = os.environ.get("OPDEFORM_TEST_TMP") or tempfile.mkdtemp(prefix="opdeform_blender_")
        os.makedirs(_tmp["dir"], exist_ok=True)
    return _tmp["dir"]


def cleanup():
    if _tmp["dir"] and not os.environ.get("OPDEFORM_TEST_TMP"):
        shutil.rmtree(_tmp["dir"], ignore_errors=True)


def host():
    kind = "blender" if bpy.app.binary_path else "bpy-module"
    return f"{kind} {bpy.app.version_string}"


def enable_addon():
    import addon_utils
    mod = addon_utils.enable(ADDON, default_set=True, handle_error=None)
    assert mod is not None, "the add-on did not enable"
    return mod



def install_package(zip_path, kind):
    """Installs a zip of scripts/package as a new user does (kind: "legacy", the add-on zip for Blender 3.4-4.1;
    else the extension zip) and enables it; returns the add-on's module name."""
    if kind == "legacy":
        bpy.ops.preferences.addon_install(filepath=zip_path)
        import addon_utils
        assert addon_utils.enable(ADDON, default_set=True, handle_error=None) is not None
        return ADDON
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    return "bl_ext.user_default." + ADDON

def disable_addon():
    import addon_utils
    addon_utils.disable(ADDON, default_set=True)


def fresh():
    """Empty factory scene with the add-on enabled (frames 1..250, 24 fps)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    enable_addon()
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 250
    scene.frame_set(1)


def runtime():
    import importlib
    return importlib.import_module(ADDON + ".blender.runtime")


def pc2():
    """opdeform.io (PC2 files), as the add-on found it."""
    return runtime().module().io


def mesh_object(name, vertices, triangles=(), edges=(), location=(0, 0, 0)):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, v)) for v in vertices], [tuple(map(int, e)) for e in edges],
                     [tuple(map(int, t)) for t in triangles])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.context.view_layer.update()
    return obj


def box_mesh(lo, hi, n):
    """Closed box surface with n = (nx, ny, nz) vertices per side: (vertices, triangles)."""
    xs = [np.linspace(lo[a], hi[a], n[a]) for a in range(3)]
    index, verts, tris = {}, [], []

    def vid(ijk):
        if ijk not in index:
            index[ijk] = len(verts)
            verts.append([xs[a][ijk[a]] for a in range(3)])
        return index[ijk]

    for a in range(3):
        b, c = [x for x in range(3) if x != a]
        for side in (0, n[a] - 1):
            for u in range(n[b] - 1):
                for w in range(n[c] - 1):
                    def at(uu, ww):
                        t = [0, 0, 0]
                        t[a], t[b], t[c] = side, uu, ww
                        return vid(tuple(t))
                    q = [at(u, w), at(u + 1, w), at(u + 1, w + 1), at(u, w + 1)]
                    if side == 0:
                        q = q[::-1]
                    tris += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    return np.array(verts), np.array(tris)


def bar_object(name="Bar", pinned=True, particles=20):
    """The paper's bar (2 x 0.2 x 0.2 along +x) with its x = 0 end face in the vertex group "Pin"."""
    v, t = box_mesh((0.0, -0.1, -0.1), (2.0, 0.1, 0.1), (21, 5, 5))
    obj = mesh_object(name, v, t)
    if pinned:
        group = obj.vertex_groups.new(name="Pin")
        group.add([int(i) for i in np.where(v[:, 0] < 1e-9)[0]], 1.0, 'REPLACE')
        obj.opdeform.pin_group = "Pin"
    s = obj.opdeform
    s.particles = particles
    s.graph_mode = "chain"
    s.stiffness = 1e6
    return obj


def base_positions(obj):
    """The mesh's own vertex positions (the add-on never writes them)."""
    return runtime().vertex_positions(obj.data).copy()


def positions(obj):
    """What the object shows: its evaluated mesh (the OPDeform modifier's offset or the bake included)."""
    return evaluated_positions(obj)


def evaluated_positions(obj):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(depsgraph).to_mesh()
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", out)
    obj.evaluated_get(depsgraph).to_mesh_clear()
    return out.reshape(-1, 3)


def play(frames):
    """frame_set through the frames; the mesh after each (float32 copies)."""
    scene = bpy.context.scene
    out = {}
    for f in frames:
        scene.frame_set(f)
        for obj in scene.objects:
            if obj.type == 'MESH' and obj.opdeform.enabled:
                out.setdefault(obj.name, {})[f] = positions(obj)
    return out


def monkey_in(scene, levels):
    """Benchmarks: Suzanne of size 0.6 with a Subdivision of ``levels`` applied, in ``scene`` only."""
    bpy.ops.mesh.primitive_monkey_add(size=0.6)
    obj = bpy.context.active_object
    obj.modifiers.new("Subdivision", 'SUBSURF').levels = levels
    bpy.ops.object.modifier_apply(modifier="Subdivision")
    return move_to(obj, scene)


def move_to(obj, scene):
    """The object in ``scene``'s own collection only (benchmarks keep one scene per variant)."""
    for c in obj.users_collection:
        c.objects.unlink(obj)
    scene.collection.objects.link(obj)
    return obj


def play_interleaved(scenes, frames):
    """Benchmarks: each scene ({label: (scene, object)}) set to frames 1..frames, the scenes interleaved frame
    by frame; per label the median process time of scene.frame_set (ms), its wall time (wall_ms) and opdeform's
    solver time (solver_ms, None for other solvers) over frames 2..frames, in ms. An opdeform object that
    reports an error fails."""
    import statistics
    import time

    rt = runtime()
    times = {label: [] for label in scenes}
    walls = {label: [] for label in scenes}
    solver = {label: [] for label in scenes}
    for f in range(1, frames + 1):
        for label, (scene, obj) in scenes.items():
            t, wall = time.process_time(), time.perf_counter()
            scene.frame_set(f)
            times[label].append(time.process_time() - t)
            walls[label].append(time.perf_counter() - wall)
            if rt.get(obj) is not None:
                assert not obj.opdeform.error, (label, obj.opdeform.error)
                solver[label].append(rt.get(obj).engine.timing["solver"])
    return {label: dict(ms=1e3 * statistics.median(times[label][1:]),
                        wall_ms=1e3 * statistics.median(walls[label][1:]),
                        solver_ms=1e3 * statistics.median(solver[label][1:]) if solver[label] else None)
            for label in scenes}


def expect_error(fn, *words):
    """fn() must fail with an error report (bpy.ops raises RuntimeError) mentioning the words."""
    try:
        fn()
    except RuntimeError as exc:
        text = str(exc)
        for w in words:
            assert w.lower() in text.lower(), f"error {text!r} does not mention {w!r}"
        return text
    raise AssertionError(f"no error report (wanted one mentioning {words})")


def state_of(obj):
    """What "change nothing" compares: the mesh, the settings, the modifiers, the vertex groups."""
    s = obj.opdeform if hasattr(obj, "opdeform") else None
    settings = None if s is None else {k: repr(getattr(s, k)) for k in s.bl_rna.properties.keys()
                                       if k not in ("rna_type", "handles")}
    mesh = positions(obj) if obj.type == 'MESH' else None
    return (settings, None if mesh is None else mesh.tobytes(), [m.name for m in obj.modifiers],
            [g.name for g in obj.vertex_groups], len(bpy.data.objects),
            None if obj.type != 'MESH' else sorted(obj.data.attributes.keys()))


class FakeLayout:
    """Records what a panel's draw() asks for (labels, operators, properties): panels cannot be drawn in
    background mode, but their draw code can run and be checked."""

    def __init__(self, log=None, use_property_split=False):
        self.log = [] if log is None else log
        self.use_property_split = use_property_split

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)

        def call(*args, **kw):
            if name == "label":
                self.log.append(("label", kw.get("text", ""), kw.get("icon", 'NONE') != 'NONE'))
            elif name == "operator":
                self.log.append(("operator", args[0], kw.get("text")))
            elif name in ("prop", "prop_search"):
                kind = args[0].bl_rna.properties[args[1]].type
                self.log.append(("prop", args[1], _shown_text(args[0], args[1], kw), self.use_property_split, kind))
            elif name == "template_list":
                self.log.append(("list", args[0]))
            return FakeLayout(self.log, self.use_property_split)
        return call

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)


def _shown_text(data, identifier, kw):
    """The text Blender shows beside a property: text=, else the property's name ("" for an expanded enum)."""
    if "text" in kw:
        return kw["text"]
    return "" if kw.get("expand") else data.bl_rna.properties[identifier].name


class _FakePanel:
    """Stands for a panel instance: its layout records, its other attributes and methods are the class's."""

    def __init__(self, cls, layout):
        self.layout, self._cls = layout, cls

    def __getattr__(self, name):
        value = getattr(self._cls, name)
        return value.__get__(self) if callable(value) and hasattr(value, "__get__") else value


def draw_panels():
    """Runs poll/draw_header/draw of every add-on panel for the active object; the recorded log."""
    log = []
    panels = [c for c in bpy.types.Panel.__subclasses__() if c.__module__.startswith(ADDON)]
    assert panels, "no panels registered"
    for cls in panels:
        if not cls.poll(bpy.context):
            continue
        fake = _FakePanel(cls, FakeLayout(log))
        if hasattr(cls, "draw_header"):
            cls.draw_header(fake, bpy.context)
        cls.draw(fake, bpy.context)
    return log


def labels(log):
    """The labels' texts joined by spaces (a text wrapped over several labels reads whole)."""
    return " ".join(entry[1] for entry in log if entry[0] == "label")


REGION_WIDTH = 320  # the Properties editor's width in the factory layout, 1920-pixel window, UI scale 1


def cut_texts(log, region_width=REGION_WIDTH):
    """The (text, its width, the room for it) of every label and property text in a draw_panels() log that Blender
    would cut at this region width, with Blender's UI font at 11 px (its default). The room, from Blender's
    property split (0.4 of the row for the label): the row is the region less 40 px of margins; a text has 16
    px of padding, an icon or a checkbox takes 20 px. Calibrated on Blender 3.4's screenshots
    (tests/blender/screenshot_tabs.py): at 227 px "Skin Neighbors" (74 px) is cut and "Follow Min" (54 px)
    whole, at 320 px "Damping per Step" (89 px) whole."""
    import blf
    blf.size(0, 11) if bpy.app.version >= (4, 0, 0) else blf.size(0, 11, 72)
    row = region_width - 40
    cut = []
    for entry in log:
        if entry[0] == "label":
            text, room = entry[1], row - 16 - (20 if entry[2] else 0)
        elif entry[0] == "prop" and entry[2]:
            text, split, kind = entry[2], entry[3], entry[4]
            room = (0.6 * row - 36 if kind == 'BOOLEAN' else 0.4 * row - 16) if split else row - 16
        else:
            continue
        width = blf.dimensions(0, text)[0]
        if width > room:
            cut.append((text, width, room))
    return cut


FPS = 24
SWING_FRAMES = 12  # 60 degrees in 0.5 s at 24 fps, then held


def _keyframe_swing(owner, path, frames=SWING_FRAMES):
    """owner.<path>[2] (a z rotation) keyed 0 at frame 1 and 60 degrees at 1 + frames, linear, then held."""
    import math
    getattr(owner, path)[2] = 0.0
    owner.keyframe_insert(path, index=2, frame=1)
    getattr(owner, path)[2] = math.radians(60.0)
    owner.keyframe_insert(path, index=2, frame=1 + frames)
    action = owner.id_data.animation_data.action
    for fc in action_fcurves(action):
        for k in fc.keyframe_points:
            k.interpolation = 'LINEAR'


def action_fcurves(action):
    """The F-curves of an action (Blender 5's layered actions keep them in a channelbag)."""
    if hasattr(action, "fcurves") and len(action.fcurves):
        return list(action.fcurves)
    return [fc for layer in action.layers for strip in layer.strips for bag in strip.channelbags
            for fc in bag.fcurves]


def tail_rig(strength=0.5, armature=True, frames=6 * FPS, group=None):
    """The swinging-armature shot: a 2 m tail (the bar, 20 chain particles, gravity off) skinned to a 2-bone
    armature whose root bone swings 60 degrees about z in 0.5 s and stops (armature=False: the tail object
    itself is keyframed). group: a goal weight group of this weight on every vertex. Returns the tail."""
    scene = bpy.context.scene
    scene.use_gravity = False
    scene.render.fps = FPS
    scene.frame_end = frames
    tail = bar_object("Tail", pinned=False)
    if armature:
        rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
        scene.collection.objects.link(rig)
        bpy.context.view_layer.objects.active = rig
        bpy.ops.object.mode_set(mode='EDIT')
        root = rig.data.edit_bones.new("Root")
        root.head, root.tail = (0, 0, 0), (1, 0, 0)
        tip = rig.data.edit_bones.new("Tip")
        tip.head, tip.tail, tip.parent, tip.use_connect = (1, 0, 0), (2, 0, 0), root, True
        bpy.ops.object.mode_set(mode='OBJECT')
        x = np.array([v.co.x for v in tail.data.vertices])
        w_tip = np.clip(x - 0.5, 0.0, 1.0)
        for name, w in (("Root", 1.0 - w_tip), ("Tip", w_tip)):
            g = tail.vertex_groups.new(name=name)
            for i, wi in enumerate(w):
                g.add([i], float(wi), 'REPLACE')
        tail.modifiers.new("Armature", 'ARMATURE').object = rig
        bone = rig.pose.bones["Root"]
        bone.rotation_mode = 'XYZ'
        _keyframe_swing(bone, "rotation_euler")
    else:
        _keyframe_swing(tail, "rotation_euler")
    if group is not None:
        g = tail.vertex_groups.new(name="Goal")
        g.add(list(range(len(tail.data.vertices))), group, 'REPLACE')
        tail.opdeform.goal_group = "Goal"
    s = tail.opdeform
    s.use_goal, s.goal_strength = True, strength
    s.frame_start, s.frame_end = 1, frames
    bpy.context.view_layer.objects.active = tail
    bpy.ops.opdeform.enable(object=tail.name)
    return tail


def animated_positions(obj):
    """The input at the OPDeform modifier now (the animation without opdeform's effect), object space."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    n = len(obj.data.vertices)
    positions, index = runtime().modifier.read_input(obj.evaluated_get(depsgraph).data, n)
    return runtime().original_input(positions, index, n)


def tail_motion(obj, frames):
    """Plays the frames; per frame (world space): the tip's output, the tip's animated position, and the
    largest distance of any output vertex from the animation."""
    scene = bpy.context.scene
    tip = int(np.argmin(np.linalg.norm(base_positions(obj) - (2.0, 0.0, 0.0), axis=1)))  # on the tail's axis
    out = []
    for f in frames:
        scene.frame_set(f)
        m = np.array(obj.matrix_world)
        shown, animated = positions(obj) @ m[:3, :3].T + m[:3, 3], animated_positions(obj) @ m[:3, :3].T + m[:3, 3]
        out.append((shown[tip], animated[tip], np.linalg.norm(shown - animated, axis=1).max()))
    return out


def animated_or_plain(obj):
    """The object's evaluated mesh with every opdeform modifier off (the plain animation)."""
    saved = [(m, m.show_viewport) for m in obj.modifiers if m.name.startswith("OPDeform")]
    for m, _ in saved:
        m.show_viewport = False
    try:
        return evaluated_positions(obj)
    finally:
        for m, v in saved:
            m.show_viewport = v


def suzanne_drop(particles, **settings):
    """Blender's Suzanne with a Subdivision of 2 levels applied (a head and two loose eyeballs), tilted 15
    degrees with its lowest point 0.3 m above the floor, enabled with Floor, the particle count and the other
    settings given, dropped for 2 s at 24 fps (the drop of issues 12 and 14). Returns (the object, its
    tests/suzanne_check.DropCheck)."""
    import math
    sys.path.insert(0, os.path.dirname(HERE))  # tests/: the check shared with the core's tests
    from suzanne_check import DropCheck
    bpy.ops.mesh.primitive_monkey_add(rotation=(math.radians(15.0), 0.0, 0.0))
    obj = bpy.context.active_object
    mod = obj.modifiers.new("Subdivision", 'SUBSURF')
    mod.levels = 2
    bpy.ops.object.modifier_apply(modifier=mod.name)
    obj.location.z = 0.3 - min((obj.matrix_world @ v.co).z for v in obj.data.vertices)
    s = obj.opdeform
    s.particles, s.use_floor = particles, True
    for name, value in settings.items():
        setattr(s, name, value)
    bpy.ops.opdeform.enable(object=obj.name)
    check = DropCheck(base_positions(obj), runtime().triangles(obj.data))
    for f in range(1, 2 * FPS + 1):
        bpy.context.scene.frame_set(f)
        check.update(positions(obj).astype(np.float64))
    assert not obj.opdeform.error, obj.opdeform.error
    return obj, check


def start_in_ui(setup, first_interval=1.0):
    """Runs setup() from a timer once Blender's window is up (screenshot scripts); on an error the traceback is
    printed and Blender quits, so the caller never waits on a window that will not draw."""
    def guarded():
        try:
            setup()
        except Exception:
            traceback.print_exc()
            bpy.ops.wm.quit_blender()
    bpy.app.timers.register(guarded, first_interval=first_interval)
