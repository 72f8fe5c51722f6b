"""Sub-panels "Collisions" and "Field Weights" of the Oriented Particles and Tumbling Particles panels, laid out
like Cloth's Collisions and Soft Body's Field Weights (``Object.opdeform_contact``)."""

import bpy

from .panel_base import PhysicsPanel, SubPanel, prepared

WEIGHTS = ("all", "wind", "force", "vortex", "turbulence")


def draw_collisions(layout, settings, bodies=False):
    """The Collisions sub-panel; ``bodies``: with contact between opdeform objects and self collision."""
    layout = prepared(layout)
    col = layout.column()
    col.active = settings.use_colliders
    col.prop(settings, "collision_collection", text="Collection")
    layout.prop(settings, "show_contacts")
    if not bodies:
        return
    col = layout.column(align=True)
    col.prop(settings, "object_distance")
    col.prop(settings, "object_friction")
    col.prop(settings, "object_shape")
    layout.prop(settings, "use_self_collision")
    col = layout.column(align=True)
    col.active = settings.use_self_collision
    col.prop(settings, "self_distance", text="Distance")
    col.prop(settings, "self_friction", text="Friction")


def draw_weights(layout, weights):
    layout = prepared(layout)
    layout.prop(weights, "collection", text="Collection")
    col = layout.column(align=True)
    for name in WEIGHTS:
        col.prop(weights, name, slider=True)


class _TumblingSubPanel(PhysicsPanel):
    bl_parent_id = "PHYSICS_PT_opdeform_tumbling"
    bl_options = {'DEFAULT_CLOSED'}

    @classmethod
    def poll(cls, context):
        obj = context.object
        return obj is not None and obj.type == 'MESH' and obj.opdeform_tumbling.enabled


class _Collisions:
    bl_label = "Collisions"
    bodies = False  # contact with other opdeform objects and self collision (opdeform objects only)

    def draw_header(self, context):
        self.layout.prop(context.object.opdeform_contact, "use_colliders", text="")

    def draw(self, context):
        draw_collisions(self.layout, context.object.opdeform_contact, self.bodies)


class _FieldWeights:
    bl_label = "Field Weights"

    def draw(self, context):
        draw_weights(self.layout, context.object.opdeform_contact.effector_weights)


class PHYSICS_PT_opdeform_collisions(_Collisions, SubPanel, bpy.types.Panel):
    bl_options = {'DEFAULT_CLOSED'}
    bodies = True


class PHYSICS_PT_opdeform_field_weights(_FieldWeights, SubPanel, bpy.types.Panel):
    bl_options = {'DEFAULT_CLOSED'}


class PHYSICS_PT_opdeform_tumbling_collisions(_Collisions, _TumblingSubPanel, bpy.types.Panel):
    pass


class PHYSICS_PT_opdeform_tumbling_field_weights(_FieldWeights, _TumblingSubPanel, bpy.types.Panel):
    pass


classes = (PHYSICS_PT_opdeform_collisions, PHYSICS_PT_opdeform_field_weights, PHYSICS_PT_opdeform_tumbling_collisions,
           PHYSICS_PT_opdeform_tumbling_field_weights)

# registers in the order of `classes`, unregisters in the reverse order
register, unregister = bpy.utils.register_classes_factory(classes)
