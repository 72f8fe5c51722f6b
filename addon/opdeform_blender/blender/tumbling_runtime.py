"""Tumbling particles between Blender data and core/tumbling.py: the domain, the emitter's particles, the
colliders and the settings read from the scene, the bake job, and a baked frame shown on the point cloud.

A mesh object is the domain (its world bounding box). Particles come from an emitter object's volume or a layer
of flakes; wind, a floor and the mesh objects of a collider collection (animated or not) act on them. The bake
writes one PLY per frame; the frames then play on the point cloud of blender/point_cloud.py.
"""

import contextlib

import bpy
import numpy as np

from ..core import fields as field_logic
from ..core import tumbling as core
from ..core.frames import BakeFrames
from . import colliders as scene_colliders
from . import point_cloud
from .compiled import AddonError, mpm
from .mesh_data import triangles, vertex_positions
from .parameters import cache_folder, frame_rate

_baking = {"busy": False}


def baking():
    """True while a bake moves the scene's frame: the frame handler leaves the point clouds alone then."""
    return _baking["busy"]


@contextlib.contextmanager
def _bake_frame(scene, frame):
    """Sets the scene's frame for the bake; core's ValueError and RuntimeError become AddonError."""
    _baking["busy"] = True
    try:
        scene.frame_set(frame)
        yield
    except (ValueError, RuntimeError) as exc:  # core's and core/colliders.py's ColliderError
        raise AddonError(str(exc)) from None
    finally:
        _baking["busy"] = False


def domain_box(obj):
    """The domain's world bounding box: (lower, upper) corners."""
    m = np.array(obj.matrix_world)
    corners = np.array(obj.bound_box, float) @ m[:3, :3].T + m[:3, 3]
    return corners.min(axis=0), corners.max(axis=0)


def _local_mesh(obj, role):
    verts, tris = vertex_positions(obj.data).astype(float), triangles(obj.data)
    if len(tris) == 0:
        raise AddonError(f"{role} {obj.name!r} has no faces: it needs a closed mesh")
    return verts, tris


def emitted_positions(s, lower, upper, module):
    if s.emitter == 'LAYER':
        return core.flake_layer(module, s, lower, upper)
    obj = s.emitter_object
    if obj is None:
        raise AddonError("choose an emitter object (or the Flake Layer emitter)")
    verts, tris = _local_mesh(obj, "emitter")
    return core.fill_volume(module, s, verts, tris, np.array(obj.matrix_world))


def colliders(domain, scene):
    """The collider collection's meshes (the domain's friction) and every Collision modifier's (its own
    friction, see blender/colliders.py), each once."""
    s = domain.opdeform_tumbling
    own = [o for o in (s.colliders.all_objects if s.colliders else ()) if o.type == 'MESH']
    found = {o.name: (o, s.collider_friction) for o in own}
    for o in scene_colliders.collider_objects(scene, domain, domain.opdeform_contact):
        found.setdefault(o.name, (o, scene_colliders.FRICTION_SCALE * o.collision.cloth_friction))
    out = []
    for name in sorted(found):
        obj, friction = found[name]
        verts, tris = _local_mesh(obj, "collider")
        out.append(core.Collider(name, verts, tris, np.array(obj.matrix_world), s.collider_contact, friction))
    return out


def scene_fields(domain, scene):
    """The force fields acting on the domain's flakes at the scene's frame, weighted (blender/colliders.py)."""
    return scene_colliders.fields(scene, domain.opdeform_contact, bpy.context.evaluated_depsgraph_get())


def gravity(scene):
    return tuple(scene.gravity) if scene.use_gravity else (0.0, 0.0, 0.0)


class BakeJob(BakeFrames):
    """A bake one frame at a time, with runtime.BakeJob's interface (step, done, frame, start, total, obj_name,
    path, finish, abort) so the Bake operators' shared modal code runs it with its progress bar and Esc."""

    def __init__(self, obj, scene):
        if obj is None or obj.type != 'MESH':
            raise AddonError("select the domain: a mesh object with Tumbling Particles enabled")
        s = obj.opdeform_tumbling
        if not s.enabled:
            raise AddonError(f"{obj.name!r}: enable Tumbling Particles first")
        if s.frame_end <= s.frame_start:
            raise AddonError("the cache's end frame must be after its start frame")
        module = mpm()
        self.obj_name, self.scene, self.mpm = obj.name, scene, module
        self.path = cache_folder(s.cache_directory or core.DEFAULT_FOLDER)
        self.start, self.end = s.frame_start, s.frame_end
        self.original_frame = scene.frame_current
        core.free_frames(self.path)
        with _bake_frame(scene, self.start):
            lower, upper = domain_box(obj)
            found = colliders(obj, scene)
            self.collider_names = [c.name for c in found]
            self.bake = core.Bake(module, core.settings_dict(s, gravity(scene), lower, upper),
                                  emitted_positions(s, lower, upper, module), found, self.path, self.start,
                                  self.end, frame_rate(scene))
            self.fields = field_logic.SceneFields(self.bake.world)
        s.baked, s.error = False, ""
        self.frame = self.start + 1

    def step(self):
        with _bake_frame(self.scene, self.frame):
            self.fields.set(scene_fields(bpy.data.objects[self.obj_name], self.scene))
            self.bake.step([self._collider_matrix(name) for name in self.collider_names])
        self.frame += 1

    @staticmethod
    def _collider_matrix(name):
        obj = bpy.data.objects.get(name)
        if obj is None:
            raise AddonError(f"collider {name!r} disappeared during the bake")
        return np.array(obj.matrix_world)

    def finish(self):
        """Makes the point cloud and its instances from the frames written. Returns the frame count."""
        count = self.bake.frame - self.start + 1
        obj = bpy.data.objects.get(self.obj_name)
        if obj is None:
            return count
        s = obj.opdeform_tumbling
        s.baked, s.baked_folder = True, self.path
        points = point_cloud.points_object(obj, self.scene)
        point_cloud.show_frame(points, self.mpm, self.path, self.start)
        if s.instance_object is not None:
            point_cloud.instance_nodes(points, s.instance_object)
        else:
            point_cloud.instance_nodes(points, point_cloud.snowflake_object(), s.flake_size)
        self.scene.frame_set(self.original_frame)
        return count

    def abort(self, message):
        """Stops without the frames: those written go (the last bake went when this one began); the domain's
        error says why."""
        core.free_frames(self.path)
        obj = bpy.data.objects.get(self.obj_name)
        if obj is not None:
            obj.opdeform_tumbling.error = message


def free_bake(obj):
    """Deletes the baked frames and the point cloud."""
    s = obj.opdeform_tumbling
    if s.baked_folder:
        core.free_frames(s.baked_folder)
    points = bpy.data.objects.get(s.points_name) if s.points_name else None
    if points is not None:
        bpy.data.objects.remove(points)
    s.baked, s.baked_folder, s.points_name, s.error = False, "", "", ""


def show_baked(obj, scene):
    """Shows the baked frame of the scene's frame (clamped to the baked range) on a domain's point cloud.
    Raises AddonError when that frame's file is missing."""
    s = obj.opdeform_tumbling
    points = bpy.data.objects.get(s.points_name)
    if points is None or points.type != 'MESH':  # gone, or replaced by a non-mesh of the same name
        return
    frame = core.shown_frame(scene.frame_current, s.frame_start, s.frame_end)
    if not point_cloud.show_frame(points, mpm(), s.baked_folder, frame):
        raise AddonError(f"baked frame {frame} is missing from {s.baked_folder}")
