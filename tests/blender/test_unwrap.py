"""dgmesh.unwrap and dgmesh.stretch_map inside Blender (thesis chapter 5)."""

import bmesh
import bpy
import numpy as np
import pytest

from helpers import attribute_array, layer_uv, mesh_snapshot, open_fixture, select
import make_fixtures
from make_fixtures import add_mesh_object

from dgmesh.blender import bridge, compat


def unwrap(**props):
    """Run the operator the way the UI does: with an undo push."""
    return bpy.ops.dgmesh.unwrap('EXEC_DEFAULT', True, **props)


def stretch_map(**props):
    return bpy.ops.dgmesh.stretch_map('EXEC_DEFAULT', True, **props)


def set_seams(mesh, edge_mask):
    mesh.edges.foreach_set("use_seam", np.asarray(edge_mask, bool))
    mesh.update()


def edges_of(mesh):
    E = np.empty(2 * len(mesh.edges), np.int32)
    mesh.edges.foreach_get("vertices", E)
    return E.reshape(-1, 2)


def coords(mesh):
    co = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3).astype(np.float64)


def chart_faces(mesh):
    """Polygon index sets of the charts the operator should find: faces joined across non-seam,
    two-face edges (a plain Python flood fill, independent of the add-on)."""
    faces_of_edge = {}
    for p in mesh.polygons:
        for k in p.edge_keys:
            faces_of_edge.setdefault(k, []).append(p.index)
    key_seam = {e.key: e.use_seam for e in mesh.edges}
    adj = {p.index: [] for p in mesh.polygons}
    for k, fs in faces_of_edge.items():
        if len(fs) == 2 and not key_seam[k]:
            adj[fs[0]].append(fs[1])
            adj[fs[1]].append(fs[0])
    seen, charts = set(), []
    for p in adj:
        if p in seen:
            continue
        stack, comp = [p], set()
        while stack:
            q = stack.pop()
            if q in comp:
                continue
            comp.add(q)
            stack.extend(adj[q])
        seen |= comp
        charts.append(comp)
    return charts


def check_charts(dg, obj, charts):
    """Every chart's triangles: no flip, no zero-area triangle, finite stretch; corners of one
    vertex inside a chart share a UV unless a seam separates them."""
    mesh = obj.data
    arrays = bridge.read_mesh(mesh)
    uv = layer_uv(mesh).astype(np.float64)
    stretch = []
    for comp in charts:
        tri = np.isin(arrays.tri_poly, list(comp))
        m = dg.uv_metrics(arrays.V, arrays.F[tri], uv[arrays.tri_loops[tri]])
        assert m.flipped == 0 and m.zero_area == 0, m
        assert np.isfinite(m.stretch_l2)
        stretch.append(m.stretch_l2)
    return stretch


def ngon_cylinder_with_seams():
    """NgonCylinder (16 quads around, two 16-gon caps) with seams on both cap rims and one
    vertical edge: three charts (two n-gon disks and the side slit open)."""
    open_fixture("shapes")
    obj = bpy.data.objects["NgonCylinder"]
    mesh = obj.data
    V = coords(mesh)
    E = edges_of(mesh)
    cap_edges = set()
    for p in mesh.polygons:
        if p.loop_total > 4:
            cap_edges |= {mesh.loops[p.loop_start + k].edge_index for k in range(p.loop_total)}
    vertical = np.nonzero(np.abs(V[E[:, 0], 2] - V[E[:, 1], 2]) > 1.0)[0]
    seam = np.zeros(len(E), bool)
    seam[list(cap_edges)] = True
    seam[vertical[0]] = True
    set_seams(mesh, seam)
    return obj


