"""dgmesh.blender.compat: each version difference, in whichever Blender runs the suite (the test
lanes run 3.4, 4.3 and 5.x), checked against where that Blender itself keeps the data."""

import bmesh
import bpy
import numpy as np
import pytest

from dgmesh import shapes
from dgmesh.blender import compat


@pytest.fixture
def cube():
    bpy.ops.wm.read_homefile(use_empty=True)
    V, quads = shapes.rounded_cube(4, quads=True)
    mesh = bpy.data.meshes.new("Cube")
    mesh.from_pydata([tuple(v) for v in V], [], [tuple(f) for f in quads])
    mesh.update()
    obj = bpy.data.objects.new("Cube", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    return obj


@pytest.mark.parametrize("name", ["crease_vert", "crease_edge", "bevel_weight_vert", "bevel_weight_edge",
                                  "sharp_edge"])
def test_element_values_round_trip_where_blender_keeps_them(cube, name):
    mesh = cube.data
    n = len(mesh.vertices) if name.endswith("_vert") else len(mesh.edges)
    assert compat.element_values(mesh, name) is None or not compat.element_values(mesh, name).any()
    values = (np.arange(n) % 3 == 0) if name == "sharp_edge" else (np.arange(n) % 5) / 4.0
    compat.set_element_values(mesh, name, values)
    np.testing.assert_allclose(compat.element_values(mesh, name), values, atol=1e-6)
    # Where this Blender keeps them: its own accessor reads what compat wrote.
    i = int(np.argmax(values))
    if name == "crease_vert":
        own = (mesh.attributes["crease_vert"].data[i].value if bpy.app.version >= (4, 0, 0)
               else mesh.vertex_creases[0].data[i].value)
    elif name == "sharp_edge" and "use_edge_sharp" in bpy.types.MeshEdge.bl_rna.properties:
        own = mesh.edges[i].use_edge_sharp
    elif bpy.app.version >= (4, 0, 0):
        own = mesh.attributes[name].data[i].value
    else:
        own = getattr(mesh.vertices[i] if name.endswith("_vert") else mesh.edges[i], name.rsplit("_", 1)[0])
    assert own == pytest.approx(float(values[i]))
    # ... and it survives a bmesh round trip (what Edit mode does).
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bm.to_mesh(mesh)
    bm.free()
    np.testing.assert_allclose(compat.element_values(mesh, name), values, atol=1e-6)


def test_custom_normals_set_and_read(cube):
    mesh = cube.data
    assert not mesh.has_custom_normals
    target = np.tile([0.0, 0.6, 0.8], (len(mesh.loops), 1))
    compat.set_custom_normals(mesh, target)
    assert mesh.has_custom_normals
    # (Blender stores custom normals to about 0.01)
    assert np.abs(compat.corner_normals(mesh) - target).max() < 0.02


def test_corner_normals_of_a_flat_shaded_cube(cube):
    mesh = cube.data
    mesh.polygons.foreach_set("use_smooth", np.zeros(len(mesh.polygons), bool))
    mesh.update()
    normals = compat.corner_normals(mesh)
    face_normal = np.empty(3 * len(mesh.polygons), np.float32)
    mesh.polygons.foreach_get("normal", face_normal)
    start = np.empty(len(mesh.polygons), np.int32)
    total = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_start", start)
    mesh.polygons.foreach_get("loop_total", total)
    per_corner = np.repeat(face_normal.reshape(-1, 3), total, axis=0)
    assert normals.shape == (len(mesh.loops), 3) and np.abs(normals - per_corner).max() < 1e-5


def test_uv_selection_round_trip(cube):
    """Object mode read and write of the UV selection, and the same flags seen from Edit mode."""
    mesh = cube.data
    mesh.uv_layers.new(name="UVMap")
    n, m = len(mesh.loops), len(mesh.polygons)
    compat.set_uv_selection(mesh, [np.ones(n, bool), np.ones(n, bool)] + ([np.ones(m, bool)] if
                                                                            bpy.app.version >= (5, 0, 0) else []))
    assert all(a.all() for a in compat.uv_selection(mesh))
    pattern = [np.arange(n) % 2 == 0, np.arange(n) % 3 == 0] + ([np.arange(m) % 2 == 0] if
                                                                bpy.app.version >= (5, 0, 0) else [])
    compat.set_uv_selection(mesh, pattern)
    got = compat.uv_selection(mesh)
    assert len(got) == len(pattern) and all(np.array_equal(a, b) for a, b in zip(got, pattern))
    bpy.ops.object.mode_set(mode='EDIT')
    try:
        bm = bmesh.from_edit_mesh(mesh)
        lay = bm.loops.layers.uv.active
        loops = sorted((l for f in bm.faces for l in f.loops), key=lambda l: l.index)
        flags = compat.bm_uv_flags(loops, lay)
        assert np.array_equal(flags[0], pattern[0]) and np.array_equal(flags[1], pattern[1])
        compat.bm_set_uv_flags(loops, lay, True)
        assert all(all(f) for f in compat.bm_uv_flags(loops, lay))
        compat.bm_set_uv_flags(loops, lay, flags)
        assert [list(f) for f in compat.bm_uv_flags(loops, lay)] == [list(f) for f in flags]
    finally:
        bpy.ops.object.mode_set(mode='OBJECT')


def test_uv_select_state_survives_turning_synced_selection_off_and_on(cube):
    """Edit mode: 5.x rewrites the UV flags when synced selection is turned off (from the mesh
    selection, or flushed); the saved state puts every loop's flags back, as they were."""
    mesh = cube.data
    mesh.uv_layers.new(name="UVMap")
    n = len(mesh.loops)
    compat.set_uv_selection(mesh, [np.arange(n) % 3 == 0, np.arange(n) % 4 == 1])
    tool = bpy.context.scene.tool_settings
    tool.use_uv_select_sync = True
    bpy.ops.object.mode_set(mode='EDIT')
    try:
        bpy.ops.mesh.select_all(action='SELECT')
        bm = bmesh.from_edit_mesh(mesh)
        lay = bm.loops.layers.uv.active
        loops = [l for f in bm.faces for l in f.loops]
        before = [list(f) for f in compat.bm_uv_flags(loops, lay)]
        state = compat.bm_uv_select_state(bm, lay)
        assert (state is None) == (bpy.app.version < (5, 0, 0))
        tool.use_uv_select_sync = False
        # 5.x: every face is selected, so are all UVs now; before 5.0 the flags stay as they were
        assert ([list(f) for f in compat.bm_uv_flags(loops, lay)] == before) == (state is None)
        tool.use_uv_select_sync = True
        compat.bm_set_uv_select_state(bm, lay, state)
        assert [list(f) for f in compat.bm_uv_flags(loops, lay)] == before
        if state is not None:
            assert bm.uv_select_sync_valid == state[2]
    finally:
        bpy.ops.object.mode_set(mode='OBJECT')


def test_uv_selection_without_a_uv_map(cube):
    assert compat.uv_selection(cube.data) is None
    compat.set_uv_selection(cube.data, None)  # nothing to restore: no error


def test_uv_pins_round_trip(cube):
    """Pins set on a UV map that never had any (3.5+ makes their layer then), read back, seen by
    Blender's own per-corner accessor and from Edit mode; the UV map taken afterwards is valid."""
    mesh = cube.data
    mesh.uv_layers.new(name="UVMap")
    n = len(mesh.loops)
    assert not compat.uv_pins(mesh).any()
    pins = np.arange(n) % 3 == 0
    compat.set_uv_pins(mesh, pins)
    assert np.array_equal(compat.uv_pins(mesh), pins)
    if "pin_uv" in bpy.types.MeshUVLoop.bl_rna.properties:  # Blender's own per-corner accessor
        assert [d.pin_uv for d in mesh.uv_layers.active.data] == pins.tolist()
    bpy.ops.object.mode_set(mode='EDIT')
    try:
        bm = bmesh.from_edit_mesh(mesh)
        lay = bm.loops.layers.uv.active
        loops = sorted((l for f in bm.faces for l in f.loops), key=lambda l: l.index)
        assert [l[lay].pin_uv for l in loops] == pins.tolist()
    finally:
        bpy.ops.object.mode_set(mode='OBJECT')


def test_uv_pins_without_a_uv_map(cube):
    assert compat.uv_pins(cube.data) is None


def test_geometry_node_group_and_modifier_order(cube):
    ng = compat.new_geometry_node_group("DG Test Group")
    kinds = [n.bl_idname for n in ng.nodes]
    assert kinds == [] or set(kinds) <= {'NodeGroupInput', 'NodeGroupOutput'}
    mod_a = cube.modifiers.new("A", 'SUBSURF')
    mod_b = cube.modifiers.new("B", 'NODES')
    mod_b.node_group = ng
    compat.move_modifier(cube, mod_b, 0)
    assert [m.name for m in cube.modifiers] == ["B", "A"]
    compat.move_modifier(cube, mod_a, 0)
    assert [m.name for m in cube.modifiers] == ["A", "B"]


def test_loop_totals_after_adding_triangles():
    bpy.ops.wm.read_homefile(use_empty=True)
    mesh = bpy.data.meshes.new("Tris")
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float32)
    F = np.array([[0, 1, 2], [2, 1, 3]], np.int32)
    mesh.vertices.add(4)
    mesh.vertices.foreach_set("co", V.ravel())
    mesh.loops.add(6)
    mesh.loops.foreach_set("vertex_index", F.ravel())
    mesh.polygons.add(2)
    mesh.polygons.foreach_set("loop_start", np.array([0, 3], np.int32))
    compat.set_loop_totals(mesh, np.array([3, 3], np.int32))
    mesh.update(calc_edges=True)
    assert not mesh.validate(verbose=False)
    assert [len(p.vertices) for p in mesh.polygons] == [3, 3] and len(mesh.edges) == 5


