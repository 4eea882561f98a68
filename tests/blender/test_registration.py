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

    def prop(self, data, name="", **kw):
        self.props = getattr(self, "props", []) + [name]

    def label(self, **kw):
        pass

    def separator(self, **kw):
        self.operators.append("|")

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
        assert _menu_funcs(menu).count(ui.menu_entry) == 1, menu

    # Panel and submenu list every registered entry of ui.OPERATORS (no active object: a bound one
    # adds state-dependent entries such as Show Skeleton).
    bpy.ops.wm.read_homefile(use_empty=True)
    expected = [idname for idname, _label, _icon in ui.OPERATORS]
    for cls in (ui.DGMESH_PT_main, ui.DGMESH_MT_menu):
        fake = FakeLayout()
        cls.draw(type("Self", (), {"layout": fake})(), bpy.context)
        # The groups (interrogation, smoothing, simplification, UVs, remeshing, deformation) are
        # set apart.
        assert fake.operators.count("|") == 5
        assert [o for o in fake.operators if o != "|"] == expected
    for idname in expected:
        module, name = idname.split(".")
        getattr(getattr(bpy.ops, module), name).get_rna_type()  # raises KeyError if missing


def test_disable_enable_cycle():
    addon_utils.disable("dgmesh", default_set=True)
    try:
        assert not any(_registered().values())
        from dgmesh.blender import ui
        for menu in ("VIEW3D_MT_object", "VIEW3D_MT_edit_mesh"):
            assert ui.menu_entry not in _menu_funcs(menu)
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
        assert _menu_funcs(menu).count(dgmesh.blender.ui.menu_entry) == 1

    # Another add-on's handlers named like ours stay.
    namespace = {"__name__": "other_addon"}
    exec("def _on_load(*args):\n    pass\n", namespace)
    foreign = namespace["_on_load"]
    bpy.app.handlers.load_post.append(foreign)
    try:
        dgmesh.unregister()
        dgmesh.register()
        assert foreign in bpy.app.handlers.load_post
        from dgmesh.blender import skeletal_live
        assert skeletal_live.on_load in bpy.app.handlers.load_post
    finally:
        bpy.app.handlers.load_post.remove(foreign)

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


def _draw_redo_panel(idname, mode):
    """The props an operator's draw() puts in its redo panel, with its default property values."""
    cls = getattr(bpy.types, "DGMESH_OT_" + idname.split(".")[1])
    values = {}
    module, name = idname.split(".")
    for p in getattr(getattr(bpy.ops, module), name).get_rna_type().properties:
        if p.type == 'ENUM':
            values[p.identifier] = p.default or p.enum_items[0].identifier
        elif p.type in ('BOOLEAN', 'INT', 'FLOAT', 'STRING'):
            values[p.identifier] = p.default if getattr(p, "array_length", 0) == 0 else tuple(p.default_array)
    fake = FakeLayout()
    stub = type("Self", (), dict(values, layout=fake))()
    context = type("Context", (), {"mode": mode})()
    cls.draw(stub, context)
    return fake.props


def test_redo_panels_draw_in_both_modes():
    from dgmesh.blender import ui

    drawn = {}
    for idname, _label, _icon in ui.OPERATORS:
        cls = getattr(bpy.types, "DGMESH_OT_" + idname.split(".")[1])
        if "draw" in cls.__dict__:
            for mode in ('OBJECT', 'EDIT_MESH'):
                drawn[idname, mode] = _draw_redo_panel(idname, mode)
    # Edit-mode-only options are not offered in Object mode.
    assert "keep_border" not in drawn["dgmesh.regularize", 'OBJECT']
    assert "keep_border" in drawn["dgmesh.regularize", 'EDIT_MESH']
    assert {"steps", "margin"} <= set(drawn["dgmesh.unwrap", 'OBJECT'])