def test_seams_split_closed_ngon_cylinder_into_three_charts(dg, capsys):
    obj = ngon_cylinder_with_seams()
    mesh = obj.data
    n_poly, n_loop = len(mesh.polygons), len(mesh.loops)
    select("NgonCylinder")
    assert "UVMap" not in mesh.uv_layers
    assert unwrap(pack=True) == {'FINISHED'}
    out = capsys.readouterr().out
    assert "Unwrapped 3 chart(s) on 1 object(s)" in out and "(no UV map before)" in out
    assert "0 flipped, 0 zero-area" in out and "packed" in out and "not packed" not in out
    assert bpy.context.mode == 'OBJECT'
    # The user's polygons are kept: UVs per corner of the 16-gons and quads.
    assert (len(mesh.polygons), len(mesh.loops)) == (n_poly, n_loop)
    assert max(p.loop_total for p in mesh.polygons) == 16
    assert mesh.uv_layers.active is not None
    charts = chart_faces(mesh)
    assert len(charts) == 3
    stretch = check_charts(dg, obj, charts)
    # A planar n-gon cap maps to itself up to similarity; the slit side is a developable strip.
    assert min(stretch) < 1.01 and max(stretch) < 1.2, stretch
    uv = layer_uv(mesh)
    # Packed: inside the unit square, and the charts' bounding boxes do not overlap.
    assert uv.min() >= -1e-4 and uv.max() <= 1 + 1e-4
    boxes = []
    for comp in charts:
        loops = [l for p in comp for l in range(mesh.polygons[p].loop_start,
                                                mesh.polygons[p].loop_start + mesh.polygons[p].loop_total)]
        boxes.append((uv[loops].min(0), uv[loops].max(0)))
    for i in range(3):
        for j in range(i + 1, 3):
            (lo1, hi1), (lo2, hi2) = boxes[i], boxes[j]
            overlap = np.minimum(hi1, hi2) - np.maximum(lo1, lo2)
            assert (overlap <= 1e-3).any(), (boxes[i], boxes[j])
    # Corners of the same vertex away from seams share one UV; across the vertical seam they differ.
    lv = np.array([l.vertex_index for l in mesh.loops])
    side = [p.index for p in mesh.polygons if p.loop_total == 4]
    side_loops = np.array([l for p in side for l in range(mesh.polygons[p].loop_start, mesh.polygons[p].loop_start + 4)])
    seam_verts = set(edges_of(mesh)[[e.index for e in mesh.edges if e.use_seam and
                                     abs(mesh.vertices[e.vertices[0]].co.z - mesh.vertices[e.vertices[1]].co.z) > 1]].ravel())
    for v in np.unique(lv[side_loops]):
        pts = np.unique(np.round(uv[side_loops[lv[side_loops] == v]], 5), axis=0)
        assert len(pts) == (2 if v in seam_verts else 1), (v, pts)


def test_quad_grid_unwraps_to_itself_and_ngons_keep_corners(dg):
    # A planar quad grid with one hexagon: a disk chart; the map is a similarity (stretch 1).
    n = 8
    x, y = np.meshgrid(np.linspace(0, 1.4, n + 1), np.linspace(0, 1, n + 1), indexing="ij")
    V = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    idx = lambda i, j: i * (n + 1) + j  # noqa: E731
    faces = [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)] for i in range(n) for j in range(n)
             if not (i == 3 and j in (3, 4))]
    faces.append([idx(3, 3), idx(4, 3), idx(4, 4), idx(4, 5), idx(3, 5), idx(3, 4)])
    obj = add_mesh_object("Grid", V, faces)
    select("Grid")
    assert unwrap(boundary='FREE', pack=False) == {'FINISHED'}
    mesh = obj.data
    assert max(p.loop_total for p in mesh.polygons) == 6
    uv = layer_uv(mesh).astype(np.float64)
    lv = np.array([l.vertex_index for l in mesh.loops])
    # One UV per vertex (no seams), and UV = similarity of (x, y).
    per_vertex = np.zeros((len(V), 2))
    per_vertex[lv] = uv
    assert np.abs(per_vertex[lv] - uv).max() < 1e-6
    A = np.c_[V[:, :2], np.ones(len(V))]
    coef, *_ = np.linalg.lstsq(A, per_vertex, rcond=None)
    assert np.abs(A @ coef - per_vertex).max() < 1e-4
    s = np.linalg.svd(coef[:2])[1]
    assert s[0] / s[1] == pytest.approx(1.0, abs=1e-4)


