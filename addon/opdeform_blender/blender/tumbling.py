"""Physics tab > Tumbling Particles: MLS-MPM snow or flakes whose particles turn with the material.

A mesh object is the domain (its world bounding box). Particles come from an emitter object's volume or
a layer of flakes; wind, a floor and the mesh objects of a collider collection (animated or not) act on
them. Bake writes one PLY per frame (core/tumbling.py) with the deformation bake's progress and Esc; the
frames then play on a point-cloud object "<domain> Particles" whose "orientation" attribute (a quaternion
from Blender 4.1, XYZ Euler angles before) turns a snowflake, or any object, instanced by Geometry Nodes.
"""

import os

import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty,
                       PointerProperty, StringProperty)
from bpy.app.handlers import persistent
import numpy as np

from ..core import tumbling as core
from . import runtime
from .operators import OPDEFORM_OT_bake, _ObjectOperator
from .panels import _PhysicsPanel, _wrapped

ATTRIBUTE = "orientation"
MATERIALS = (("flakes", "Flakes", "Loose flakes: no shear, no tension, they resist compression only"),
             ("snow", "Snow", "Stomakhin 2013 snow (the seed's Table 2)"),
             ("jelly", "Jelly", "Elastic, no plasticity"))
EMITTERS = (("LAYER", "Flake Layer", "Flakes scattered in a horizontal layer across the domain"),
            ("VOLUME", "Object Volume", "Particles filling the emitter object's closed mesh"))
WINDS = (("off", "Off", "No wind"), ("noise", "Noise", "Perlin-noise wind with vorticity: flakes tumble"),
         ("potential", "Curl-Free", "Gradient of Perlin noise: pushes flakes without turning them"))
CONTACTS = (("separate", "Separate", "Material may leave the surface"), ("slip", "Slip", "Slides along"),
            ("sticky", "Sticky", "Moves with the collider"))
_guard = {"busy": False}


def _mpm():
    import importlib
    return importlib.import_module(runtime.module().__name__ + ".mpm")


def _material_preset(self, context):
    try:
        preset = getattr(_mpm(), self.material)()
    except runtime.AddonError:
        return  # the module is missing: the panel says so; keep the values
    self.density, self.young_modulus, self.poisson_ratio = preset.density, preset.young_modulus, \
        preset.poisson_ratio


