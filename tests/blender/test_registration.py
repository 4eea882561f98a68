"""The add-on registers like a user's add-on; panel, menus, preferences."""

import os

import addon_utils
import bpy
import pytest

from helpers import curvature_map, open_fixture, select

CLASS_NAMES = ("DGMESH_OT_curvature_map", "DGMESH_PT_main", "DGMESH_MT_menu")


def _menu_funcs(menu_name):
    # The draw functions appended to a menu (bpy's own bookkeeping).
    return list(getattr(bpy.types, menu_name)._dyn_ui_initialize())


def _registered():
    return {name: hasattr(bpy.types, name) for name in CLASS_NAMES}


class FakeLayout:
    """Records what a draw() function puts into a layout."""

    def __init__(self):
        self.operators = []

    def operator(self, idname, **kw):
        self.operators.append(idname)

    def column(self, **kw):
        return self

    def row(self, **kw):
        return self

    def prop(self, *a, **kw):
        pass

    def label(self, **kw):
        pass

    def separator(self, **kw):
        pass

    def menu(self, *a, **kw):
        pass


def test_enabled_as_addon():
    loaded_default, loaded_state = addon_utils.check("dgmesh")
    assert loaded_default and loaded_state
    assert bpy.context.preferences.addons.get("dgmesh") is not None
    assert all(_registered().values())
    assert bpy.ops.dgmesh.curvature_map.get_rna_type().bl_rna.identifier == "DGMESH_OT_curvature_map"


def test_panel_and_menus():
    from dgmesh.blender import ui

    panel = bpy.types.DGMESH_PT_main
    assert (panel.bl_space_type, panel.bl_region_type, panel.bl_category, panel.bl_label) == (
        'VIEW_3D', 'UI', "DG Mesh", "DG Mesh")
    for menu in ("VIEW3D_MT_object", "VIEW3D_MT_edit_mesh"):
        assert _menu_funcs(menu).count(ui._menu_entry) == 1, menu

    # Panel and submenu list every registered entry of ui.OPERATORS.
    expected = [idname for idname, _label, _icon in ui.OPERATORS]
    for cls in (ui.DGMESH_PT_main, ui.DGMESH_MT_menu):
        fake = FakeLayout()
        cls.draw(type("Self", (), {"layout": fake})(), bpy.context)
        assert fake.operators == expected
    for idname in expected:
        module, name = idname.split(".")
        getattr(getattr(bpy.ops, module), name).get_rna_type()  # raises KeyError if missing


def test_disable_enable_cycle():
    addon_utils.disable("dgmesh", default_set=True)
    try:
        assert not any(_registered().values())
        from dgmesh.blender import ui
        for menu in ("VIEW3D_MT_object", "VIEW3D_MT_edit_mesh"):
            assert ui._menu_entry not in _menu_funcs(menu)
        with pytest.raises((KeyError, AttributeError)):
            bpy.ops.dgmesh.curvature_map.get_rna_type()
    finally:
        addon_utils.enable("dgmesh", default_set=True)
    assert all(_registered().values())

    # Repeated register() (e.g. script reload) and unregister/register stay clean.
    import dgmesh
    dgmesh.register()
    dgmesh.unregister()
    dgmesh.unregister()
    dgmesh.register()
    dgmesh.register()
    assert all(_registered().values())
    for menu in ("VIEW3D_MT_object", "VIEW3D_MT_edit_mesh"):
        assert _menu_funcs(menu).count(dgmesh.blender.ui._menu_entry) == 1

    # And the operator still works.
    open_fixture("shapes")
    select("QuadSphere")
    assert curvature_map() == {'FINISHED'}


def test_thread_count_preference(dg):
    prefs = bpy.context.preferences.addons["dgmesh"].preferences
    try:
        prefs.num_threads = 1
        assert dg.num_threads() == 1
        prefs.num_threads = 2
        assert dg.num_threads() == 2
    finally:
        prefs.num_threads = 0
    assert dg.num_threads() == len(os.sched_getaffinity(0))  # 0 = all usable cores


def test_poll_explains_itself():
    open_fixture("shapes")
    select()
    assert not bpy.ops.dgmesh.curvature_map.poll()
    with pytest.raises(RuntimeError, match="Select one or more mesh objects"):
        bpy.ops.dgmesh.curvature_map()

    # Only non-mesh objects selected.
    empty = bpy.data.objects.new("Empty", None)
    bpy.context.scene.collection.objects.link(empty)
    select("Empty")
    assert not bpy.ops.dgmesh.curvature_map.poll()