def test_partial_selection_leaves_other_uvs_untouched(dg):
    open_fixture("shapes")
    obj = bpy.data.objects["QuadSphere"]
    mesh = obj.data
    layer = mesh.uv_layers.new(name="Existing")
    rng = np.random.default_rng(0)
    layer.data.foreach_set("uv", rng.random(2 * len(mesh.loops)).astype(np.float32))
    other = mesh.uv_layers.new(name="Other")
    other.data.foreach_set("uv", rng.random(2 * len(mesh.loops)).astype(np.float32))
    mesh.uv_layers.active = layer
    # Select the northern cap (quads and the pole's triangles): one disk chart.
    centers = np.array([p.center.z for p in mesh.polygons])
    sel = centers > 0.45
    mesh.polygons.foreach_set("select", sel)
    before = layer_uv(mesh).copy()
    before_other = layer_uv(mesh, "Other").copy()
    select("QuadSphere")
    bpy.ops.object.mode_set(mode='EDIT')
    assert unwrap() == {'FINISHED'}
    assert bpy.context.mode == 'EDIT_MESH'
    bpy.ops.object.mode_set(mode='OBJECT')
    after = layer_uv(mesh)
    poly_of_loop = np.repeat(np.arange(len(mesh.polygons)), [p.loop_total for p in mesh.polygons])
    untouched = ~sel[poly_of_loop]
    assert untouched.any() and (~untouched).any()
    assert after[untouched].tobytes() == before[untouched].tobytes()
    assert np.abs(after[~untouched] - before[~untouched]).max() > 1e-3
    assert layer_uv(mesh, "Other").tobytes() == before_other.tobytes()
    check_charts(dg, obj, [set(np.nonzero(sel)[0])])


def test_undo_restores_the_uv_map():
    obj = ngon_cylinder_with_seams()
    select("NgonCylinder")
    obj.data.uv_layers.new(name="UVMap")
    before = mesh_snapshot(obj.data)
    bpy.ops.ed.undo_push(message="before")
    assert unwrap() == {'FINISHED'}
    assert mesh_snapshot(bpy.data.objects["NgonCylinder"].data)["uv_layers"] != before["uv_layers"]
    assert bpy.ops.ed.undo() == {'FINISHED'}
    assert mesh_snapshot(bpy.data.objects["NgonCylinder"].data) == before


def test_closed_chart_is_an_error_and_changes_nothing():
    open_fixture("shapes")
    mesh = bpy.data.objects["Torus"].data
    mesh.uv_layers.new(name="UVMap")
    before = mesh_snapshot(mesh)
    select("Torus")
    with pytest.raises(RuntimeError) as info:
        unwrap()
    msg = str(info.value)
    assert "'Torus' chart 1 of 1 (1024 triangles" in msg and "closed" in msg
    assert "seams" in msg and "DG Mesh > Segment" in msg
    assert mesh_snapshot(mesh) == before


def test_chart_with_a_handle_is_named_and_nothing_is_written():
    # Seams around one quad of the torus: that quad is a disk chart, the rest is a torus with a
    # hole (genus 1): the error names that chart and neither chart is written.
    open_fixture("shapes")
    mesh = bpy.data.objects["Torus"].data
    quad = mesh.polygons[37]
    seam = np.zeros(len(mesh.edges), bool)
    seam[[mesh.loops[quad.loop_start + k].edge_index for k in range(4)]] = True
    set_seams(mesh, seam)
    before = mesh_snapshot(mesh)
    select("Torus")
    with pytest.raises(RuntimeError) as info:
        unwrap()
    msg = str(info.value)
    assert "'Torus' chart" in msg and "of 2 (1022 triangles" in msg and "handle" in msg
    assert mesh_snapshot(mesh) == before
    assert mesh.uv_layers.active is None


def test_torus_cut_along_meridian_and_longitude_is_one_disk(dg, capsys):
    open_fixture("shapes")
    obj = bpy.data.objects["Torus"]
    mesh = obj.data
    nv = 16  # the torus is 32 x 16
    E = edges_of(mesh)
    i, j = E // nv, E % nv
    meridian = (i[:, 0] == 0) & (i[:, 1] == 0)          # the ring of vertices i == 0
    longitude = (j[:, 0] == 0) & (j[:, 1] == 0)         # the ring j == 0
    set_seams(mesh, meridian | longitude)
    select("Torus")
    assert unwrap(pack=False) == {'FINISHED'}
    assert "Unwrapped 1 chart(s)" in capsys.readouterr().out
    check_charts(dg, obj, [set(range(len(mesh.polygons)))])
    # Only the meridian cut: a tube (two boundary loops): unwrapped with the inner loop kept open.
    set_seams(mesh, meridian)
    assert unwrap(pack=False) == {'FINISHED'}
    check_charts(dg, obj, [set(range(len(mesh.polygons)))])


