"""Settings stored in the .blend: ``Object.opdeform`` (OPDEFORM_ObjectSettings) and its handles, and
``Object.opdeform_tumbling`` (OPDEFORM_TumblingSettings, a tumbling-particle domain)."""

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty, StringProperty)

from ..core import checks, tumbling
from ..core.settings import SHELL_FOLLOW_MIN
from . import presets
from .compiled import AddonError, mpm
from .discovery import mark_discovery

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

MATERIALS = (("flakes", "Flakes", "Loose flakes: no shear, no tension, they resist compression only"),
             ("snow", "Snow", "Stomakhin 2013 snow (the seed's Table 2)"),
             ("jelly", "Jelly", "Elastic, no plasticity"))
EMITTERS = (("LAYER", "Flake Layer", "Flakes scattered in a horizontal layer across the domain"),
            ("VOLUME", "Object Volume", "Particles filling the emitter object's closed mesh"))
WINDS = (("off", "Off", "No wind"), ("noise", "Noise", "Perlin-noise wind with vorticity: flakes tumble"),
         ("potential", "Curl-Free", "Gradient of Perlin noise: pushes flakes without turning them"))
CONTACTS = (("separate", "Separate", "Material may leave the surface"), ("slip", "Slip", "Slides along"),
            ("sticky", "Sticky", "Moves with the collider"))


def _poll_handle(self, obj):
    return obj.type == 'EMPTY'


def _scene(context):
    return getattr(context, "scene", None) or bpy.context.scene


def _own_range(name):
    """The update of Start or End: setting one stops following the scene; the other starts at the scene's."""
    def update(self, context):
        if self.use_scene_range:
            value = getattr(self, name)
            self.use_scene_range = False  # copies the scene's range (_scene_range_off)
            setattr(self, name, value)
    return update


def _scene_range_off(self, context):
    """Unticking Scene Range keeps the range the cache had: the scene's now."""
    if not self.use_scene_range:
        scene = _scene(context)
        self.frame_start, self.frame_end = scene.frame_start, scene.frame_end


def _enabled(self, context):
    mark_discovery()
    presets.stamp(self)


