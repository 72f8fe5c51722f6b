"""Pieces shared by the outside-view rig scripts (scripts/outside_rigs.py, outside_bird.py, outside_fish.py,
outside_knight.py, outside_bear.py, outside_pig.py, outside_chubby.py, outside_blob.py): the arguments, objects linked into the scene, parented to an
armature with automatic weights, painted groups, mesh shells, world positions, the base mesh and the armature-only
twin; the add-on installed from a zip, its settings tuned and printed, the panels after the group picked, a bake
against playback; a saved file reopened."""
import json
import os
import sys
import time

import bpy
import numpy as np
from mathutils import Vector

TESTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "blender")


def options():
    """The script's arguments (after "--" under Blender, else after the script): ZIP, KIND, OUT (made) and the
    options after them as a dict (NAME=VALUE, or NAME: True)."""
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    os.makedirs(args[2], exist_ok=True)
    return (*args[:3], dict((a.partition("=")[0], a.partition("=")[2] or True) for a in args[3:]))


def gauss(v, centre, radii):
    """Per point of v, a bump of 1 at centre falling off over radii (x, y, z): where a body is pushed out."""
    return np.exp(-sum(((v[:, k] - centre[k]) / radii[k]) ** 2 for k in range(3)))


def install(zip_path, kind):
    """The add-on as a new user has it: the zip installed into the (empty) user folders, kind "legacy" or
    "extension"; kind "dev" (zip "-"): the repository's add-on with $OPDEFORM_PYTHONPATH. Its module name."""
    sys.path.insert(0, TESTS)
    import helpers
    if kind == "dev":
        helpers.enable_addon()
        return helpers.ADDON
    sys.path[:] = [p for p in sys.path if os.path.abspath(p) != os.path.abspath(helpers.ADDON_DIR)]
    return helpers.install_package(zip_path, kind)


def empty_scene(fps, frames):
    """The scene emptied of objects, at fps, frames 1..frames; the scene."""
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    sc = bpy.context.scene
    sc.render.fps, sc.frame_start, sc.frame_end = fps, 1, frames
    return sc


def link(obj):
    bpy.context.scene.collection.objects.link(obj)
    return obj


def parent_auto(obj, arm):
    bpy.ops.object.select_all(action='DESELECT')
    obj.select_set(True)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.parent_set(type='ARMATURE_AUTO')


def paint(obj, name, w):
    g = obj.vertex_groups.new(name=name)
    for value in np.unique(w):
        g.add([int(i) for i in np.where(w == value)[0]], float(value), 'REPLACE')


def shells(obj):
    """Per vertex, its connected piece's index (ordered by first vertex)."""
    n = len(obj.data.vertices)
    parent = np.arange(n)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for e in obj.data.edges:
        a, b = find(e.vertices[0]), find(e.vertices[1])
        if a != b:
            parent[max(a, b)] = min(a, b)
    return np.array([find(i) for i in range(n)])


def world(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    me = ev.to_mesh()
    out = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", out)
    ev.to_mesh_clear()
    m = np.array(ev.matrix_world)
    return out.reshape(-1, 3).astype(float) @ m[:3, :3].T + m[:3, 3]


def base(obj):
    out = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", out)
    return out


def twin_of(obj):
    t = obj.copy()
    t.data = obj.data.copy()
    t.name = obj.name + "_twin"
    for m in [m for m in t.modifiers if m.type != 'ARMATURE']:
        t.modifiers.remove(m)
    bpy.context.scene.collection.objects.link(t)
    return t


def save(obj, folder):
    """Frame 30 shown, its world positions into folder/f30.npy and the file into folder/NAME.blend (NAME the
    object's name in lower case), for reopen."""
    bpy.context.scene.frame_set(30)
    np.save(os.path.join(folder, "f30.npy"), world(obj))
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, f"{obj.name.lower()}.blend"))