def test_object_mode_several_objects_and_stretch_map_with_checker(dg, capsys):
    obj = ngon_cylinder_with_seams()
    grid_V = np.array([[x, y, 0.1 * np.sin(3 * x)] for x in np.linspace(0, 1, 6) for y in np.linspace(0, 1, 6)])
    quads = [[i * 6 + j, (i + 1) * 6 + j, (i + 1) * 6 + j + 1, i * 6 + j + 1] for i in range(5) for j in range(5)]
    grid = add_mesh_object("Wavy", grid_V, quads)
    select("NgonCylinder", "Wavy")
    assert unwrap() == {'FINISHED'}
    out = capsys.readouterr().out
    assert "Unwrapped 4 chart(s) on 2 object(s)" in out
    check_charts(dg, grid, chart_faces(grid.data))
    check_charts(dg, obj, chart_faces(obj.data))

    before = {o.name: mesh_snapshot(o.data) for o in (obj, grid)}
    assert stretch_map(checker=True) == {'FINISHED'}
    assert "Stretch map: vertex stretch" in capsys.readouterr().out
    for o in (obj, grid):
        mesh = o.data
        attr = mesh.attributes["dg_uv_stretch"]
        assert (attr.domain, attr.data_type) == ('POINT', 'FLOAT')
        got = attribute_array(attr).ravel()
        arrays = bridge.read_mesh(mesh)
        ref = dg.uv_stretch(arrays.V, arrays.F, layer_uv(mesh).astype(np.float64)[arrays.tri_loops])
        np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-6)
        assert "dg_uv_stretch_color" in mesh.color_attributes
        assert "DG Checker" in [m.name for m in mesh.materials if m]
        # Nothing else changed: positions, topology, UVs.
        snap = mesh_snapshot(mesh)
        for key in ("co", "loop_vertex", "uv_layers"):
            assert snap[key] == before[o.name][key]
    mat = bpy.data.materials["DG Checker"]
    assert any(n.bl_idname == "ShaderNodeTexChecker" for n in mat.node_tree.nodes)

    # A mesh with materials shows the checker on every face through object-linked slots; the
    # mesh's own materials and indices stay (the checker was an unused extra slot).
    own = [bpy.data.materials.new("A"), bpy.data.materials.new("B")]
    mesh = obj.data
    mesh.materials.clear()
    for m in own:
        mesh.materials.append(m)
    index = np.arange(len(mesh.polygons), dtype=np.int32) % 2
    mesh.polygons.foreach_set("material_index", index)
    select("NgonCylinder")
    assert stretch_map(checker=True) == {'FINISHED'}
    assert [s.material for s in obj.material_slots] == [mat, mat]
    assert list(mesh.materials) == own and [p.material_index for p in mesh.polygons] == index.tolist()


def test_stretch_map_checker_on_every_selected_linked_duplicate():
    """Linked duplicates share one mesh (one target) but not their object-linked slots: the checker
    showed on the first selected one only."""
    open_fixture("shapes")
    bpy.ops.mesh.primitive_uv_sphere_add()
    a = bpy.context.object
    own = bpy.data.materials.new("Own")
    a.data.materials.append(own)
    b, c = a.copy(), a.copy()  # linked duplicates: the same mesh
    for o in (b, c):
        bpy.context.scene.collection.objects.link(o)
    bpy.context.view_layer.update()
    select(a.name, b.name, active=b.name)
    assert stretch_map(checker=True) == {'FINISHED'}
    mat = bpy.data.materials["DG Checker"]
    assert [s.material for s in a.material_slots] == [mat]
    assert [s.material for s in b.material_slots] == [mat]
    assert [s.material for s in c.material_slots] == [own]  # not selected
    assert list(a.data.materials) == [own]


def test_stretch_map_without_uvs_is_an_error():
    open_fixture("shapes")
    select("QuadSphere")
    before = mesh_snapshot(bpy.data.objects["QuadSphere"].data)
    with pytest.raises(RuntimeError, match="no UV map"):
        stretch_map()
    assert mesh_snapshot(bpy.data.objects["QuadSphere"].data) == before