class OPDEFORM_TumblingSettings(bpy.types.PropertyGroup):
    enabled: BoolProperty(name="Tumbling Particles", default=False)
    error: StringProperty(name="Error", default="")
    dx: FloatProperty(name="Grid Spacing", default=0.05, min=1e-4, soft_max=1.0, subtype='DISTANCE',
                      description="MPM grid cell size; the domain is this object's bounding box")
    spin: FloatProperty(name="Spin", default=1.0, min=0.0, soft_max=5.0,
                        description="η: scales each particle's rotation angle (0 = plain MLS-MPM, no turning)")
    material: EnumProperty(name="Material", items=MATERIALS, default="flakes", update=_material_preset)
    density: FloatProperty(name="Density", default=100.0, min=1e-3, description="kg/m^3")
    young_modulus: FloatProperty(name="Young's Modulus", default=1e3, min=1e-3, description="Pa")
    poisson_ratio: FloatProperty(name="Poisson Ratio", default=0.3, min=0.0, max=0.49)
    emitter: EnumProperty(name="Emitter", items=EMITTERS, default="LAYER")
    emitter_object: PointerProperty(name="Object", type=bpy.types.Object, poll=lambda s, o: o.type == 'MESH')
    spacing: FloatProperty(name="Particle Spacing", default=0.025, min=1e-4, subtype='DISTANCE',
                           description="Distance between particles filling a volume (and each one's size)")
    count: IntProperty(name="Flakes", default=2000, min=1, soft_max=100000)
    layer_height: FloatProperty(name="Height", default=0.8, min=0.0, max=1.0, subtype='FACTOR',
                                description="Where the layer lies between the domain's bottom and top")
    layer_thickness: FloatProperty(name="Thickness", default=0.1, min=0.0, max=1.0, subtype='FACTOR')
    seed: IntProperty(name="Seed", default=0, min=0)
    wind: EnumProperty(name="Wind", items=WINDS, default="noise")
    wind_velocity: FloatVectorProperty(name="Mean Velocity", size=3, default=(0.5, 0.0, 0.0), subtype='VELOCITY')
    wind_amplitude: FloatProperty(name="Strength", default=1.5, min=0.0, description="m/s of the noise")
    wind_wavelength: FloatProperty(name="Wavelength", default=1.5, min=1e-3, subtype='DISTANCE')
    wind_octaves: IntProperty(name="Octaves", default=4, min=1, max=16)
    wind_persistence: FloatProperty(name="Persistence", default=0.6, min=0.01, soft_max=2.0)
    wind_drift: FloatVectorProperty(name="Drift", size=2, default=(0.4, 0.1),
                                    description="m/s: the noise pattern moves with this velocity")
    wind_drag: FloatProperty(name="Air Drag", default=8.0, min=0.0, description="1/s: how fast the air "
                                                                                "carries the particles along")
    wind_exponent: FloatProperty(name="Height Exponent", default=0.4, min=0.0, soft_max=2.0,
                                 description="The wind grows as height^exponent above the domain's bottom")
    use_floor: BoolProperty(name="Floor", default=True)
    floor_height: FloatProperty(name="Height", default=0.0, subtype='DISTANCE')
    floor_friction: FloatProperty(name="Friction", default=0.3, min=0.0)
    colliders: PointerProperty(name="Colliders", type=bpy.types.Collection,
                               description="Mesh objects (animated or not) that push the particles")
    collider_contact: EnumProperty(name="Contact", items=CONTACTS, default="separate")
    collider_friction: FloatProperty(name="Friction", default=0.3, min=0.0)
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=120)
    cache_directory: StringProperty(name="Folder", default="//opdeform_tumbling", subtype='DIR_PATH')
    flake_size: FloatProperty(name="Flake Size", default=0.03, min=1e-4, subtype='DISTANCE',
                              description="Radius of the built-in snowflake (a chosen Instance keeps its size)")
    instance_object: PointerProperty(name="Instance", type=bpy.types.Object,
                                     description="Object instanced on every particle (empty: a snowflake)")
    baked: BoolProperty(name="Baked", default=False)
    baked_folder: StringProperty(default="", subtype='DIR_PATH')
    points_name: StringProperty(default="")


# -- gathering the scene -------------------------------------------------------------------------------------
def domain_box(obj):
    corners = np.array([obj.matrix_world @ _vector(c) for c in obj.bound_box])
    return corners.min(axis=0), corners.max(axis=0)


def _vector(c):
    from mathutils import Vector
    return Vector(c)


def _local_mesh(obj):
    mesh = obj.data
    verts = runtime.vertex_positions(mesh).astype(float)
    return verts, runtime.triangles(mesh)


def emitted_positions(s, lower, upper, mpm):
    if s.emitter == 'VOLUME':
        obj = s.emitter_object
        if obj is None:
            raise runtime.AddonError("choose an emitter object (or the Flake Layer emitter)")
        verts, tris = _local_mesh(obj)
        if len(tris) == 0:
            raise runtime.AddonError(f"emitter {obj.name!r} has no faces: it needs a closed mesh")
        m = np.array(obj.matrix_world)
        return mpm.fill_mesh(verts @ m[:3, :3].T + m[:3, 3], tris, s.spacing, jitter=0.5, seed=s.seed)
    # the layer keeps 3 cells clear of the domain's faces (particles must start 2 cells inside)
    inner_lo, inner_hi = lower + 3 * s.dx, upper - 3 * s.dx
    if np.any(inner_hi <= inner_lo):
        raise runtime.AddonError("the domain is too small for its grid spacing: lower Grid Spacing")
    size = inner_hi - inner_lo
    thickness = s.layer_thickness * size[2]
    centre = inner_lo + size * [0.5, 0.5, 0.0]
    centre[2] = np.clip(lower[2] + s.layer_height * (upper[2] - lower[2]), inner_lo[2] + thickness / 2,
                        inner_hi[2] - thickness / 2)
    return mpm.flake_layer(centre, size[:2], thickness, s.count, seed=s.seed)