def reopen(folder, zip_path, kind, name):
    """Opens folder/NAME.blend (NAME the object's name in lower case) as an artist does, the add-on installed from
    the zip: is frame 30 the simulated pose saved beside it (f30.npy), before and after a frame change?"""
    install(zip_path, kind)
    bpy.ops.wm.open_mainfile(filepath=os.path.join(folder, f"{name.lower()}.blend"))
    obj, ref = bpy.data.objects[name], np.load(os.path.join(folder, "f30.npy"))
    twin = world(bpy.data.objects[f"{name}_twin"])
    print("REOPEN frame", bpy.context.scene.frame_current, "vs saved mm", 1e3 * np.abs(world(obj) - ref).max(),
          "saved vs armature-only mm", 1e3 * np.abs(ref - twin).max(), "error", repr(obj.opdeform.error))
    for f in (31, 30):
        bpy.context.scene.frame_set(f)
    print("REOPEN after 31->30 vs saved mm", 1e3 * np.abs(world(obj) - ref).max())


def artist_enable(obj, particles=None):
    """The artist's order on obj, made active and alone selected: [Particles,] Enable (printed), Goal ticked, the
    Follow group picked."""
    bpy.context.view_layer.objects.active = obj
    for x in bpy.context.scene.objects:
        x.select_set(x == obj)
    s = obj.opdeform
    if particles is not None:
        s.particles = int(particles)
    print("ENABLE ->", bpy.ops.opdeform.enable())
    s.use_goal = True
    s.goal_group = "Follow"
    return s


def tuned(s, opt):
    """The options' look=NAME (picked from the Goal panel's menu) and +NAME=VALUE settings of obj.opdeform, in
    that order, as an artist sets them after the group."""
    if "look" in opt:
        print("LOOK ->", opt["look"], bpy.ops.opdeform.apply_preset(preset=opt["look"]))
    for key, value in ((k[1:], v) for k, v in opt.items() if k.startswith("+")):
        kind = type(getattr(s, key))
        setattr(s, key, value in ("1", "True", "true") if kind is bool else kind(value))


SETTINGS = ("particles", "goal_strength", "goal_min", "goal_max", "shell_follow_min", "sag", "modulus",
            "damping_rate", "soft_stiffness")


def settings(s, *more):
    """The settings that make a look (and the named ones more), rounded, for a print."""
    return {k: round(getattr(s, k), 4) for k in SETTINGS + more}


def first_panels(obj, H, shown):
    """What the artist sees once the group is picked: the panel's labels and reports, the labels cut at the
    default width, and the settings (shown, a dict), the error and the modifier stack."""
    log = H.draw_panels()
    print("PANEL AFTER GROUP", reports(log))
    print("CUT", [c[0] for c in H.cut_texts(log)])
    print("SETTINGS", shown, "error", repr(obj.opdeform.error), "mods", [(m.name, m.type) for m in obj.modifiers])


def bake_check(obj, H, folder, frames):
    """Bake into folder/cache, compare the frames with the playback just before, free the bake."""
    s, shown = obj.opdeform, {}
    for f in frames:
        bpy.context.scene.frame_set(f)
        shown[f] = world(obj)
    s.cache_directory = os.path.join(folder, "cache")
    print("BAKE ->", bpy.ops.opdeform.bake())
    diff = 0.0
    for f in frames:
        bpy.context.scene.frame_set(f)
        diff = max(diff, 1e3 * np.abs(world(obj) - shown[f]).max())
    print("BAKED", bool(s.baked), "bake vs playback mm", diff, "PANEL", reports(H.draw_panels()))
    print("FREE BAKE ->", bpy.ops.opdeform.free_bake())


def armature(name, bones, connected, scale=1.0):
    """An armature object ``name`` of ``bones`` (name, head, tail, parent or None, deforms) scaled by ``scale``,
    each joined to its parent where connected(name, parent)."""
    arm = link(bpy.data.objects.new(name, bpy.data.armatures.new(name)))
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    for bone, h, t, p, d in bones:
        b = arm.data.edit_bones.new(bone)
        b.head, b.tail, b.use_deform = Vector(h) * scale, Vector(t) * scale, d
        if p:
            b.parent, b.use_connect = arm.data.edit_bones[p], connected(bone, p)
    bpy.ops.object.mode_set(mode='OBJECT')
    return arm