def test_color_names(cube):
    colors = cube.data.color_attributes
    colors.new("A", 'FLOAT_COLOR', 'POINT')
    colors.new("B", 'BYTE_COLOR', 'CORNER')
    compat.set_color_names(colors, "B", "A")
    assert colors.active_color.name == "B" and colors[colors.render_color_index].name == "A"
    compat.set_color_names(colors, "A", "B")
    assert colors.active_color.name == "A" and colors[colors.render_color_index].name == "B"


def test_shader_nodes_on_a_new_material():
    mat = bpy.data.materials.new("DG Test Material")
    compat.use_shader_nodes(mat)
    assert mat.node_tree is not None and any(n.type == 'OUTPUT_MATERIAL' for n in mat.node_tree.nodes)


def test_file_path_options_register_and_take_blend_relative_paths():
    class DGTestPathOp(bpy.types.Operator):
        bl_idname = "dgmesh_test.path_options"
        bl_label = "Path options"
        filepath: bpy.props.StringProperty(subtype='FILE_PATH', options=compat.FILE_PATH_OPTIONS)

        def execute(self, context):
            return {'FINISHED'}

    bpy.utils.register_class(DGTestPathOp)
    try:
        prop = bpy.ops.dgmesh_test.path_options.get_rna_type().properties["filepath"]
        if "is_path_supports_blend_relative" in bpy.types.Property.bl_rna.properties:
            assert prop.is_path_supports_blend_relative
        assert bpy.ops.dgmesh_test.path_options(filepath="//cache.pc2") == {'FINISHED'}
    finally:
        bpy.utils.unregister_class(DGTestPathOp)
