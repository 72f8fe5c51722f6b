"""What the Physics tab's panels share (panels.py, settings_panels.py, collider_panels.py): their base classes,
laid out like Blender's Soft Body and Cloth panels, and small drawing helpers."""


class PhysicsPanel:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "physics"

    @classmethod
    def poll(cls, context):
        obj = context.object
        return obj is not None and obj.type == 'MESH'


class SubPanel(PhysicsPanel):
    bl_parent_id = "PHYSICS_PT_opdeform"

    @classmethod
    def poll(cls, context):
        obj = context.object
        return obj is not None and obj.type == 'MESH' and obj.opdeform.enabled


class ToggledSubPanel(SubPanel):
    """A sub-panel whose header holds an on/off setting (``toggle``) that greys out its body when off."""
    toggle = ""

    def draw_header(self, context):
        self.layout.prop(context.object.opdeform, self.toggle, text="")

    def body(self, context):
        layout, obj, s = split(self.layout, context)
        layout.active = getattr(s, self.toggle)
        return layout, obj, s


def prepared(layout):
    """The layout with property split, as Blender's physics panels draw their settings."""
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout


def split(layout, context):
    """(the layout with property split, the object, its settings)."""
    return prepared(layout), context.object, context.object.opdeform


def wrapped(layout, text, icon='NONE', width=40):
    """text as labels of at most ``width`` characters a line, whole at the factory Properties width (333 px)."""
    col = layout.column(align=True)
    words, line, first = text.split(), "", True
    for w in words:
        if len(line) + len(w) + 1 > width:
            col.label(text=line, icon=icon if first else 'BLANK1')
            line, first = w, False
        else:
            line = f"{line} {w}".strip()
    if line:
        col.label(text=line, icon=icon if first else 'BLANK1')
