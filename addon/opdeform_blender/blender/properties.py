"""Settings stored in the .blend: ``Object.opdeform`` (OPDEFORM_ObjectSettings) and its handles."""

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty, StringProperty)

GRAPH_MODE_ITEMS = (
    ("auto", "Auto", "Volume for closed meshes, surface for open or thin ones"),
    ("volume", "Volume", "Particles fill the inside of a closed mesh"),
    ("surface", "Surface", "Particles cover the surface (sheets, thin shells)"),
    ("chain", "Chain", "A 1-D chain along the principal axis (bars, tails, ropes)"),
)
MODE_ITEMS = (
    ("DYNAMIC", "Dynamics", "Playing the timeline simulates (jiggle, soft body, falling)"),
    ("POSE", "Posing", "No dynamics: moving a handle re-solves the static ARAP pose"),
)


def _poll_handle(self, obj):
    return obj.type == 'EMPTY'


def _mark_discovery(self, context):
    from . import handlers
    handlers.mark_discovery()


class OPDEFORM_HandleItem(bpy.types.PropertyGroup):
    target: PointerProperty(name="Handle", type=bpy.types.Object, poll=_poll_handle,
                            description="Empty whose location moves the nearest vertex and whose orientation "
                                        "turns the mesh there")
    use_rotation: BoolProperty(name="Rotation", default=True,
                               description="The empty's orientation drives direction constraints at the vertex")
    strength: FloatProperty(name="Strength", default=1.0, min=0.0, soft_max=10.0,
                            description="Multiplies the solver's default constraint weight")
    # bound at Build (or when the handle is first seen): nearest rest vertex and the empty's rest transform
    vertex: IntProperty(name="Vertex", default=-1, min=-1)
    rest_matrix: FloatVectorProperty(name="Rest Matrix", size=16, default=(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0,
                                                                           0, 0, 0, 1))
    bound_name: StringProperty(name="Bound To", default="")


class OPDEFORM_ObjectSettings(bpy.types.PropertyGroup):
    enabled: BoolProperty(name="Oriented Particles", default=False, update=_mark_discovery,
                          description="Simulate this mesh with oriented particles")
    built: BoolProperty(name="Built", default=False, description="A particle graph was built")
    error: StringProperty(name="Error", default="", description="The last error; the simulation is paused "
                                                                "until Reset")
    # graph
    particles: IntProperty(name="Particles", default=100, min=2, soft_max=2000,
                           description="Number of ellipsoid particles (press Build after changing)")
    graph_mode: EnumProperty(name="Graph", items=GRAPH_MODE_ITEMS, default="auto")
    neighbors: IntProperty(name="Skin Neighbors", default=4, min=1, max=16,
                           description="Particles that move each vertex (m of the skinning weights)")
    # dynamics
    mode: EnumProperty(name="Mode", items=MODE_ITEMS, default="DYNAMIC")
    stiffness: FloatProperty(name="Stiffness", default=1e5, min=1e-6, soft_min=1.0, soft_max=1e10,
                             description="ARAP stiffness k (Pa/m^2)")
    density: FloatProperty(name="Density", default=1000.0, min=1e-6, soft_max=1e5, description="kg/m^3")
    damping: FloatProperty(name="Damping", default=0.0, min=0.0, max=1.0,
                           description="Share of the velocity removed each step")
    substeps: IntProperty(name="Substeps", default=1, min=1, max=100, description="Time steps per frame")
    iterations: IntProperty(name="Iterations", default=10, min=1, max=1000,
                            description="Local/global iterations per time step")
    pose_iterations: IntProperty(name="Pose Iterations", default=30, min=1, max=10000,
                                 description="Iterations per static solve in posing mode")
    pose_gravity: BoolProperty(name="Gravity", default=False,
                               description="Posing mode: let the scene's gravity weigh on the pose (off: pure ARAP "
                                           "posing)")
    # floor
    use_floor: BoolProperty(name="Floor", default=False)
    floor_height: FloatProperty(name="Height", default=0.0, subtype='DISTANCE')
    floor_friction: FloatProperty(name="Friction", default=0.5, min=0.0, soft_max=2.0)
    # pins and handles
    pin_group: StringProperty(name="Pin Group", default="",
                              description="Vertex group whose vertices are held in place (weight = constraint "
                                          "weight); read at Build")
    pin_strength: FloatProperty(name="Pin Strength", default=1.0, min=0.0, soft_max=10.0)
    handles: CollectionProperty(type=OPDEFORM_HandleItem)
    handle_index: IntProperty(default=0)
    # cache
    frame_start: IntProperty(name="Start", default=1, description="The state resets to rest at this frame")
    frame_end: IntProperty(name="End", default=250)
    cache_directory: StringProperty(name="Folder", default="//opdeform_cache", subtype='DIR_PATH',
                                    description="Where Bake writes the PC2 file ('//' = next to the .blend)")
    baked: BoolProperty(name="Baked", default=False)
    bake_file: StringProperty(name="Bake File", default="", subtype='FILE_PATH')
    bake_signature: StringProperty(default="")
    # overlay
    show_particles: BoolProperty(name="Show Particles", default=True,
                                 description="Draw the ellipsoids and edges in the viewport")
    show_edges: BoolProperty(name="Edges", default=True)


classes = (OPDEFORM_HandleItem, OPDEFORM_ObjectSettings)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.opdeform = PointerProperty(type=OPDEFORM_ObjectSettings)


def unregister():
    del bpy.types.Object.opdeform
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
