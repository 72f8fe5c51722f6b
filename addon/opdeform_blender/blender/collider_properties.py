"""Contact and force settings stored in the .blend: ``Object.opdeform_contact`` (OPDEFORM_ContactSettings) on an
opdeform object or a tumbling domain (contact with other opdeform objects and self collision: opdeform objects
only), with its effector weights (OPDEFORM_EffectorWeights, Soft Body's and
Cloth's ``effector_weights`` for the fields opdeform reads). blender/colliders.py reads them."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, PointerProperty


def _weight(name):
    return FloatProperty(name=name, default=1.0, min=-200.0, max=200.0, soft_min=0.0, soft_max=1.0,
                         description=f"How much {name} fields push this object")


class OPDEFORM_EffectorWeights(bpy.types.PropertyGroup):
    collection: PointerProperty(name="Effector Collection", type=bpy.types.Collection,
                                description="Only the force fields in this collection act (empty: every field "
                                            "of the scene)")
    all: FloatProperty(name="All", default=1.0, min=-200.0, max=200.0, soft_min=0.0, soft_max=1.0,
                       description="Multiplies every field's push")
    wind: _weight("Wind")
    force: _weight("Force")
    vortex: _weight("Vortex")
    turbulence: _weight("Turbulence")


class OPDEFORM_ContactSettings(bpy.types.PropertyGroup):
    use_colliders: BoolProperty(name="Scene Colliders", default=True,
                                description="Collide with every object that has a Collision modifier (off: "
                                            "ignore them all)")
    collision_collection: PointerProperty(name="Collision Collection", type=bpy.types.Collection,
                                          description="Only the colliders in this collection (empty: every "
                                                      "Collision modifier of the scene)")
    effector_weights: PointerProperty(type=OPDEFORM_EffectorWeights)
    object_distance: FloatProperty(name="Object Distance", default=0.005, min=0.0001, max=1.0, subtype='DISTANCE',
                                   description="Gap kept from other opdeform objects (contact between objects with "
                                               "the same frame rate, substeps and cache range; the largest of "
                                               "the two)")
    object_friction: FloatProperty(name="Object Friction", default=5.0, min=0.0, max=80.0,
                                   description="Friction with other opdeform objects (Coulomb mu = Friction / 10; "
                                               "the mean of the two)")
    object_shape: EnumProperty(
        name="Object Shape", default='PARTICLES',
        items=(('PARTICLES', "Particles", "Other opdeform objects meet this one's particles (their ellipsoids): "
                                          "round bodies stack, flat faces rest a few centimetres apart"),
               ('SKIN', "Skin", "Other opdeform objects meet this one's skin: flat faces rest the Object Distance "
                                "apart; round bodies roll off each other (slower to simulate in contact)")),
        description="What other opdeform objects touch of this one (the floor and colliders always meet its skin)")
    use_self_collision: BoolProperty(name="Self Collision", default=False,
                                     description="Distant parts of this object collide with each other (a tail "
                                                 "against its own body); neighbouring particles never do")
    self_distance: FloatProperty(name="Self Distance", default=0.005, min=0.0001, max=1.0, subtype='DISTANCE',
                                 description="Gap kept between distant parts of this object")
    self_friction: FloatProperty(name="Self Friction", default=5.0, min=0.0, max=80.0,
                                 description="Friction between parts of this object (Coulomb mu = Friction / 10)")
    show_contacts: BoolProperty(name="Contact Points", default=True,
                                description="Mark the particles near or inside a collider in the viewport")


classes = (OPDEFORM_EffectorWeights, OPDEFORM_ContactSettings)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.opdeform_contact = PointerProperty(type=OPDEFORM_ContactSettings)


def unregister():
    del bpy.types.Object.opdeform_contact
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
