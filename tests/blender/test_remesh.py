"""dgmesh.remesh inside Blender (thesis 5.4): Object mode on a disk, Edit mode on a selected disk
region of a closed mesh (stitched watertight), undo, and non-disk errors that change nothing."""

import bmesh
import bpy
import numpy as np
import pytest

from helpers import mesh_snapshot, open_fixture, select
from make_fixtures import bmesh_object


def remesh(**props):
    """Run the operator the way the UI does: with an undo push."""
    return bpy.ops.dgmesh.remesh('EXEC_DEFAULT', True, **props)


def fresh_scene():
    open_fixture("shapes")


def coords(mesh):
    co = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def edge_face_counts(mesh):
    """Faces per edge (plain Python over polygons, independent of the add-on)."""
    count = {e.key: 0 for e in mesh.edges}
    for p in mesh.polygons:
        for k in p.edge_keys:
            count[k] += 1
    return np.array(list(count.values()))


def euler(mesh):
    return len(mesh.vertices) - len(mesh.edges) + len(mesh.polygons)


def boundary_coords(mesh):
    counts = {e.key: 0 for e in mesh.edges}
    for p in mesh.polygons:
        for k in p.edge_keys:
            counts[k] += 1
    vs = sorted({v for k, c in counts.items() if c == 1 for v in k})
    co = coords(mesh)
    return {tuple(co[v]) for v in vs}


def select_faces(mesh, mask):
    """Exactly the faces in mask selected, with their vertices and edges (so that Edit mode's
    selection flushing keeps it)."""
    mask = np.asarray(mask, bool)
    vs = np.zeros(len(mesh.vertices), bool)
    es = np.zeros(len(mesh.edges), bool)
    key_index = {e.key: e.index for e in mesh.edges}
    for p in mesh.polygons:
        if mask[p.index]:
            vs[list(p.vertices)] = True
            es[[key_index[k] for k in p.edge_keys]] = True
    mesh.vertices.foreach_set("select", vs)
    mesh.edges.foreach_set("select", es)
    mesh.polygons.foreach_set("select", mask)
    mesh.update()


def bridge_array(polygons, key, dtype, attribute=False):
    """One property of every polygon, or (``attribute``) the face attribute named ``key``."""
    data = polygons.id_data.attributes[key].data if attribute else polygons
    a = np.empty(len(data), dtype)
    data.foreach_get("value" if attribute else key, a)
    return a


def grid_object():
    return bmesh_object("Grid", lambda bm: bmesh.ops.create_grid(bm, x_segments=24, y_segments=24, size=1.0))


def sphere_object():
    return bmesh_object("Sphere", lambda bm: bmesh.ops.create_icosphere(bm, subdivisions=4, radius=1.0))


def test_object_mode_disk_is_replaced_with_boundary_kept_and_undo():
    fresh_scene()
    obj = grid_object()
    select("Grid")
    mesh = obj.data
    before = mesh_snapshot(mesh)
    bnd_before = boundary_coords(mesh)
    bpy.ops.ed.undo_push(message="before")
    assert remesh(target_vertices=400, resolution=256) == {'FINISHED'}
    mesh = bpy.data.objects["Grid"].data
    n = len(mesh.vertices)
    assert abs(n - 400) <= 0.05 * 400, n
    assert all(p.loop_total == 3 for p in mesh.polygons)
    assert boundary_coords(mesh) == bnd_before  # the 96 boundary vertices, bit for bit
    counts = edge_face_counts(mesh)
    assert counts.min() >= 1 and counts.max() == 2
    assert euler(mesh) == 1
    assert np.abs(coords(mesh)[:, 2]).max() == 0.0  # still the plane
    assert bpy.ops.ed.undo() == {'FINISHED'}
    assert mesh_snapshot(bpy.data.objects["Grid"].data) == before


def test_object_mode_resampled_boundary_hits_the_count():
    fresh_scene()
    grid_object()
    select("Grid")
    assert remesh(target_vertices=300, resample_boundary=True, mode='SINGLE_U0') == {'FINISHED'}
    mesh = bpy.data.objects["Grid"].data
    assert abs(len(mesh.vertices) - 300) <= 15
    assert euler(mesh) == 1 and edge_face_counts(mesh).max() == 2