def reports(log):
    """The panel's labels and the operators' reports in a draw log (helpers' draw_panels)."""
    return [e[2] or e[1] if e[0] == "operator" else e[1] for e in log if e[0] in ("label", "operator")]


def taper(w, parts, param, lows):
    """Follow weights w with each named part (name, low) going from 1 at its root to low at its tip (param: 0 to 1
    along it), rounded as painted."""
    for name, low in lows:
        w[parts[name]] = 1 - (1 - low) * param[parts[name]]
    return w.round(3)


class Shot:
    """A shot replayed against its armature-only twin: the Follow-1 core (a vertex mask), the mesh's edges and its
    base mesh as found, for the scripts' measures."""

    def __init__(self, obj, twin, parts, core, H):
        self.obj, self.twin, self.parts, self.H = obj, twin, parts, H
        self.core = np.where(core)[0]
        self.edges = np.array([e.vertices[:] for e in obj.data.edges]).T
        self.before = base(obj)

    @staticmethod
    def timed(f):
        """Frame f set; the processor seconds it took."""
        t0 = time.process_time()
        bpy.context.scene.frame_set(f)
        return time.process_time() - t0

    def against_twin(self):
        """The shown frame: the mesh's and the twin's world positions, each vertex's distance between them and
        each edge's length over its length in the twin (its stretch against the animation)."""
        a, b = world(self.obj), world(self.twin)
        i, j = self.edges
        st = np.linalg.norm(a[i] - a[j], axis=1) / np.linalg.norm(b[i] - b[j], axis=1)
        return a, b, np.linalg.norm(a - b, axis=1), st

    def played(self, frames):
        """Frames 1..frames from the start through self.frame(f) -> (CPU s, {figure: value}): the figures per
        frame as columns, the errors the settings showed (frame, error) and the CPU seconds in all."""
        s, rows, errors, cpu = self.obj.opdeform, [], [], 0.0
        for f in range(1, frames + 1):
            c, r = self.frame(f)
            cpu += c
            rows.append(r)
            if s.error:
                errors.append((f, s.error))
        return {k: np.array([r[k] for r in rows]) for k in rows[0]}, errors, cpu

    def look(self):
        """The look the settings hold (presets.current_look), "Custom" for none."""
        return sys.modules[self.H.ADDON + ".blender.presets"].current_look(self.obj.opdeform)