@pytest.mark.parametrize("uv_value", [0.0, float("nan")], ids=["collapsed", "nan"])
def test_stretch_map_of_a_broken_uv_map_is_an_error_and_writes_nothing(uv_value):
    open_fixture("shapes")
    bpy.ops.mesh.primitive_uv_sphere_add()
    mesh = bpy.context.object.data
    uv = mesh.uv_layers.active.data
    uv.foreach_set("uv", np.full(2 * len(uv), uv_value, np.float32))
    before = mesh_snapshot(mesh)
    with pytest.raises(RuntimeError, match=f"UV stretch map failed on '{bpy.context.object.name}'") as exc:
        stretch_map()
    assert "Traceback" not in str(exc.value)
    assert mesh_snapshot(mesh) == before


def test_stretch_map_in_edit_mode(dg):
    open_fixture("shapes")
    bpy.ops.mesh.primitive_uv_sphere_add()
    obj = bpy.context.object
    bpy.ops.object.mode_set(mode='EDIT')
    assert stretch_map() == {'FINISHED'}
    assert obj.mode == 'EDIT'
    bpy.ops.object.mode_set(mode='OBJECT')
    mesh = obj.data
    arrays = bridge.read_mesh(mesh)
    ref = dg.uv_stretch(arrays.V, arrays.F, layer_uv(mesh).astype(np.float64)[arrays.tri_loops])
    got = attribute_array(mesh.attributes["dg_uv_stretch"]).ravel()
    np.testing.assert_allclose(got, np.nan_to_num(ref, nan=0.0), rtol=1e-5, atol=1e-6)


def _relative_uv_areas(UV, F):
    a, b, c = UV[F[:, 0]], UV[F[:, 1]], UV[F[:, 2]]
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))
    return area / area.sum()


def test_packed_scan_keeps_its_slivers(dg, capsys):
    """CGAL's mannequin-devil has 3D slivers (relative area 9e-11): written at the 3D scale and
    moved by Blender's float32 packer they collapsed to zero-area UV triangles. Every packed UV
    triangle must keep the relative area of the native map (up to float32 rounding)."""
    obj = make_fixtures.load_cgal_object("mannequin-devil")
    select(obj.name)
    assert unwrap() == {'FINISHED'}
    assert ", 0 flipped, 0 zero-area, packed" in capsys.readouterr().out
    arrays = bridge.read_mesh(obj.data)
    uv = layer_uv(obj.data).astype(np.float64)[arrays.tri_loops]
    m = dg.uv_metrics(arrays.V, arrays.F, uv)
    assert m.flipped == 0 and m.zero_area == 0, m
    # The defaults on the operator's own chart, in float64: one chart without seams, its vertices
    # numbered in order of their first corner (the chart's corner classes), its triangles in order.
    lv = np.empty(len(obj.data.loops), np.int32)
    obj.data.loops.foreach_get("vertex_index", lv)
    _, first = np.unique(lv, return_index=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    Vc, Fc = arrays.V[order], rank[arrays.F].astype(np.int32)
    ref = dg.unwrap(Vc, Fc)
    got = _relative_uv_areas(uv.reshape(-1, 2), np.arange(3 * len(arrays.F)).reshape(-1, 3))
    want = _relative_uv_areas(ref.uv, Fc)
    ratio = got / want
    assert want.min() < 1e-9  # the slivers are there
    assert 0.8 < ratio.min() and ratio.max() < 1.25, (ratio.min(), ratio.max(), np.argmin(ratio), np.argmax(ratio))


def test_a_flipped_face_is_reported_as_such_and_nothing_changes():
    open_fixture("shapes")
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=10, y_subdivisions=10, size=2)
    mesh = bpy.context.object.data
    mesh.polygons[0].flip()
    mesh.update()
    before = mesh_snapshot(mesh)
    with pytest.raises(RuntimeError, match="inconsistent face orientation") as exc:
        unwrap()
    assert "zero area" not in str(exc.value)
    assert mesh_snapshot(mesh) == before