def test_relaxation_steps_even_out_the_spacing():
    """The redo panel's Relaxation Steps: 0 is the thesis's plain error diffusion; the default
    Lloyd steps give more even edges on the same planar grid."""
    cvs = {}
    for relax in (0, 4):
        fresh_scene()
        grid_object()
        select("Grid")
        assert remesh(target_vertices=400, resolution=256, resample_boundary=True, relax=relax,
                      flips=False, smooth=0) == {'FINISHED'}
        mesh = bpy.data.objects["Grid"].data
        assert euler(mesh) == 1 and edge_face_counts(mesh).max() == 2
        co = coords(mesh).astype(float)
        L = np.array([np.linalg.norm(co[e.vertices[0]] - co[e.vertices[1]]) for e in mesh.edges])
        cvs[relax] = L.std() / L.mean()
    assert cvs[4] < cvs[0] - 0.02, cvs


def test_smoothing_sweeps_even_out_the_spacing():
    """The redo panel's Smoothing Sweeps (default 3, 0 = off): same vertex count, more even edges."""
    cvs, counts = {}, {}
    for smooth in (0, 3):
        fresh_scene()
        grid_object()
        select("Grid")
        assert remesh(target_vertices=400, resolution=256, resample_boundary=True, smooth=smooth) == {'FINISHED'}
        mesh = bpy.data.objects["Grid"].data
        assert euler(mesh) == 1 and edge_face_counts(mesh).max() == 2
        co = coords(mesh).astype(float)
        L = np.array([np.linalg.norm(co[e.vertices[0]] - co[e.vertices[1]]) for e in mesh.edges])
        cvs[smooth], counts[smooth] = L.std() / L.mean(), len(mesh.vertices)
    assert counts[0] == counts[3]
    assert cvs[3] < cvs[0] - 0.01, cvs


def test_edit_mode_region_is_stitched_watertight_and_undo():
    fresh_scene()
    obj = sphere_object()
    select("Sphere")
    mesh = obj.data
    co = coords(mesh)
    centres = np.array([p.center[:] for p in mesh.polygons])
    sel = centres[:, 2] > 0.3
    select_faces(mesh, sel)
    outside_verts = sorted({v for p in mesh.polygons if not p.select for v in p.vertices})
    kept_before = {tuple(co[v]) for v in outside_verts}
    n_sel_before = int(sel.sum())
    bpy.context.tool_settings.mesh_select_mode = (False, False, True)  # faces: no flushing from vertices
    bpy.ops.object.mode_set(mode='EDIT')
    obj.update_from_editmode()
    assert [p.select for p in obj.data.polygons] == sel.tolist()
    bpy.ops.ed.undo_push(message="before")
    assert remesh(target_vertices=300, adaptivity=0.3, mode='DOUBLE') == {'FINISHED'}
    assert bpy.context.mode == 'EDIT_MESH'
    obj.update_from_editmode()
    mesh = obj.data
    # Watertight: a closed 2-manifold of genus 0 again.
    counts = edge_face_counts(mesh)
    assert counts.min() == 2 and counts.max() == 2
    assert euler(mesh) == 2
    # Everything outside the region is unchanged; the new faces are the selection.
    co = coords(mesh)
    assert kept_before <= {tuple(c) for c in co}
    new_sel = np.empty(len(mesh.polygons), bool)
    mesh.polygons.foreach_get("select", new_sel)
    assert new_sel.sum() != n_sel_before and new_sel.any()
    new_verts = sorted({v for p in mesh.polygons if p.select for v in p.vertices})
    assert abs(len(new_verts) - 300) <= 15
    # New vertices lie on the sphere (up to the input's chordal error).
    r = np.linalg.norm(co[new_verts], axis=1)
    assert np.abs(r - 1).max() < 0.01
    assert bpy.ops.ed.undo() == {'FINISHED'}
    obj = bpy.data.objects["Sphere"]
    obj.update_from_editmode()
    assert len(obj.data.polygons) == len(sel)
    assert int(np.count_nonzero([p.select for p in obj.data.polygons])) == n_sel_before