def colliders(s):
    out = []
    for obj in (s.colliders.all_objects if s.colliders else ()):
        if obj.type != 'MESH':
            continue
        verts, tris = _local_mesh(obj)
        if len(tris) == 0:
            raise runtime.AddonError(f"collider {obj.name!r} has no faces: colliders need a closed mesh")
        out.append(core.Collider(obj.name, verts, tris, np.array(obj.matrix_world), s.collider_contact,
                                 s.collider_friction))
    return out


def settings_dict(s, scene, lower, upper):
    gravity = tuple(scene.gravity) if scene.use_gravity else (0.0, 0.0, 0.0)
    wind = None
    if s.wind != "off":
        wind = {"kind": s.wind, "velocity": tuple(s.wind_velocity), "amplitude": s.wind_amplitude,
                "wavelength": s.wind_wavelength, "octaves": s.wind_octaves, "persistence": s.wind_persistence,
                "drift": tuple(s.wind_drift), "drag": s.wind_drag, "ground": float(lower[2]),
                "ref_height": float(upper[2] - lower[2]), "exponent": s.wind_exponent, "seed": s.seed + 1}
    return {"lower": tuple(lower), "upper": tuple(upper), "dx": s.dx, "gravity": gravity, "spin": s.spin,
            "material": s.material, "density": s.density, "young_modulus": s.young_modulus,
            "poisson_ratio": s.poisson_ratio, "spacing": s.spacing, "seed": s.seed, "wind": wind,
            "floor": (s.floor_height, s.floor_friction) if s.use_floor else None}


def cache_folder(s):
    folder = s.cache_directory or "//opdeform_tumbling"
    if folder.startswith("//") and not bpy.data.filepath:
        raise runtime.AddonError("save the .blend file first, or choose an absolute cache folder")
    return bpy.path.abspath(folder)


# -- the point cloud and its instances -----------------------------------------------------------------------
def _quaternion_attributes():
    return bpy.app.version >= core.QUATERNION_ATTRIBUTES


def show_frame(points, mpm, folder, frame):
    """Loads a baked frame into the point cloud; False when its file is missing."""
    data = core.read_frame(mpm, folder, frame)
    if data is None:
        return False
    show_particles(points, mpm, *data)
    return True


def show_particles(points, mpm, positions, quaternions):
    """Sets the point cloud's vertices and orientation attribute (quaternions w x y z)."""
    mesh = points.data
    if len(mesh.vertices) != len(positions):
        mesh.clear_geometry()
        mesh.vertices.add(len(positions))
    runtime.write_positions(mesh, np.ascontiguousarray(positions, dtype=np.float32))
    attr = mesh.attributes.get(ATTRIBUTE)
    if attr is None:
        attr = mesh.attributes.new(ATTRIBUTE, 'QUATERNION' if _quaternion_attributes() else 'FLOAT_VECTOR', 'POINT')
    if attr.data_type == 'QUATERNION':
        attr.data.foreach_set("value", np.ascontiguousarray(quaternions, dtype=np.float32).ravel())
    else:
        euler = mpm.quaternions_to_euler(quaternions)
        attr.data.foreach_set("vector", np.ascontiguousarray(euler, dtype=np.float32).ravel())
    mesh.update()


def snowflake_object():
    """The add-on's snowflake: a six-armed star of radius 1 in the xy plane (not linked to any scene)."""
    import importlib
    scenes = importlib.import_module(runtime.module().__name__ + ".mpm_scenes")
    name = "OPDeform Snowflake"
    obj = bpy.data.objects.get(name)
    if obj is None:
        verts, tris = scenes.snowflake_mesh(radius=1.0)
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata([tuple(v) for v in verts], [], [tuple(int(i) for i in t) for t in tris])
        mesh.update()
        obj = bpy.data.objects.new(name, mesh)
    return obj


