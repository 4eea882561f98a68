"""Sidebar panel and menus.  Both list the entries of OPERATORS, so a new
operator appears everywhere by adding one line there."""

import bpy

# (bl_idname, label, icon); keep in the order they should appear.
OPERATORS = [
    # Interrogation
    ("dgmesh.curvature_map", "Curvature Map", 'SMOOTHCURVE'),
    ("dgmesh.crest_lines", "Crest Lines", 'IPO_EASE_IN_OUT'),
    ("dgmesh.similarity_map", "Similarity Map", 'GROUP_VERTEX'),
    # Smoothing and fairing
    ("dgmesh.denoise", "Denoise", 'MOD_SMOOTH'),
    ("dgmesh.fair", "Fair", 'SPHERECURVE'),
    ("dgmesh.regularize", "Regularize", 'MESH_GRID'),
    # Simplification and segmentation
    ("dgmesh.decimate_features", "Feature Decimate", 'MOD_DECIM'),
    ("dgmesh.segment", "Segment", 'MOD_EXPLODE'),
    # UVs
    ("dgmesh.unwrap", "Low-Stretch Unwrap", 'UV'),
    ("dgmesh.auto_unwrap", "Auto Unwrap (Disk Charts)", 'UV_ISLANDSEL'),
    ("dgmesh.stretch_map", "UV Stretch Map", 'UV_DATA'),
    # Remeshing
    ("dgmesh.remesh", "Remesh (Double Param.)", 'MOD_REMESH'),
    # Deformation
    ("dgmesh.multires_preview", "Multires Preview", 'MOD_MULTIRES'),
    ("dgmesh.skeletal_bind", "Skeletal Bind", 'ARMATURE_DATA'),
    ("dgmesh.skeletal_rebind", "Skeletal Rebind", 'FILE_REFRESH'),
    ("dgmesh.skeletal_bake", "Skeletal Bake", 'FILE_CACHE'),
    ("dgmesh.skeletal_unbind", "Skeletal Unbind", 'UNLINKED'),
]


# The first operator of each group after the first (a gap before it in the panel and menus).
GROUP_STARTS = {"dgmesh.denoise", "dgmesh.decimate_features", "dgmesh.unwrap", "dgmesh.remesh",
                "dgmesh.multires_preview"}


def _draw_operators(layout):
    for idname, label, icon in OPERATORS:
        if idname in GROUP_STARTS:
            layout.separator()
        layout.operator(idname, text=label, icon=icon)


def _warning(layout, lines):
    """A warning the sidebar shows whole: one short label per line (a long label is cut off)."""
    col = layout.column(align=True)
    for k, text in enumerate(lines):
        col.label(text=text, icon='ERROR' if k == 0 else 'BLANK1')


class DGMESH_PT_main(bpy.types.Panel):
    bl_idname = "DGMESH_PT_main"
    bl_label = "DG Mesh"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "DG Mesh"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        _draw_operators(col)
        from . import skeletal_live, skeletal_store
        sk = skeletal_store.skeleton_of(context.active_object)
        if sk is not None:
            shown = not sk.hide_viewport and sk.visible_get()
            col.operator("dgmesh.skeletal_show_skeleton", text="Hide Skeleton" if shown else "Show Skeleton",
                         icon='HIDE_OFF' if shown else 'HIDE_ON').show = not shown
        for obj in context.scene.objects:
            if skeletal_store.has_binding(obj) and skeletal_store.fields_problem(obj):
                _warning(layout, (f"{obj.name}:", "its saved binding", "is damaged: unbind it"))
                if obj == context.active_object:
                    layout.operator("dgmesh.skeletal_unbind", icon='UNLINKED')
                continue
            if skeletal_live.armature_modifier_on(obj):
                _warning(layout, (f"{obj.name}:", "its Armature modifier is on:", "it deforms twice;",
                                  "turn the modifier off"))
            if skeletal_live.live_modifier_misplaced(obj):
                _warning(layout, (f"{obj.name}:", "move dg_skeletal to", "the top of the modifiers"))
            if skeletal_live.shown_undeformed(obj):
                _warning(layout, (f"{obj.name}:", "edited since bound,", "rebind it"))
                layout.operator("dgmesh.skeletal_rebind", icon='FILE_REFRESH').object_name = obj.name
        # Colour attributes only show in Solid shading with Color = Attribute.
        space = context.space_data
        if getattr(space, "type", None) == 'VIEW_3D' and space.shading.type == 'SOLID':
            layout.prop(space.shading, "color_type", text="Color")


class DGMESH_MT_menu(bpy.types.Menu):
    bl_idname = "DGMESH_MT_menu"
    bl_label = "DG Mesh"

    def draw(self, context):
        _draw_operators(self.layout)


def menu_entry(self, context):
    self.layout.separator()
    self.layout.menu(DGMESH_MT_menu.bl_idname)


# Object menu (Object mode) and Mesh menu (Edit mode).
MENUS = ("VIEW3D_MT_object", "VIEW3D_MT_edit_mesh")

classes = (DGMESH_MT_menu, DGMESH_PT_main)


def register_menus():
    for name in MENUS:
        menu = getattr(bpy.types, name)
        menu.remove(menu_entry)  # no-op if absent; keeps register() idempotent
        menu.append(menu_entry)


def unregister_menus():
    for name in MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.remove(menu_entry)