def test_closed_mesh_in_object_mode_is_an_error_and_changes_nothing():
    fresh_scene()
    obj = sphere_object()
    select("Sphere")
    before = mesh_snapshot(obj.data)
    with pytest.raises(RuntimeError) as info:
        remesh(target_vertices=200)
    msg = str(info.value)
    assert "'Sphere'" in msg and "closed" in msg
    assert mesh_snapshot(obj.data) == before


def test_annulus_selection_is_an_error_and_changes_nothing():
    fresh_scene()
    obj = sphere_object()
    select("Sphere")
    mesh = obj.data
    centres = np.array([p.center[:] for p in mesh.polygons])
    select_faces(mesh, np.abs(centres[:, 2]) < 0.3)  # a belt: two boundary loops
    bpy.ops.object.mode_set(mode='EDIT')
    obj.update_from_editmode()
    before = mesh_snapshot(obj.data)
    with pytest.raises(RuntimeError) as info:
        remesh(target_vertices=200)
    assert "boundary loops" in str(info.value)
    obj.update_from_editmode()
    assert mesh_snapshot(obj.data) == before


def test_wire_edge_on_an_inner_vertex_is_an_error_and_changes_nothing():
    """A loose edge hanging from the middle of the disk would be deleted with its vertex."""
    fresh_scene()
    bpy.ops.object.select_all(action='DESELECT')
    bpy.ops.mesh.primitive_circle_add(vertices=32, fill_type='TRIFAN')
    obj = bpy.context.object
    mesh = obj.data
    n = len(mesh.vertices)
    centre = int(np.argmin(np.linalg.norm(coords(mesh), axis=1)))
    mesh.vertices.add(1)
    mesh.vertices[n].co = (0, 0, 1)
    mesh.edges.add(1)
    mesh.edges[-1].vertices = (centre, n)
    mesh.update()
    before = mesh_snapshot(mesh)
    with pytest.raises(RuntimeError) as info:
        remesh(target_vertices=100)
    assert "loose edges" in str(info.value)
    assert mesh_snapshot(mesh) == before
    # A wire edge on the boundary is kept, as the boundary is.
    mesh.edges[-1].vertices = (0 if centre else 1, n)
    mesh.update()
    assert remesh(target_vertices=100) == {'FINISHED'}
    top = int(np.nonzero(coords(mesh)[:, 2] == 1)[0][0])
    assert sum(top in e.vertices for e in mesh.edges) == 1


def test_edit_mode_quad_region_inside_a_grid_stays_stitched():
    fresh_scene()
    obj = grid_object()
    select("Grid")
    mesh = obj.data
    centres = np.array([p.center[:] for p in mesh.polygons])
    sel = (np.abs(centres[:, 0]) < 0.5) & (np.abs(centres[:, 1]) < 0.5)  # an interior block of quads
    select_faces(mesh, sel)
    outer_before = boundary_coords(mesh)
    n_unselected = int((~sel).sum())
    bpy.context.tool_settings.mesh_select_mode = (False, False, True)
    bpy.ops.object.mode_set(mode='EDIT')
    assert remesh(target_vertices=150, mode='SINGLE_UOPT', flips=False) == {'FINISHED'}
    obj.update_from_editmode()
    mesh = obj.data
    counts = edge_face_counts(mesh)
    assert counts.min() >= 1 and counts.max() == 2
    assert euler(mesh) == 1  # still one disk: the new triangles share the block's boundary
    assert boundary_coords(mesh) == outer_before
    quads = sum(1 for p in mesh.polygons if p.loop_total == 4)
    assert quads == n_unselected