def test_charts_with_pinned_uvs_are_left_as_they_are(capsys):
    """Pinned UVs mean the user placed them: their chart is left alone (Blender's own unwrap keeps
    pins), the other charts are unwrapped."""
    obj = ngon_cylinder_with_seams()  # three charts: two caps and the side
    mesh = obj.data
    if mesh.uv_layers.active is None:
        mesh.uv_layers.new(name="UVMap")
    cap = next(p for p in mesh.polygons if p.loop_total > 4)
    pinned = range(cap.loop_start, cap.loop_start + cap.loop_total)
    uv = layer_uv(mesh)
    uv[list(pinned)] = 5.0
    mesh.uv_layers.active.data.foreach_set("uv", uv.ravel())
    pins = np.zeros(len(mesh.loops), bool)
    pins[list(pinned)] = True
    compat.set_uv_pins(mesh, pins)
    select(obj.name)
    assert unwrap(pack=False) == {'FINISHED'}
    assert "1 chart(s) with pinned UVs left as they are" in capsys.readouterr().out
    uv = layer_uv(mesh)
    assert np.all(uv[list(pinned)] == 5.0)  # the pinned cap is untouched
    others = np.setdiff1d(np.arange(len(mesh.loops)), list(pinned))
    assert np.all(uv[others] <= 1.0)  # the other two charts were unwrapped into [0, 1]^2


def _seamed_grid(n=8):
    """A grid cut by a seam along x = 0 into two charts, left half's faces flagged."""
    bpy.ops.object.select_all(action='DESELECT')
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=n, y_subdivisions=n)
    obj = bpy.context.object
    mesh = obj.data
    co = coords(mesh)
    set_seams(mesh, np.all(np.abs(co[edges_of(mesh)][:, :, 0]) < 1e-6, axis=1))
    centers = np.empty(3 * len(mesh.polygons), np.float32)
    mesh.polygons.foreach_get("center", centers)
    return obj, centers.reshape(-1, 3)[:, 0] < 0


def _uv_bbox(mesh, faces):
    uv = layer_uv(mesh)
    loops = [i for p in mesh.polygons if faces[p.index] for i in p.loop_indices]
    return uv[loops].min(0), uv[loops].max(0)


def test_object_mode_packs_hidden_faces_too_and_keeps_them_hidden():
    """Object mode unwraps every face, hidden ones included: the packer (which skips hidden faces)
    must see them too, or their chart overlaps the packed ones."""
    obj, left = _seamed_grid()
    mesh = obj.data
    mesh.polygons.foreach_set("hide", left)
    mesh.update()
    hide_before = [p.hide for p in mesh.polygons]
    assert unwrap(pack=True) == {'FINISHED'}
    (lo_a, hi_a), (lo_b, hi_b) = _uv_bbox(mesh, left), _uv_bbox(mesh, ~left)
    overlap = np.minimum(hi_a, hi_b) - np.maximum(lo_a, lo_b)
    assert np.any(overlap <= 1e-6), (lo_a, hi_a, lo_b, hi_b)  # the islands' boxes are apart
    assert [p.hide for p in mesh.polygons] == hide_before


@pytest.mark.parametrize("edit", [False, True])
def test_uv_selection_survives_packing(edit):
    """The packer works on selected UVs: the UV vertex and edge selection are put back (the edge
    flags were left all set)."""
    obj, _ = _seamed_grid(6)
    mesh = obj.data
    sel = np.arange(len(mesh.loops)) % 3 == 0
    sel_edge = np.arange(len(mesh.loops)) % 4 == 1
    compat.set_uv_selection(mesh, [sel, sel_edge])
    if edit:
        bpy.ops.object.mode_set(mode='EDIT')
        bpy.ops.mesh.select_all(action='SELECT')
    assert unwrap(pack=True) == {'FINISHED'}
    if edit:
        bpy.ops.object.mode_set(mode='OBJECT')
    after = compat.uv_selection(mesh)
    assert np.array_equal(after[0], sel) and np.array_equal(after[1], sel_edge)