def _geometry_sockets(group):
    if hasattr(group, "interface"):  # Blender 4.0+
        group.interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
        group.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    else:
        group.inputs.new('NodeSocketGeometry', "Geometry")
        group.outputs.new('NodeSocketGeometry', "Geometry")


def instance_nodes(points, instance, scale=1.0):
    """Geometry Nodes on the point cloud: Instance on Points of `instance` (its own geometry, without its
    transform) scaled by `scale` and turned by the orientation attribute."""
    name = f"{points.name} Instances"
    old = bpy.data.node_groups.get(name)
    if old is not None:
        bpy.data.node_groups.remove(old)
    group = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    _geometry_sockets(group)
    nodes, links = group.nodes, group.links
    gin, gout = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    info = nodes.new('GeometryNodeObjectInfo')
    info.inputs["Object"].default_value = instance
    info.transform_space = 'ORIGINAL'
    attr = nodes.new('GeometryNodeInputNamedAttribute')
    attr.data_type = 'QUATERNION' if _quaternion_attributes() else 'FLOAT_VECTOR'
    attr.inputs["Name"].default_value = ATTRIBUTE
    place = nodes.new('GeometryNodeInstanceOnPoints')
    place.inputs["Scale"].default_value = (scale, scale, scale)
    links.new(gin.outputs[0], place.inputs["Points"])
    links.new(info.outputs["Geometry"], place.inputs["Instance"])
    links.new(next(o for o in attr.outputs if o.name == "Attribute" and o.enabled), place.inputs["Rotation"])
    links.new(place.outputs["Instances"], gout.inputs[0])
    mod = points.modifiers.get("Tumbling Instances") or points.modifiers.new("Tumbling Instances", 'NODES')
    mod.node_group = group
    return mod


def points_object(domain, scene):
    s = domain.opdeform_tumbling
    name = s.points_name or f"{domain.name} Particles"
    obj = bpy.data.objects.get(name)
    if obj is None or obj.type != 'MESH':
        obj = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        scene.collection.objects.link(obj)
    s.points_name = obj.name
    return obj


# -- bake ----------------------------------------------------------------------------------------------------
class TumblingBakeJob:
    """The interface of runtime.BakeJob (step, done, frame, start, total, finish), so the deformation bake's
    operator runs it with its progress bar and Esc."""

    def __init__(self, obj, scene):
        if obj is None or obj.type != 'MESH':
            raise runtime.AddonError("select the domain: a mesh object with Tumbling Particles enabled")
        s = obj.opdeform_tumbling
        if not s.enabled:
            raise runtime.AddonError(f"{obj.name!r}: enable Tumbling Particles first")
        if s.frame_end <= s.frame_start:
            raise runtime.AddonError("the cache's end frame must be after its start frame")
        mpm = _mpm()
        self.obj_name, self.scene, self.mpm = obj.name, scene, mpm
        self.path = cache_folder(s)
        self.start, self.end = s.frame_start, s.frame_end
        self.original_frame = scene.frame_current
        free_frames(self.path)
        _guard["busy"] = True
        try:
            scene.frame_set(self.start)
            lower, upper = domain_box(obj)
            self.collider_names = []
            found = colliders(s)
            self.collider_names = [c.name for c in found]
            try:
                self.bake = core.Bake(mpm, settings_dict(s, scene, lower, upper),
                                      emitted_positions(s, lower, upper, mpm), found, self.path, self.start,
                                      self.end, scene.render.fps / scene.render.fps_base)
            except (ValueError, RuntimeError) as exc:
                raise runtime.AddonError(str(exc)) from None
        finally:
            _guard["busy"] = False
        s.baked, s.error = False, ""
        self.frame = self.start + 1

    @property
    def total(self):
        return self.end - self.start + 1

    @property
    def done(self):
        return self.frame > self.end

    def step(self):
        _guard["busy"] = True
        try:
            self.scene.frame_set(self.frame)
            matrices = []
            for name in self.collider_names:
                obj = bpy.data.objects.get(name)
                if obj is None:
                    raise runtime.AddonError(f"collider {name!r} disappeared during the bake")
                matrices.append(np.array(obj.matrix_world))
            try:
                self.bake.step(matrices)
            except (ValueError, RuntimeError) as exc:
                raise runtime.AddonError(str(exc)) from None
        finally:
            _guard["busy"] = False
        self.frame += 1

    def finish(self):
        """Makes the point cloud and its instances from the frames written. Returns the frame count."""
        count = self.bake.frame - self.start + 1
        obj = bpy.data.objects.get(self.obj_name)
        if obj is None:
            return count
        s = obj.opdeform_tumbling
        s.baked, s.baked_folder = True, self.path
        points = points_object(obj, self.scene)
        show_frame(points, self.mpm, self.path, self.start)
        if s.instance_object is not None:
            instance_nodes(points, s.instance_object)
        else:
            instance_nodes(points, snowflake_object(), s.flake_size)
        self.scene.frame_set(self.original_frame)
        return count