def test_new_vertices_carry_uvs_and_vertex_weights():
    """The new triangulation's corners take the UV map and the new vertices the vertex-group weights
    of the input point each lies on (source_face / source_bary): on Add > Grid, whose UVs and the
    weights here are affine in x and y, they are exact (they were (0, 0) and no group)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=12, y_subdivisions=12, size=2)
    obj = bpy.context.object
    me = obj.data
    group = obj.vertex_groups.new(name="W")
    for v in me.vertices:
        group.add([v.index], 0.5 + 0.2 * v.co.x - 0.1 * v.co.y, 'REPLACE')
    col = me.color_attributes.new("Col", 'BYTE_COLOR', 'CORNER')  # stored as sRGB bytes
    col.data.foreach_set("color_srgb", np.tile([0.5, 0.2, 0.05, 1.0], len(me.loops)).astype(np.float32))
    # Types Blender 3.4's bmesh does not reach (new vertices and corners had (0, 0) and False).
    co = coords(me)
    me.attributes.new("xy", 'FLOAT2', 'POINT').data.foreach_set("vector", co[:, :2].ravel())
    me.attributes.new("left", 'BOOLEAN', 'POINT').data.foreach_set("value", co[:, 0] < 0)
    lv = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", lv)
    me.attributes.new("cxy", 'FLOAT2', 'CORNER').data.foreach_set("vector", co[lv, :2].ravel())
    me.attributes.new("on", 'BOOLEAN', 'CORNER').data.foreach_set("value", np.ones(len(me.loops), bool))
    bpy.ops.object.mode_set(mode='EDIT')
    bm = bmesh.from_edit_mesh(me)
    for f in bm.faces:
        f.select = f.calc_center_median().length < 0.6
    bm.select_flush(True)
    bmesh.update_edit_mesh(me)
    n_before = len(me.vertices)
    assert remesh(target_vertices=400) == {'FINISHED'}
    bpy.ops.object.mode_set(mode='OBJECT')
    me = obj.data
    co = coords(me)
    assert len(co) > n_before + 100
    uv = np.empty(2 * len(me.loops), np.float32)
    me.uv_layers.active.data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    lv = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", lv)
    # Add > Grid of size 2 maps x, y in [-1, 1] to u, v in [0, 1].
    assert np.abs(uv - (co[lv, :2] + 1) / 2).max() < 1e-5
    for v in me.vertices:
        w = [g.weight for g in v.groups]
        assert len(w) == 1 and abs(w[0] - (0.5 + 0.2 * v.co.x - 0.1 * v.co.y)) < 1e-5
    c = np.empty(4 * len(me.loops), np.float32)
    me.color_attributes["Col"].data.foreach_get("color_srgb", c)
    assert np.abs(c.reshape(-1, 4) - [0.5, 0.2, 0.05, 1.0]).max() < 2 / 255  # not darkened
    a = np.empty(2 * len(me.vertices), np.float32)
    me.attributes["xy"].data.foreach_get("vector", a)
    assert np.abs(a.reshape(-1, 2) - co[:, :2]).max() < 1e-5  # affine: exact
    b = np.empty(len(me.vertices), bool)
    me.attributes["left"].data.foreach_get("value", b)
    off_axis = np.abs(co[:, 0]) > 0.2  # a grid spacing off: the heaviest source is on the same side
    assert np.array_equal(b[off_axis], co[off_axis, 0] < 0)
    a = np.empty(2 * len(me.loops), np.float32)
    me.attributes["cxy"].data.foreach_get("vector", a)
    assert np.abs(a.reshape(-1, 2) - co[lv, :2]).max() < 1e-5
    b = np.empty(len(me.loops), bool)
    me.attributes["on"].data.foreach_get("value", b)
    assert b.all()


def test_triangles_across_a_uv_seam_take_one_side_of_it():
    """A UV seam inside the remeshed disk (Add > Grid whose halves x < 0 and x > 0 are two UV
    islands): every new triangle takes its three corners from one island's map, extended past the
    seam where a corner lies beyond it. (Each corner had been blended on its own side, so triangles
    across the seam were stretched over the gap between the islands.)"""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=12, y_subdivisions=12, size=2)
    obj = bpy.context.object
    me = obj.data
    lv = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", lv)
    co = coords(me)
    right = np.zeros(len(me.loops), bool)
    for p in me.polygons:
        right[list(p.loop_indices)] = np.mean(co[list(p.vertices), 0]) > 0
    x, y = co[lv, 0], co[lv, 1]
    uv = np.stack([(x + 1) / 4 + 0.5 * right, (y + 1) / 2], 1).astype(np.float32)
    me.uv_layers.active.data.foreach_set("uv", uv.ravel())
    select(obj.name)
    assert remesh(target_vertices=600) == {'FINISHED'}
    me = obj.data
    co = coords(me)
    lv = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", lv)
    uv = np.empty(2 * len(me.loops), np.float32)
    me.uv_layers.active.data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    x = co[lv, 0]
    island = np.round((uv[:, 0] - (x + 1) / 4) / 0.5)  # 0 left map, 1 right map
    assert np.abs(uv[:, 0] - ((x + 1) / 4 + 0.5 * island)).max() < 1e-4  # one of the two affine maps
    assert set(np.unique(island)) == {0.0, 1.0}
    tri = island.reshape(-1, 3)  # all triangles
    assert (tri == tri[:, :1]).all()
    assert np.abs(uv[:, 1] - (co[lv, 1] + 1) / 2).max() < 1e-4


def test_triangles_across_a_seam_that_ends_inside_the_region_are_not_stretched():
    """A seam cut from the rim to the centre (opening up to 0.8 in u at the rim): its two sides are
    one island, joined around the seam's end. A new triangle's corner across the seam takes the
    other corners' map instead of its own side's (it had been stretched across the opening: 22
    triangles over 1.5x the input's largest UV/3D edge ratio; now at most a couple at the seam's
    end, where the opening is narrower than a triangle)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=20, y_subdivisions=20, size=2)
    obj = bpy.context.object
    me = obj.data
    co = coords(me)
    lv = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", lv)
    side = np.zeros(len(me.loops))
    for p in me.polygons:
        side[list(p.loop_indices)] = np.sign(np.mean(co[list(p.vertices), 0]))
    x, y = co[lv, 0], co[lv, 1]
    uv = np.stack([0.25 * (x + 0.4 * side * np.maximum(y, 0) + 1.4), 0.5 * (y + 1)], 1).astype(np.float32)
    me.uv_layers.active.data.foreach_set("uv", uv.ravel())

    def worst_ratio(me):
        co = coords(me)
        lv = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("vertex_index", lv)
        uv = np.empty(2 * len(me.loops), np.float32)
        me.uv_layers.active.data.foreach_get("uv", uv)
        U, X = uv.reshape(-1, 3, 2), co[lv].reshape(-1, 3, 3)
        ratio = [np.linalg.norm(U[:, a] - U[:, b], axis=1) / np.linalg.norm(X[:, a] - X[:, b], axis=1)
                 for a, b in ((0, 1), (1, 2), (2, 0))]
        return np.max(ratio, axis=0)

    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.quads_convert_to_tris()
    bpy.ops.object.mode_set(mode='OBJECT')
    limit = 1.5 * worst_ratio(obj.data).max()
    select(obj.name)
    assert remesh(target_vertices=600) == {'FINISHED'}
    assert (worst_ratio(obj.data) > limit).sum() <= 2