def test_edit_mode_unwrap_stays_in_edit_mode(dg, capsys):
    """Edit mode is never left: each round trip rebuilt the edit-mesh (seconds on a mesh of a
    million triangles) and invalidated a script's bmesh of it. Only the selected faces' UVs change
    and they are packed; mesh selection, UV selection and the faces left out stay as they were."""
    obj, left = _seamed_grid(8)
    mesh = obj.data
    layer = mesh.uv_layers.active
    rng = np.random.default_rng(2)
    layer.data.foreach_set("uv", (3 * rng.random(2 * len(mesh.loops))).astype(np.float32))
    compat.set_uv_selection(mesh, [rng.random(len(mesh.loops)) < 0.5, rng.random(len(mesh.loops)) < 0.5])
    mesh.polygons.foreach_set("select", left)
    mesh.vertices.foreach_set("select", np.zeros(len(mesh.vertices), bool))
    mesh.edges.foreach_set("select", np.zeros(len(mesh.edges), bool))
    mesh.update()
    before = layer_uv(mesh).copy()
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.context.tool_settings.mesh_select_mode = (False, False, True)
    bm = bmesh.from_edit_mesh(mesh)
    bm.faces.ensure_lookup_table()
    face = bm.faces[0]
    uv = bm.loops.layers.uv.active

    def flags():
        return ([v.select for v in bm.verts], [e.select for e in bm.edges], [f.select for f in bm.faces],
                compat.bm_uv_flags([l for f in bm.faces for l in f.loops], uv))

    sel_before = flags()
    assert unwrap(pack=True) == {'FINISHED'}
    assert "Unwrapped 1 chart(s) on 1 object(s)" in capsys.readouterr().out
    assert bm.is_valid and face.is_valid and bpy.context.mode == 'EDIT_MESH'
    assert flags() == sel_before
    bpy.ops.object.mode_set(mode='OBJECT')
    after = layer_uv(mesh)
    loop_left = np.repeat(left, [p.loop_total for p in mesh.polygons])
    assert after[~loop_left].tobytes() == before[~loop_left].tobytes()
    assert after[loop_left].min() >= 0 and after[loop_left].max() <= 1  # packed into the unit square
    check_charts(dg, obj, [set(np.flatnonzero(left))])


def test_edit_mode_without_uv_map_creates_it(dg, capsys):
    obj = ngon_cylinder_with_seams()
    select("NgonCylinder")
    assert obj.data.uv_layers.active is None
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    assert unwrap() == {'FINISHED'}
    out = capsys.readouterr().out
    assert "Unwrapped 3 chart(s) on 1 object(s)" in out and "(no UV map before)" in out
    assert "0 flipped, 0 zero-area, packed" in out
    bpy.ops.object.mode_set(mode='OBJECT')
    assert [layer.name for layer in obj.data.uv_layers] == ["UVMap"]
    check_charts(dg, obj, chart_faces(obj.data))


def test_undo_in_edit_mode_restores_the_uv_map():
    """Edit mode writes the UVs into the edit-mesh: one undo step, in Edit mode, takes them back."""
    obj = ngon_cylinder_with_seams()
    select("NgonCylinder")
    obj.data.uv_layers.new(name="UVMap")
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')

    def edit_uvs():
        bm = bmesh.from_edit_mesh(bpy.context.object.data)
        uv = bm.loops.layers.uv.active
        return [l[uv].uv[:] for f in bm.faces for l in f.loops]

    before = edit_uvs()
    bpy.ops.ed.undo_push(message="before")
    assert unwrap() == {'FINISHED'}
    assert edit_uvs() != before
    assert bpy.ops.ed.undo() == {'FINISHED'}
    assert bpy.context.mode == 'EDIT_MESH'
    assert edit_uvs() == before


def test_failed_packing_restores_the_selection(capsys):
    """An object outside the view layer (a script's override) cannot enter Edit mode: packing fails
    with a warning, and the selection it had set up is undone."""
    bpy.ops.object.select_all(action='DESELECT')
    bpy.ops.mesh.primitive_cube_add()
    other = bpy.context.object
    coll = bpy.data.collections.new("Excluded")
    bpy.context.scene.collection.children.link(coll)
    obj, _ = _seamed_grid(4)
    for c in obj.users_collection:
        c.objects.unlink(obj)
    coll.objects.link(obj)
    obj.data.polygons.foreach_set("select", np.zeros(len(obj.data.polygons), bool))
    obj.data.update()
    other.select_set(True)
    bpy.context.view_layer.layer_collection.children["Excluded"].exclude = True
    with bpy.context.temp_override(selected_objects=[obj], active_object=obj, object=obj):
        assert bpy.ops.dgmesh.unwrap(pack=True) == {'FINISHED'}
    assert "Packing failed" in capsys.readouterr().out
    assert not any(p.select for p in obj.data.polygons)
    assert other.select_get()