def free_frames(folder):
    for frame in core.baked_frames(folder):
        os.remove(core.frame_file(folder, frame))


@persistent
def tumbling_frame_change(scene, depsgraph=None):
    """Shows the baked frame (clamped to the baked range) on every domain's point cloud."""
    if _guard["busy"]:
        return
    for obj in scene.objects:
        s = getattr(obj, "opdeform_tumbling", None)
        if s is None or not s.enabled or not s.baked:
            continue
        points = bpy.data.objects.get(s.points_name)
        if points is None or points.type != 'MESH':  # gone, or replaced by a non-mesh of the same name
            continue
        frame = min(max(scene.frame_current, s.frame_start), s.frame_end)
        try:
            if not show_frame(points, _mpm(), s.baked_folder, frame):
                s.error = f"baked frame {frame} is missing from {s.baked_folder}"
        except Exception as exc:  # a damaged frame file or a bug: report it, never raise from a handler
            s.error = str(exc) if isinstance(exc, (runtime.AddonError, OSError, ValueError)) else \
                f"{type(exc).__name__}: {exc}"


# -- operators and panel -------------------------------------------------------------------------------------
class OPDEFORM_OT_tumbling_enable(_ObjectOperator, bpy.types.Operator):
    """Make this mesh the domain of a tumbling-particle simulation (its bounding box)"""
    bl_idname = "opdeform.tumbling_enable"
    bl_label = "Enable Tumbling Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj, rt):
        if obj is None or obj.type != 'MESH':
            raise rt.AddonError("select a mesh object: its bounding box becomes the domain")
        s = obj.opdeform_tumbling
        s.enabled = True
        s.frame_start, s.frame_end = context.scene.frame_start, context.scene.frame_end
        obj.display_type = 'WIRE'
        return {'FINISHED'}


class OPDEFORM_OT_tumbling_disable(_ObjectOperator, bpy.types.Operator):
    """Stop using this mesh as a tumbling-particle domain (the baked frames stay on disk)"""
    bl_idname = "opdeform.tumbling_disable"
    bl_label = "Disable Tumbling Particles"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj, rt):
        if obj is None:
            raise rt.AddonError("no object")
        obj.opdeform_tumbling.enabled = False
        return {'FINISHED'}


class OPDEFORM_OT_tumbling_bake(_ObjectOperator, bpy.types.Operator):
    """Bake the tumbling particles to one PLY file per frame and show them as instanced flakes. Esc cancels
    and keeps the frames baked so far"""
    bl_idname = "opdeform.tumbling_bake"
    bl_label = "Bake Tumbling Particles"
    bl_options = {'REGISTER', 'UNDO'}

    # The deformation bake's blocking, modal (progress bar, Esc) and reporting code, borrowed rather than
    # inherited: Blender loses the Python class of a registered operator that another one subclasses.
    _job = None
    _timer = None
    execute = OPDEFORM_OT_bake.execute
    invoke = OPDEFORM_OT_bake.invoke
    modal = OPDEFORM_OT_bake.modal
    _end = OPDEFORM_OT_bake._end

    def _begin(self, context):
        return TumblingBakeJob(self.target(context), context.scene)