def test_materials_smooth_shading_and_face_attributes_follow_the_source_faces():
    """New triangles take material, shading and the face attributes (they had none: 0 and False)
    of the input polygon under most of their corners."""
    fresh_scene()
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=10, y_subdivisions=10, size=2)
    obj = bpy.context.object
    me = obj.data
    me.materials.append(bpy.data.materials.new("Left"))
    me.materials.append(bpy.data.materials.new("Right"))
    for p in me.polygons:
        p.material_index = int(p.center.x > 0)
        p.use_smooth = p.center.x > 0
    right = bridge_array(me.polygons, "material_index", np.int32) == 1
    me.attributes.new("right", 'BOOLEAN', 'FACE').data.foreach_set("value", right)
    me.attributes.new("side", 'FLOAT', 'FACE').data.foreach_set("value", np.where(right, 2.5, -1.0).astype(np.float32))
    assert remesh(target_vertices=200) == {'FINISHED'}
    me = obj.data
    flag = bridge_array(me.polygons, "right", bool, attribute=True)
    side = bridge_array(me.polygons, "side", np.float32, attribute=True)
    assert np.array_equal(flag, bridge_array(me.polygons, "material_index", np.int32) == 1)
    assert np.array_equal(side, np.where(flag, 2.5, -1.0))
    area = [0.0, 0.0]
    for p in obj.data.polygons:
        area[p.material_index] += p.area
        assert p.use_smooth == (p.material_index == 1)
        assert (p.center.x > 0) == (p.material_index == 1) or abs(p.center.x) < 0.25
    assert abs(area[0] - 2.0) < 0.2 and abs(area[1] - 2.0) < 0.2