class PartsShot(Shot):
    """A shot with named loose parts, played frames 1..frames with a dead stop at frame `stop` (fps frames a
    second): per part its largest distance from the armature-only twin while moving, 1 s after the stop, and when
    it last was 2 mm off; the core, the stretch (with its worst edge), the floor, the base mesh, errors, CPU."""

    def __init__(self, obj, twin, parts, follow, H, frames, stop, fps):
        super().__init__(obj, twin, parts, follow >= 0.999, H)
        self.size = np.ptp(world(twin)[:, 2])
        self.follow = follow
        self.frames, self.stop, self.fps = frames, stop, fps
        self.trace = False  # artist_session's opt "trace": each part's distance per frame after the stop printed

    def frame(self, f):
        cpu = self.timed(f)
        a, b, d, st = self.against_twin()
        return cpu, dict(core=d[self.core].max(), stretch=st.max(), stretch999=np.percentile(st, 99.9),
                         over=int((st > 1.5).sum()), stretch_edge=int(np.argmax(st)), low=a[:, 2].min(),
                         low_twin=b[:, 2].min(), nan=bool(np.isnan(a).any()),
                         **{k: d[ix].max() for k, ix in self.parts.items()})

    def part_of(self, i):
        """The named part vertex i lies in, else "body"."""
        part = [k for k, ix in self.parts.items() if i in ix]
        return part[0] if part else "body"

    def where(self, e):
        """The worst edge's vertices: rest length, position, Follow, and which part (or body)."""
        i, j = int(self.edges[0, e]), int(self.edges[1, e])
        v = self.obj.data.vertices
        return dict(rest_len_mm=round(1e3 * (v[i].co - v[j].co).length, 2), co=[round(c, 3) for c in v[i].co],
                    follow=float(self.follow[i]), part=self.part_of(i))

    def play(self, label):
        col, errors, cpu = self.played(self.frames)
        s, fr = self.obj.opdeform, np.arange(1, self.frames + 1)
        moving, after = fr <= self.stop, fr >= self.stop + self.fps
        settle = {}
        for k in self.parts:
            late = np.where((fr > self.stop) & (col[k] >= 2e-3))[0]
            settle[k] = round((fr[late[-1]] - self.stop) / self.fps, 2) if len(late) else 0.0
        worst = np.argmax(col["stretch"])
        row = dict(label=label, host=bpy.app.version_string, particles=s.particles, look=self.look(),
                   size_m=round(self.size, 3), core_mm=round(1e3 * col["core"].max(), 3),
                   moving_pct={k: round(100 * col[k][moving].max() / self.size, 2) for k in self.parts},
                   moving_mm={k: round(1e3 * col[k][moving].max(), 1) for k in self.parts},
                   after_1s_mm={k: round(1e3 * col[k][after].max(), 3) for k in self.parts},
                   settle_s_2mm=settle, stretch=round(col["stretch"].max(), 3),
                   stretch_p99_9=round(col["stretch999"].max(), 3),
                   edges_over_1_5x_worst_frame=int(col["over"].max()), edges=self.edges.shape[1],
                   stretch_frame=int(fr[worst]), stretch_at=self.where(col["stretch_edge"][worst]),
                   floor_pen_mm=round(-1e3 * min(col["low"].min(), 0.0), 2),
                   lowest_twin_mm=round(1e3 * col["low_twin"].min(), 2), nan=bool(col["nan"].any()),
                   base_kept=bool(np.array_equal(base(self.obj), self.before)), errors=errors[:3],
                   cpu_ms_frame=round(1e3 * cpu / self.frames, 2))
        print("ROW " + json.dumps(row, default=float), flush=True)
        if self.trace:  # each part's distance per frame from the stop on: its ringing and decay
            print("TRACE", json.dumps({k: [round(1e3 * x, 2) for x in col[k][self.stop - 1:]] for k in self.parts}))
        print("PANEL", reports(self.H.draw_panels()))
        return row


def scrub(obj, shot):
    """The artist scrubs: frame 30 and 60 shown after a straight play, then 96 -> 30, 10 -> 60 (a jump ahead),
    1 -> 60 again: each against the straight play (mm) and the armature-only twin (mm)."""
    sc, ref = bpy.context.scene, {}
    for f in range(1, 61):
        sc.frame_set(f)
        if f in (30, 60):
            ref[f] = world(obj)
    for a, b in ((96, 30), (10, 60), (1, 60)):
        sc.frame_set(a)
        sc.frame_set(b)
        print(f"SCRUB {a}->{b} vs straight play mm", round(1e3 * np.abs(world(obj) - ref[b]).max(), 3),
              "vs armature-only mm", round(1e3 * np.abs(world(obj) - world(shot.twin)).max(), 3),
              "error", repr(obj.opdeform.error))


def artist_session(shot, H, opt, out, bake_frames, between=None):
    """The artist's session on a shot built and its add-on installed: Enable (Particles from opt), the opt's
    settings, the panels, a play; then between(shot) if given, and as opt asks: scrub, bake, the three looks, save."""
    obj, shot.trace = shot.obj, "trace" in opt
    bpy.context.scene.frame_set(1)
    s = artist_enable(obj, opt.get("particles"))
    tuned(s, opt)
    first_panels(obj, H, settings(s))
    shot.play("default")
    if between:
        between(shot)
    if "scrub" in opt:
        scrub(obj, shot)
    if "bake" in opt:
        bake_check(obj, H, out, bake_frames)
    if "looks" in opt:
        for look in ("Subtle", "Fleshy", "Floppy"):
            print("LOOK ->", look, bpy.ops.opdeform.apply_preset(preset=look), settings(s))
            shot.play(look)
    if "save" in opt:
        save(obj, out)