class OPDEFORM_OT_tumbling_free_bake(_ObjectOperator, bpy.types.Operator):
    """Delete the baked frames and the point cloud"""
    bl_idname = "opdeform.tumbling_free_bake"
    bl_label = "Free Bake"
    bl_options = {'REGISTER', 'UNDO'}

    def run(self, context, obj, rt):
        if obj is None:
            raise rt.AddonError("no object")
        s = obj.opdeform_tumbling
        if s.baked_folder:
            free_frames(s.baked_folder)
        points = bpy.data.objects.get(s.points_name) if s.points_name else None
        if points is not None:
            bpy.data.objects.remove(points)
        s.baked, s.baked_folder, s.points_name, s.error = False, "", "", ""
        return {'FINISHED'}


class PHYSICS_PT_opdeform_tumbling(_PhysicsPanel, bpy.types.Panel):
    bl_label = "Tumbling Particles"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = self.layout
        obj = context.object
        s = obj.opdeform_tumbling
        if not s.enabled:
            layout.operator("opdeform.tumbling_enable", icon='MOD_PARTICLES')
            return
        row = layout.row()
        row.label(text="Domain: this object's bounding box", icon='MESH_CUBE')
        row.operator("opdeform.tumbling_disable", text="", icon='X')
        if s.error:
            box = layout.box()
            box.alert = True
            _wrapped(box, s.error, 'ERROR')
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column()
        for name in ("dx", "spin", "material", "density", "young_modulus", "poisson_ratio"):
            col.prop(s, name)
        col = layout.column(heading="Emitter")
        col.prop(s, "emitter")
        if s.emitter == 'VOLUME':
            col.prop(s, "emitter_object")
            col.prop(s, "spacing")
        else:
            for name in ("count", "layer_height", "layer_thickness", "spacing"):
                col.prop(s, name)
        col.prop(s, "seed")
        col = layout.column(heading="Wind")
        col.prop(s, "wind")
        if s.wind != "off":
            for name in ("wind_velocity", "wind_amplitude", "wind_wavelength", "wind_octaves", "wind_persistence",
                         "wind_drift", "wind_drag", "wind_exponent"):
                col.prop(s, name)
        col = layout.column(heading="Colliders")
        col.prop(s, "use_floor")
        if s.use_floor:
            col.prop(s, "floor_height")
            col.prop(s, "floor_friction")
        col.prop(s, "colliders")
        col.prop(s, "collider_contact")
        col.prop(s, "collider_friction")
        col = layout.column(heading="Display")
        col.prop(s, "instance_object")
        col.prop(s, "flake_size")
        col = layout.column(align=True)
        col.prop(s, "frame_start")
        col.prop(s, "frame_end")
        layout.prop(s, "cache_directory")
        row = layout.row(align=True)
        row.operator("opdeform.tumbling_bake", icon='REC')
        row.operator("opdeform.tumbling_free_bake", icon='TRASH')
        if s.baked:
            layout.label(text=f"Baked to {s.baked_folder}", icon='CHECKMARK')


classes = (OPDEFORM_TumblingSettings, OPDEFORM_OT_tumbling_enable, OPDEFORM_OT_tumbling_disable,
           OPDEFORM_OT_tumbling_bake, OPDEFORM_OT_tumbling_free_bake, PHYSICS_PT_opdeform_tumbling)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.opdeform_tumbling = PointerProperty(type=OPDEFORM_TumblingSettings)
    if tumbling_frame_change not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(tumbling_frame_change)


def unregister():
    while tumbling_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(tumbling_frame_change)
    del bpy.types.Object.opdeform_tumbling
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