def _solver_units(self, context):
    """Setting the raw k (the Advanced sub-panel, or a script written for it) switches to solver units."""
    if not self.use_solver_units:
        self.use_solver_units = True


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
    enabled: BoolProperty(name="Oriented Particles", default=False, update=_enabled,
                          description="Simulate this mesh with oriented particles")
    built: BoolProperty(name="Built", default=False, description="A particle graph was built")
    # the object's transform at Build, column-major: a runtime rebuilt after a file load or undo is built in it again
    # (runtime.build_transform) while build_key, what it belongs to, is the object's (runtime.build_key)
    build_matrix: FloatVectorProperty(name="Build Matrix", size=16, default=(0.0,) * 16)
    build_key: StringProperty(name="Build Key", default="")
    error: StringProperty(name="Error", default="", description="The last error; the simulation is paused "
                                                                "until Reset")
    # graph
    particles: IntProperty(name="Particles", default=100, min=2, soft_max=checks.PARTICLES_OFFERED,
                           description="Number of ellipsoid particles (press Build after changing); a long or "
                           "flat closed detached shell of a rigged mesh gets at least 16 in all, those it "
                           "lacks added beyond this count")
    graph_mode: EnumProperty(name="Graph", items=GRAPH_MODE_ITEMS, default="auto")
    neighbors: IntProperty(name="Skin Neighbors", default=4, min=1, max=16,
                           description="Particles that move each vertex (m of the skinning weights)")
    # dynamics
    mode: EnumProperty(name="Mode", items=MODE_ITEMS, default="DYNAMIC")
    stiffness: FloatProperty(name="Stiffness k", default=1e5, min=1e-6, soft_min=1.0, soft_max=1e10,
                             update=_solver_units,
                             description="Solver units: the ARAP stiffness k (J/m^5); setting it turns Solver "
                                         "Units on")
    density: FloatProperty(name="Density", default=1000.0, min=1e-6, soft_max=1e5, description="kg/m^3")
    damping: FloatProperty(name="Damping per Step", default=0.0, min=0.0, max=1.0,
                           description="Solver units: share of the velocity removed each step")
    substeps: IntProperty(name="Substeps", default=1, min=1, max=100, description="Time steps per frame")
    iterations: IntProperty(name="Iterations", default=10, min=1, max=1000,
                            description="Solver units: local/global iterations per time step")
    # material units (settings version 1, docs/blender.md); Enable applies the default preset to those unset
    settings_version: IntProperty(name="Settings Version", default=0, min=0,
                                  description="0: made before material units (opens in solver units); 1: before the "
                                              "bending calibration (its modulus is tripled on load); below 5: "
                                              "before the size-free goal (Physical Scaling on load)")
    use_solver_units: BoolProperty(name="Solver Units", default=False,
                                   description="Raw k, damping per step and a fixed iteration count (files made "
                                               "before material units); off: modulus, damping per second and "
                                               "an error tolerance")
    modulus: FloatProperty(name="Stiffness", default=15.0, min=1e-6, soft_min=0.01, soft_max=1000.0, precision=2,
                           description="Young's modulus in MPa of the material at 1 m, the same look at any "
                                       "particle count (within about 12 %) and at any size: with a Goal, above "
                                       "2.43 m, the same motion in units of the size at the same keyframe "
                                       "timing (the same frequencies, Sag's gravity scaled with the size; "
                                       "below, a smaller body is stiffer, as without one); without one "
                                       "the same relative sag, a larger body swaying slower as a real one "
                                       "(docs/settings.md, \"Size\")")
    use_physical_scaling: BoolProperty(name="Physical Scaling", default=False,
                                       description="With a Goal: a larger body is softer in units of its size, as "
                                                   "a real material (the rule without a Goal; objects made "
                                                   "before settings version 5); off: the same look at any size "
                                                   "above 2.43 m")
    damping_rate: FloatProperty(name="Damping", default=0.3, min=0.0, soft_max=20.0,
                                description="Velocity lost per second (independent of the frame rate)")
    tolerance: FloatProperty(name="Tolerance", default=0.002, min=1e-6, max=10.0, precision=4, step=0.1,
                             subtype='PERCENTAGE',
                             description="Quality: each step iterates until its error (the largest move of a "
                                         "particle in the last iteration) is below this share of the body's "
                                         "size; smaller is more accurate and slower")
    max_iterations: IntProperty(name="Max Iterations", default=100, min=1, max=10000,
                                description="The most iterations a step may take to reach the tolerance")
    use_frame_rate_substeps: BoolProperty(name="Match Frame Rate", default=False,
                                          description="Substeps of at most 1/240 s, so that the motion looks the "
                                                      "same at any frame rate (10 at 24 fps, 4 at 60)")
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
    # goal: follow the animated input (Armature, shape keys, object animation) with secondary motion; the maps
    # are read every frame (no Build): docs/goals.md
    use_goal: BoolProperty(name="Goal", default=False, update=lambda s, c: presets.goal_ticked(s),
                           description="Follow the animated shape that reaches the OPDeform modifier: it is where "
                                       "the flesh comes to rest, the simulation adds its lag and overshoot "
                                       "(secondary motion); off: a soft body around the rest shape")
    goal_strength: FloatProperty(name="Follow", default=0.7, min=0.0, max=1.0, subtype='FACTOR',
                                 description="How closely the body follows the animation without a Follow Group "
                                             "(1: exactly, 0: free; in between a spring of 0.2 Hz to 1000 Hz)")
    goal_group: StringProperty(name="Follow Group", default="",
                               description="Vertex group: a weight of 1 locks a vertex to the animation, 0 frees "
                                           "it (mapped to Min..Max, and on a detached shell then into Shell "
                                           "Min..1); empty: Follow everywhere")
    goal_min: FloatProperty(name="Min", default=0.0, min=0.0, max=1.0, subtype='FACTOR',
                            description="Follow at a group weight of 0")
    goal_max: FloatProperty(name="Max", default=1.0, min=0.0, max=1.0, subtype='FACTOR',
                            description="Follow at a group weight of 1")
    shell_follow_min: FloatProperty(name="Shell Min", default=SHELL_FOLLOW_MIN, min=0.0, max=1.0,
                                    subtype='FACTOR',
                                    description="Follow of a detached shell (a separate ear, tail or trunk) where "
                                                "its group weight gives 0: its Follow is mapped into Shell Min..1, "
                                                "so that a long shell held to the body only at its root settles "
                                                "within about a second (0: as painted, the slowest swing back; "
                                                "each Look sets it: 0.3, Floppy 0.4)")
    sag: FloatProperty(name="Sag", default=0.0, min=0.0, max=1.0, subtype='FACTOR',
                       description="Share of the scene's gravity that pulls the flesh off its animation (0: the "
                                   "animation holds its shape against gravity)")
    softness_group: StringProperty(name="Softness Group", default="",
                                   description="Vertex group of softer regions (a belly, ears): at weight 1 the "
                                               "stiffness is Soft Stiffness times the body's")
    soft_stiffness: FloatProperty(name="Soft Stiffness", default=0.2, min=0.01, max=1.0, subtype='FACTOR',
                                  description="Stiffness at Softness Group weight 1, as a share of the body's")
    jiggle_hz: FloatProperty(name="Jiggle", default=0.0, min=0.0, soft_max=20.0, unit='NONE',
                             description="Hz that flesh painted Follow 0 rings at where no Softness Group is "
                                         "picked: a particle's links softened by its Follow toward it (Follow 1 "
                                         "keeps the body's stiffness; each Look sets it; 0: off)")
    damping_group: StringProperty(name="Damping Group", default="",
                                  description="Vertex group of regions damped to Region Damping at weight 1")
    region_damping: FloatProperty(name="Region Damping", default=5.0, min=0.0, soft_max=50.0,
                                  description="Damping per second at Damping Group weight 1 (the body's "
                                              "Damping at 0)")
    handles: CollectionProperty(type=OPDEFORM_HandleItem)
    handle_index: IntProperty(default=0)
    # cache
    use_scene_range: BoolProperty(name="Scene Range", default=True, update=_scene_range_off,
                                  description="The cache covers the scene's frame range and follows its changes "
                                              "(setting Start or End turns this off)")
    frame_start: IntProperty(name="Start", default=1, update=_own_range("frame_start"),
                             description="The state resets to rest at this frame")
    frame_end: IntProperty(name="End", default=250, update=_own_range("frame_end"))
    cache_directory: StringProperty(name="Folder", default="//opdeform_cache", subtype='DIR_PATH',
                                    description="Where Bake writes the PC2 file ('//' = next to the .blend)")
    baked: BoolProperty(name="Baked", default=False)
    bake_file: StringProperty(name="Bake File", default="", subtype='FILE_PATH')
    bake_signature: StringProperty(default="")
    # overlay
    show_particles: BoolProperty(name="Show Particles", default=True,
                                 description="Draw the ellipsoids and edges in the viewport")
    show_edges: BoolProperty(name="Edges", default=True)


def _material_preset(self, context):
    try:
        preset = getattr(mpm(), self.material)()
    except AddonError:
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
    cache_directory: StringProperty(name="Folder", default=tumbling.DEFAULT_FOLDER, subtype='DIR_PATH')
    flake_size: FloatProperty(name="Flake Size", default=0.03, min=1e-4, subtype='DISTANCE',
                              description="Radius of the built-in snowflake (a chosen Instance keeps its size)")
    instance_object: PointerProperty(name="Instance", type=bpy.types.Object,
                                     description="Object instanced on every particle (empty: a snowflake)")
    baked: BoolProperty(name="Baked", default=False)
    baked_folder: StringProperty(default="", subtype='DIR_PATH')
    points_name: StringProperty(default="")


classes = (OPDEFORM_HandleItem, OPDEFORM_ObjectSettings, OPDEFORM_TumblingSettings)
POINTERS = (("opdeform", OPDEFORM_ObjectSettings), ("opdeform_tumbling", OPDEFORM_TumblingSettings))


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    for name, cls in POINTERS:
        setattr(bpy.types.Object, name, PointerProperty(type=cls))


def unregister():
    for name, _ in reversed(POINTERS):
        delattr(bpy.types.Object, name)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