def skin_body(name, nodes, edges, levels):
    """A body made as artists block one out: a skeleton of (position, radius) nodes and edges under the Skin
    modifier, then Subdivision ``levels``, both applied. The linked object, made active."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([p for p, _ in nodes], edges, [])
    obj = link(bpy.data.objects.new(name, me))
    bpy.context.view_layer.objects.active = obj
    obj.modifiers.new("Skin", 'SKIN')
    for i, (_, r) in enumerate(nodes):
        me.skin_vertices[0].data[i].radius = (r, r)
    me.skin_vertices[0].data[0].use_root = True
    obj.modifiers.new("Subdivision", 'SUBSURF').levels = levels
    for m in list(obj.modifiers):
        bpy.ops.object.modifier_apply(modifier=m.name)
    return obj


def reshaped(obj, push, gap=0.004):
    """obj's mesh moved by push(v) (it moves the vertices' positions v, an (n, 3) array, in place), then lifted
    to stand gap over z = 0; what push returns."""
    me = obj.data
    v = np.array([x.co for x in me.vertices])
    out = push(v)
    v[:, 2] -= v[:, 2].min() - gap
    me.vertices.foreach_set("co", v.ravel())
    me.update()
    return out


def collision_floor():
    """A 20 m floor plane with a Collision modifier, as the shots stand on."""
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    bpy.context.active_object.name = "Floor"
    bpy.context.active_object.modifiers.new("Collision", 'COLLISION')


def joined(obj, part):
    """part (a mesh object) joined into obj as a separate shell; the new vertices' indices in obj."""
    n = len(obj.data.vertices)
    for x in bpy.context.scene.objects:
        x.select_set(x in (obj, part))
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.join()
    return np.arange(n, len(obj.data.vertices))


def still(path, frame, eye, target, hidden=()):
    """A Workbench still of frame into path (PNG), a camera at eye looking at target, the objects hidden left
    out of it."""
    sc = bpy.context.scene
    sc.frame_set(frame)
    sc.render.engine = 'BLENDER_WORKBENCH'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 640, 480, 100
    cam = link(bpy.data.objects.new("Still", bpy.data.cameras.new("Still")))
    cam.location = Vector(eye)
    cam.rotation_euler = (Vector(target) - cam.location).to_track_quat('-Z', 'Y').to_euler()
    sc.camera, sc.render.filepath = cam, path
    for o in hidden:
        o.hide_render = True
    bpy.ops.render.render(write_still=True)
    for o in hidden:
        o.hide_render = False
    bpy.data.objects.remove(cam)
    print("RENDER", path)


def run_shot(name, shot_of, bake_frames, between=None):
    """A script's run on its arguments: with open=OUT, OUT's saved file reopened (the object name); else the add-on
    installed, the shot shot_of(helpers) built and the artist's session played on it (bake_frames, between as
    artist_session's)."""
    zip_path, kind, out, opt = options()
    if "open" in opt:
        return reopen(opt["open"], zip_path, kind, name)
    addon = install(zip_path, kind)
    import helpers as H
    H.ADDON = addon
    artist_session(shot_of(H), H, opt, out, bake_frames, between)


def linear_pose(arm):
    """arm's pose bones, rotated in XYZ Euler, every key inserted from now on linear (a dead stop stays dead)."""
    bpy.context.preferences.edit.keyframe_new_interpolation_type = 'LINEAR'
    for b in arm.pose.bones:
        b.rotation_mode = 'XYZ'
    return arm.pose.bones
