"""Blender operators of thesis chapter 4: crest lines, feature decimation, segmentation."""

import bpy
import numpy as np
import pytest

import helpers
from dgmesh import shapes
from dgmesh.blender import compat


def make_object(name, V, faces):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in V], [], [tuple(f) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return obj


@pytest.fixture
def cube():
    bpy.ops.wm.read_homefile(use_empty=True)
    V, quads = shapes.rounded_cube(16, quads=True)
    return make_object("RoundedCube", V, quads)


def edge_attr(mesh, name):
    attr = mesh.attributes[name]
    assert attr.domain == 'EDGE' and attr.data_type == 'BOOLEAN'
    out = np.zeros(len(mesh.edges), bool)
    attr.data.foreach_get("value", out)
    return out


def test_crest_lines_marks_real_edges_on_quads(cube):
    res = bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=8.0, mark_sharp=True, create_curves=True)
    assert res == {'FINISHED'}
    mesh = cube.data
    ridge = edge_attr(mesh, "dg_ridge")
    valley = edge_attr(mesh, "dg_valley")
    assert ridge.sum() > 12 * 8 and valley.sum() == 0
    # Marked edges run along the rounded edges (both ends in the band of two coordinates).
    co = np.array([v.co[:] for v in mesh.vertices])
    ev = np.array([e.vertices[:] for e in mesh.edges])
    band = (np.abs(co) > 0.65).sum(axis=1) >= 2
    assert band[ev[ridge]].all()
    assert compat.element_values(mesh, "sharp_edge")[ridge].all()
    curve = bpy.data.objects["RoundedCube Crest Lines"]
    assert curve.type == 'CURVE' and len(curve.data.splines) > 0
    assert all(s.material_index == 0 for s in curve.data.splines)  # ridges: the blue material


def test_threshold_redo_uses_cache(cube):
    from dgmesh.blender import ops_crest

    ops_crest.FIT_CACHE.clear()
    bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=0.0)
    low = edge_attr(cube.data, "dg_ridge").sum()
    assert len(ops_crest.FIT_CACHE) == 1
    bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=1000.0)
    assert len(ops_crest.FIT_CACHE) == 1  # same mesh and rings: no new fit
    assert edge_attr(cube.data, "dg_ridge").sum() < low


def test_crest_lines_undo_restores_mesh(cube):
    before = helpers.mesh_snapshot(cube.data)
    bpy.ops.ed.undo_push(message="before")
    assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', True, threshold=8.0) == {'FINISHED'}
    bpy.ops.ed.undo()
    obj = bpy.data.objects["RoundedCube"]
    assert "dg_ridge" not in obj.data.attributes
    assert helpers.mesh_snapshot(obj.data) == before


def test_bad_mesh_reports_error_and_changes_nothing():
    bpy.ops.wm.read_homefile(use_empty=True)
    # Three triangles on one edge: not a manifold.
    V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1)]
    obj = make_object("Fan", V, [(0, 1, 2), (1, 0, 3), (0, 1, 4)])
    before = helpers.mesh_snapshot(obj.data)
    ops = ((bpy.ops.dgmesh.crest_lines, {}), (bpy.ops.dgmesh.decimate_features, {}),
           (bpy.ops.dgmesh.segment, {"segments": 2}))
    for op, props in ops:
        with pytest.raises(RuntimeError, match="not manifold"):
            op('EXEC_DEFAULT', **props)
        assert helpers.mesh_snapshot(obj.data) == before


def test_decimate_features(cube):
    n0 = len(cube.data.polygons) * 2
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.2, feature_weight=6.0, threshold=8.0) \
        == {'FINISHED'}
    mesh = cube.data
    assert len(mesh.polygons) <= 0.2 * n0 + 1
    import dgmesh
    from dgmesh.blender import bridge
    arrays = bridge.read_object(cube)
    dgmesh.validate(arrays.V, arrays.F, allow_loose_vertices=False)


def _values(data, key, k, dtype):
    a = np.empty(k * len(data), dtype)
    data.foreach_get(key, a)
    return a.reshape(-1, k) if k > 1 else a


def test_decimate_features_carries_vertex_groups_and_attributes(cube):
    """Rebuilding the geometry cleared the vertex groups (names too), every generic attribute,
    creases, bevel weights and custom normals.
    They are linear in the position here (or constant per side), so the carried values can be
    checked against the new positions: kept vertices exactly, moved ones by the nearest input
    triangle's barycentrics (to the rounded cube's curvature)."""
    mesh = cube.data
    V = _values(mesh.vertices, "co", 3, np.float32)
    g = cube.vertex_groups.new(name="Bone")
    cube.vertex_groups.new(name="Locked").lock_weight = True
    for i, x in enumerate(V[:, 0].tolist()):
        g.add([i], 0.5 + 0.25 * x, 'REPLACE')
    mesh.attributes.new("x", 'FLOAT', 'POINT').data.foreach_set("value", V[:, 0].copy())
    mesh.attributes.new("xy", 'FLOAT2', 'POINT').data.foreach_set("vector", V[:, :2].ravel())
    mesh.attributes.new("top", 'BOOLEAN', 'POINT').data.foreach_set("value", V[:, 2] > 0)
    up = _values(mesh.polygons, "center", 3, np.float32)[:, 2] > 0
    mesh.attributes.new("face_up", 'INT', 'FACE').data.foreach_set("value", np.where(up, 7, -2).astype(np.int32))
    mesh.attributes.new("on", 'FLOAT', 'EDGE').data.foreach_set("value", np.ones(len(mesh.edges), np.float32))
    ev = _values(mesh.edges, "vertices", 2, np.int32)
    top_edge = (V[ev, 2] > 0).all(1)  # creased, bevel-weighted where both ends are above z = 0
    for name, value in (("crease_edge", 0.75), ("bevel_weight_edge", 0.5)):
        compat.set_element_values(mesh, name, np.where(top_edge, value, 0.0))
    # Vertex creases and bevel weights: 1 on the upper half.
    for name in ("crease_vert", "bevel_weight_vert"):
        compat.set_element_values(mesh, name, V[:, 2] > 0)
    # Custom normals: every corner points along its vertex's position (not the surface normal).
    lv = _values(mesh.loops, "vertex_index", 1, np.int32)
    compat.set_custom_normals(mesh, V[lv] / np.linalg.norm(V[lv], axis=1, keepdims=True))
    col = mesh.color_attributes.new("Col", 'BYTE_COLOR', 'CORNER')
    col.data.foreach_set("color_srgb", np.tile([0.5, 0.2, 0.05, 1.0], len(mesh.loops)).astype(np.float32))
    mesh.color_attributes.new("Other", 'FLOAT_COLOR', 'POINT')
    from dgmesh.blender import bridge
    bridge.set_active_color(mesh, "Other")  # active and render
    mesh.color_attributes.active_color = mesh.color_attributes["Col"]
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.2, feature_weight=6.0) == {'FINISHED'}
    mesh = cube.data
    n = len(mesh.vertices)
    assert n < len(V) / 2
    V2 = _values(mesh.vertices, "co", 3, np.float32)
    assert [(x.name, x.lock_weight) for x in cube.vertex_groups] == [("Bone", False), ("Locked", True)]
    w = np.array([[e.weight for e in v.groups if e.group == 0] for v in mesh.vertices])
    assert w.shape == (n, 1) and np.abs(w[:, 0] - (0.5 + 0.25 * V2[:, 0])).max() < 0.01
    assert not any(e.group == 1 for v in mesh.vertices for e in v.groups)
    assert np.abs(_values(mesh.attributes["x"].data, "value", 1, np.float32) - V2[:, 0]).max() < 0.04
    assert np.abs(_values(mesh.attributes["xy"].data, "vector", 2, np.float32) - V2[:, :2]).max() < 0.04
    top = _values(mesh.attributes["top"].data, "value", 1, bool)
    clear = np.abs(V2[:, 2]) > 0.2
    assert np.array_equal(top[clear], V2[clear, 2] > 0)
    face_up = _values(mesh.attributes["face_up"].data, "value", 1, np.int32)
    z = _values(mesh.polygons, "center", 3, np.float32)[:, 2]
    far = np.abs(z) > 0.3  # a triangle takes the value of the input face it was (as its material)
    assert set(face_up.tolist()) == {7, -2} and (face_up[far] == np.where(z > 0, 7, -2)[far]).mean() > 0.95
    on = _values(mesh.attributes["on"].data, "value", 1, np.float32)
    assert set(on.tolist()) <= {0.0, 1.0} and on.sum() > len(on) / 4  # surviving edges: 1, new ones 0
    z2 = V2[_values(mesh.edges, "vertices", 2, np.int32), 2]
    for name, value in (("crease_edge", 0.75), ("bevel_weight_edge", 0.5)):  # surviving edges keep theirs
        w = compat.element_values(mesh, name)
        assert set(np.round(w, 3).tolist()) == {0.0, value} and not (w[on == 0]).any()
        upper = (on > 0) & (z2 > 0.3).all(1)
        # (flat sides decimate to large triangles: a creased edge's image can reach far down them)
        assert (w[upper] > 0).mean() > 0.9 and z2[w > 0].mean() > 0.3
    assert mesh.has_custom_normals
    n = compat.corner_normals(mesh)
    p = V2[_values(mesh.loops, "vertex_index", 1, np.int32)]
    cos = (n * p).sum(1) / np.linalg.norm(p, axis=1)
    assert cos.min() > 0.999  # moved vertices: blended at their place in the nearest input triangle
    # a merged vertex takes the largest of its sources': 1 above z = 0, 0 well below
    for w in (compat.element_values(mesh, "crease_vert"), compat.element_values(mesh, "bevel_weight_vert")):
        assert set(w.tolist()) == {0.0, 1.0} and (w[V2[:, 2] > 0.05] == 1).all() and not w[V2[:, 2] < -0.3].any()
    c = _values(mesh.color_attributes["Col"].data, "color_srgb", 4, np.float32)
    assert np.abs(c - [0.5, 0.2, 0.05, 1.0]).max() < 2 / 255
    colors = mesh.color_attributes
    assert colors.active_color.name == "Col" and colors[colors.render_color_index].name == "Other"


def test_decimate_features_carries_custom_normals_alone(cube):
    """Custom normals on a mesh with no UV map, vertex group or attribute: the vertices moved to
    their quadric optimum got zero normals (Blender's own there), as the lookup that places them was
    made only for those data."""
    mesh = cube.data
    compat.set_custom_normals(mesh, np.tile([0.0, 0.6, 0.8], (len(mesh.loops), 1)))
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.2, feature_weight=6.0) == {'FINISHED'}
    mesh = cube.data
    # (Blender stores custom normals to about 0.01)
    assert np.abs(compat.corner_normals(mesh) - [0.0, 0.6, 0.8]).max() < 0.02


def test_operators_work_on_every_selected_object():
    bpy.ops.wm.read_homefile(use_empty=True)
    V, quads = shapes.rounded_cube(10, quads=True)
    a = make_object("CubeA", V, quads)
    b = make_object("CubeB", V * 2.0, quads)
    a.select_set(True)  # make_object selected only b
    assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=0.0) == {'FINISHED'}
    for obj in (a, b):
        assert edge_attr(obj.data, "dg_ridge").sum() > 0
    assert bpy.ops.dgmesh.segment('EXEC_DEFAULT', segments=6, feature_weight=0.0) == {'FINISHED'}
    assert "dg_segment" in a.data.attributes and "dg_segment" in b.data.attributes
    n = len(a.data.polygons)
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.25, feature_weight=0.0) == {'FINISHED'}
    assert len(a.data.polygons) < n and len(b.data.polygons) < n


def test_one_bad_object_does_not_block_the_others():
    bpy.ops.wm.read_homefile(use_empty=True)
    V, quads = shapes.rounded_cube(8, quads=True)
    good = make_object("Good", V, quads)
    bad = make_object("Fan", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1)],
                      [(0, 1, 2), (1, 0, 3), (0, 1, 4)])
    good.select_set(True)
    before = helpers.mesh_snapshot(bad.data)
    # The ERROR report for the bad object makes bpy.ops raise, but the good one is written.
    with pytest.raises(RuntimeError, match="Fan.*not manifold"):
        bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=0.0)
    assert "dg_ridge" in good.data.attributes
    assert helpers.mesh_snapshot(bad.data) == before


def _uv_cube_with_materials():
    bpy.ops.wm.read_homefile(use_empty=True)
    V, quads = shapes.rounded_cube(16, quads=True)
    obj = make_object("UVCube", V, quads)
    mesh = obj.data
    # UV = (x, y) of each corner's vertex on the top half, (x, y) + 3 on the bottom half: a seam
    # along z = 0 with a jump of 3 in UV space.
    co = np.array([v.co[:] for v in mesh.vertices])
    lv = np.array([l.vertex_index for l in mesh.loops])
    pc = np.array([p.center[2] for p in mesh.polygons])
    lp = np.repeat(np.arange(len(mesh.polygons)), [p.loop_total for p in mesh.polygons])
    uv = co[lv, :2] + np.where(pc[lp] < 0, 3.0, 0.0)[:, None]
    layer = mesh.uv_layers.new(name="Proj")
    layer.data.foreach_set("uv", uv.astype(np.float32).ravel())
    for name in ("Top", "Bottom"):
        mesh.materials.append(bpy.data.materials.new(name))
    mesh.polygons.foreach_set("material_index", (pc < 0).astype(np.int32))
    return obj


def _check_uvs_and_materials(obj):
    mesh = obj.data
    assert [l.name for l in mesh.uv_layers] == ["Proj"]
    assert [m.name for m in mesh.materials][:2] == ["Top", "Bottom"]
    co = np.array([v.co[:] for v in mesh.vertices])
    lv = np.array([l.vertex_index for l in mesh.loops])
    uv = np.array([d.uv[:] for d in mesh.uv_layers["Proj"].data])
    mat = np.array([p.material_index for p in mesh.polygons])
    pc = np.array([p.center[2] for p in mesh.polygons])
    lp = np.repeat(np.arange(len(mesh.polygons)), 3)
    # Every face keeps one island: its corners' UVs are all top or all bottom, matching its material.
    off = (uv[:, 0] > 1.5).reshape(-1, 3)
    assert (off.all(1) | ~off.any(1)).all()
    assert np.array_equal(off[:, 0], mat == 1)
    # Far from the seam the material follows the side.
    assert (mat[pc > 0.2] == 0).all() and (mat[pc < -0.2] == 1).all()
    # UVs follow the (moved) vertices: UV is linear in position within each original triangle, so the
    # barycentric lookup reproduces the projection up to the distance of a vertex from the surface.
    expected = co[lv, :2] + np.where(mat[lp] == 1, 3.0, 0.0)[:, None]
    assert np.abs(uv - expected).max() < 0.1


def test_decimate_keeps_uv_maps_and_materials():
    obj = _uv_cube_with_materials()
    n = 2 * len(obj.data.polygons)
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.2, feature_weight=6.0) == {'FINISHED'}
    assert len(obj.data.polygons) <= 0.2 * n + 1
    _check_uvs_and_materials(obj)



def test_decimate_in_edit_mode_and_undo():
    obj = _uv_cube_with_materials()
    n = len(obj.data.polygons)
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.ed.undo_push(message="edit")
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', True, ratio=0.2, feature_weight=0.0) == {'FINISHED'}
    assert obj.mode == 'EDIT'
    bpy.ops.object.mode_set(mode='OBJECT')
    assert len(obj.data.polygons) < n
    _check_uvs_and_materials(obj)
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.ed.undo()
    bpy.ops.object.mode_set(mode='OBJECT')
    assert len(bpy.data.objects["UVCube"].data.polygons) == n


def test_segment_writes_labels_colours_and_seams(cube):
    assert bpy.ops.dgmesh.segment('EXEC_DEFAULT', segments=6, feature_weight=2.0, threshold=8.0,
                                  mark_seams=True) == {'FINISHED'}
    mesh = cube.data
    attr = mesh.attributes["dg_segment"]
    assert attr.domain == 'FACE' and attr.data_type == 'INT'
    labels = np.zeros(len(mesh.polygons), np.int32)
    attr.data.foreach_get("value", labels)
    assert set(labels.tolist()) == set(range(6))
    assert mesh.color_attributes.active_color.name == "dg_segment_color"
    assert sum(e.use_seam for e in mesh.edges) > 0


def _merge(A, B):
    """The polygon of polygons A and B (vertex lists, same orientation) joined across their one
    shared edge."""
    shared = set(A) & set(B)
    n = len(A)
    i = next(i for i in range(n) if A[i] in shared and A[(i + 1) % n] in shared)
    a = [A[(i + 1 + k) % n] for k in range(n)]
    j = B.index(A[i])
    b = [B[(j + k) % len(B)] for k in range(len(B))]
    return a + b[1:-1]


def ngon_cube(name="NgonCube", n=16, flip=False):
    """Rounded cube of hexagons: pairs of grid quads joined by dissolving the edge between them.
    The flat sides get collinear corners and every joined line valence-2 vertices, where Blender's
    loop triangulation cuts zero-area or doubled ears."""
    bpy.ops.wm.read_homefile(use_empty=True)
    V, quads = shapes.rounded_cube(n, quads=True)
    polys = []
    for side in range(6):
        for a in range(n):
            for b in range(0, n, 2):
                q = [list(quads[(side * n + a) * n + bb]) for bb in (b, b + 1)]
                p = _merge(*q)
                polys.append(p[::-1] if flip else p)
    return make_object(name, V, polys)


def _covers_all_twelve_edges(mesh, marked):
    co = np.array([v.co[:] for v in mesh.vertices])
    ev = np.array([e.vertices[:] for e in mesh.edges])[marked]
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        for si in (-1, 1):
            for sj in (-1, 1):
                on = ((si * co[ev, i] > 0.6) & (sj * co[ev, j] > 0.6)).all(1)
                spans = np.sort(co[ev[on], k], axis=1)
                spans = spans[np.argsort(spans[:, 0])]
                reach = -0.55
                for lo, hi in spans:
                    if lo <= reach + 1e-6:
                        reach = max(reach, hi)
                assert reach >= 0.55, f"cube edge along axis {k} at ({si}, {sj}) covered only to {reach:.3f}"


def test_crest_lines_on_ngons_follow_all_twelve_edges(capfd):
    obj = ngon_cube()
    mesh = obj.data
    assert max(len(p.vertices) for p in mesh.polygons) == 6
    res = bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=8.0, create_curves=True)
    assert res == {'FINISHED'}
    ridge = edge_attr(mesh, "dg_ridge")
    assert not edge_attr(mesh, "dg_valley").any()
    # Only the mesh's own edges can be marked; the marks run unbroken along every rounded edge,
    # also where a line crosses a hexagon through its triangulation diagonals.
    _covers_all_twelve_edges(mesh, ridge)
    co = np.array([v.co[:] for v in mesh.vertices])
    ev = np.array([e.vertices[:] for e in mesh.edges])
    assert ((np.abs(co[ev[ridge]]) > 0.6).sum(axis=2) >= 2).all()
    # The report gives the line count and the total length of the exact polylines.
    curve = bpy.data.objects["NgonCube Crest Lines"]
    total = 0.0
    for spline in curve.data.splines:
        pts = np.array([p.co[:3] for p in spline.points])
        total += np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()
    out = capfd.readouterr().out
    import re
    m = re.search(r"Crest lines on 1 object: (\d+) lines \((\d+) ridges, 0 valleys\), total length ([0-9.]+)", out)
    assert m, out
    assert int(m.group(1)) == len(curve.data.splines) > 0
    assert abs(float(m.group(3)) - total) < 1e-3 * total + 0.01
    assert total > 12 * 1.1


def test_curve_object_ridges_blue_valleys_red():
    obj = ngon_cube("Inverted", flip=True)  # inside-out: the rounded edges are valleys
    assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=8.0, create_curves=True) == {'FINISHED'}
    assert edge_attr(obj.data, "dg_valley").sum() > 0 and not edge_attr(obj.data, "dg_ridge").any()
    curve = bpy.data.objects["Inverted Crest Lines"]
    ridge_mat, valley_mat = curve.data.materials[0], curve.data.materials[1]
    r, g, b, _ = ridge_mat.diffuse_color
    assert b > 2 * max(r, g)
    r, g, b, _ = valley_mat.diffuse_color
    assert r > 2 * max(g, b)
    assert len(curve.data.splines) > 0 and all(s.material_index == 1 for s in curve.data.splines)
    assert curve.matrix_world == obj.matrix_world


def test_segment_on_ngons_seams_are_the_borders_and_undo():
    obj = ngon_cube()
    mesh = obj.data
    before = helpers.mesh_snapshot(mesh)
    bpy.ops.ed.undo_push(message="before")
    assert bpy.ops.dgmesh.segment('EXEC_DEFAULT', True, segments=6, feature_weight=2.0, threshold=8.0,
                                  mark_seams=True) == {'FINISHED'}
    labels = np.zeros(len(mesh.polygons), np.int32)
    mesh.attributes["dg_segment"].data.foreach_get("value", labels)
    assert set(labels.tolist()) == set(range(6))
    # The seams are exactly the edges between polygons of different segments.
    border = np.zeros(len(mesh.edges), bool)
    edge_labels = {}
    for p in mesh.polygons:
        for e in p.edge_keys:
            edge_labels.setdefault(e, set()).add(int(labels[p.index]))
    key = {e.key: e.index for e in mesh.edges}
    for e, ls in edge_labels.items():
        border[key[e]] = len(ls) > 1
    seams = np.array([e.use_seam for e in mesh.edges])
    assert border.any() and np.array_equal(seams, border)
    # Every segment is one connected set of polygons (across shared edges).
    parent = list(range(len(mesh.polygons)))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x
    by_edge = {}
    for p in mesh.polygons:
        for e in p.edge_keys:
            q = by_edge.setdefault(e, p.index)
            if q != p.index and labels[q] == labels[p.index]:
                parent[find(q)] = find(p.index)
    roots = {find(i) for i in range(len(mesh.polygons))}
    assert len(roots) == 6
    bpy.ops.ed.undo()
    assert helpers.mesh_snapshot(bpy.data.objects["NgonCube"].data) == before


def test_decimate_on_ngons_and_undo():
    obj = ngon_cube()
    n_tri = sum(len(p.vertices) - 2 for p in obj.data.polygons)
    before = helpers.mesh_snapshot(obj.data)
    bpy.ops.ed.undo_push(message="before")
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', True, ratio=0.2, feature_weight=6.0,
                                            threshold=8.0) == {'FINISHED'}
    mesh = obj.data
    assert len(mesh.polygons) <= 0.2 * n_tri + 1
    import dgmesh
    from dgmesh.blender import bridge
    arrays = bridge.read_object(obj)
    dgmesh.validate(arrays.V, arrays.F, allow_loose_vertices=False)
    # The 12 rounded edges keep more of the density than the flat sides (eta = 6).
    co = np.array([v.co[:] for v in mesh.vertices])
    near_edges = (np.abs(co) > 0.7).sum(1) >= 2
    assert near_edges.mean() > 0.5
    bpy.ops.ed.undo()
    assert helpers.mesh_snapshot(bpy.data.objects["NgonCube"].data) == before


def test_repair_ngon_triangles_gives_valid_consistent_triangles():
    import dgmesh
    from dgmesh import polymesh
    from dgmesh.blender import bridge
    obj = ngon_cube()
    raw = bridge.read_object(obj, edges=True)
    with pytest.raises(dgmesh.MeshError):  # Blender's own triangulation: zero-area / doubled ears
        dgmesh.validate(raw.V, raw.F)
    fixed = polymesh.repair_ngon_triangles(raw)
    dgmesh.validate(fixed.V, fixed.F, allow_loose_vertices=False)
    loop_vertex = np.array([l.vertex_index for l in obj.data.loops])
    assert np.array_equal(loop_vertex[fixed.tri_loops], fixed.F)  # corners keep their loops
    assert np.array_equal(fixed.tri_poly, raw.tri_poly)
    # Each polygon is still covered by its triangles: same total vector area per polygon.
    def vector_area(a):
        V, F = a.V, a.F
        cr = 0.5 * np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
        out = np.zeros((len(obj.data.polygons), 3))
        np.add.at(out, a.tri_poly, cr)
        return out
    assert np.allclose(vector_area(fixed), vector_area(raw), atol=1e-9)
    # No triangle is folded back against its polygon.
    cr = np.cross(fixed.V[fixed.F[:, 1]] - fixed.V[fixed.F[:, 0]], fixed.V[fixed.F[:, 2]] - fixed.V[fixed.F[:, 0]])
    assert (np.einsum("ij,ij->i", cr, vector_area(raw)[fixed.tri_poly]) > 0).all()
    # Every loop of every polygon is used by a triangle (nothing dropped).
    assert len(np.unique(fixed.tri_loops)) == len(obj.data.loops)
    # A clean mesh is returned as is.
    assert polymesh.repair_ngon_triangles(fixed) is fixed


def test_decimate_refuses_shape_keys_and_partial_edit_selections():
    """Decimation rebuilds the whole mesh: shape keys (which cannot follow the new vertex count) and,
    in Edit mode, hidden or unselected faces (which would be decimated and revealed) are refused
    with the mesh unchanged."""
    obj = _uv_cube_with_materials()
    obj.shape_key_add(name="Basis")
    obj.shape_key_add(name="Lift").value = 1.0
    before = helpers.mesh_snapshot(obj.data)
    with pytest.raises(RuntimeError, match="shape keys"):
        bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.5)
    assert helpers.mesh_snapshot(obj.data) == before
    obj.shape_key_clear()
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    bpy.ops.mesh.hide(unselected=False)
    bpy.ops.mesh.reveal(select=False)  # all shown again, none selected
    bpy.ops.object.mode_set(mode='OBJECT')
    for p in obj.data.polygons:
        p.select = p.center.z > 0
        p.hide = p.center.x > 0.5 and not p.select
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.object.mode_set(mode='OBJECT')
    before = helpers.mesh_snapshot(obj.data)  # after an Edit-mode round trip (UV data is there in Object mode)
    bpy.ops.object.mode_set(mode='EDIT')
    with pytest.raises(RuntimeError, match="whole meshes"):
        bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.5)
    bpy.ops.object.mode_set(mode='OBJECT')
    assert helpers.mesh_snapshot(obj.data) == before


def test_crest_curve_is_replaced_after_a_rename_a_long_name_and_removed_when_no_line_is_found(cube):
    def curves():
        return [o for o in bpy.data.objects if o.type == 'CURVE']

    def run(threshold=8.0):
        return bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=threshold, create_curves=True)

    assert run() == {'FINISHED'} and len(curves()) == 1
    cube.name = "Renamed"
    assert run() == {'FINISHED'}
    assert [c.name for c in curves()] == ["Renamed Crest Lines"]
    cube.name = "L" * 55  # '<name> Crest Lines' is cut to Blender's 63 characters
    for _ in range(3):
        assert run() == {'FINISHED'}
    assert len(curves()) == 1 and curves()[0].get("dgmesh_crest_lines_of") == cube
    assert run(threshold=1e9) == {'FINISHED'}  # no line at this threshold: no stale curve
    assert curves() == []


def test_segment_rerun_replaces_its_own_seams_and_keeps_the_users():
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16)
    mesh = bpy.context.object.data
    user = np.zeros(len(mesh.edges), bool)
    user[:5] = True  # the user's own seams
    mesh.edges.foreach_set("use_seam", user)

    def borders():
        lab = helpers.attribute_array(mesh.attributes["dg_segment"]).ravel()
        ef = {}
        for p in mesh.polygons:
            for k in p.edge_keys:
                ef.setdefault(k, set()).add(int(lab[p.index]))
        return np.array([len(ef.get(e.key, ())) > 1 for e in mesh.edges])

    for n in (6, 12):
        assert bpy.ops.dgmesh.segment('EXEC_DEFAULT', segments=n, mark_seams=True) == {'FINISHED'}
        seam = np.array([e.use_seam for e in mesh.edges])
        np.testing.assert_array_equal(seam, borders() | user)


def test_decimate_keeps_seams_and_sharp_edges_that_survive():
    """An unwrapped mesh's seams (their vertices are locked on the UV seam) and its sharp edges
    there come through the decimation (they were all dropped)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16)
    mesh = bpy.context.object.data
    # The primitive's UV seam: edges whose two vertices each have several UVs.
    uv = np.empty(2 * len(mesh.loops), np.float32)
    mesh.uv_layers.active.data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    lv = np.array([l.vertex_index for l in mesh.loops])
    first = {}
    multi = np.zeros(len(mesh.vertices), bool)
    for l, v in enumerate(lv):
        if v in first and np.abs(uv[first[v]] - uv[l]).max() > 1e-6:
            multi[v] = True
        first.setdefault(v, l)
    E = np.array([e.vertices[:] for e in mesh.edges])
    seam = multi[E[:, 0]] & multi[E[:, 1]]
    mesh.edges.foreach_set("use_seam", seam)
    mesh.edges.foreach_set("use_edge_sharp", seam)
    assert seam.sum() >= 15
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.3, feature_weight=0.0) == {'FINISHED'}
    E2 = np.array([e.vertices[:] for e in mesh.edges])
    co = np.array([v.co[:] for v in mesh.vertices])
    seam2 = np.array([e.use_seam for e in mesh.edges])
    assert seam2.sum() >= 15 and np.array_equal(seam2, [e.use_edge_sharp for e in mesh.edges])
    # They run along the same meridian: every seam vertex has the seam's longitude.
    seam_co = co[np.unique(E2[seam2])]
    lon = np.arctan2(seam_co[:, 1], seam_co[:, 0])
    ring = np.hypot(seam_co[:, 0], seam_co[:, 1]) > 1e-3  # the poles have no longitude
    assert np.ptp(lon[ring]) < 1e-3


def test_decimate_keeps_loose_geometry_and_hidden_faces():
    """Loose vertices and wire edges are not part of the surface: they come through as they were
    (they were deleted), a wire edge following the surface vertex it hangs from; hidden faces'
    triangles stay hidden."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16)
    obj = bpy.context.object
    mesh = obj.data
    n = len(mesh.vertices)
    top = max(range(n), key=lambda i: mesh.vertices[i].co.z)  # the pole, kept by decimation
    mesh.vertices.add(3)
    for i, co in enumerate([(0, 0, 2), (3, 0, 0), (3, 1, 0)]):
        mesh.vertices[n + i].co = co
    mesh.edges.add(2)
    mesh.edges[-2].vertices = (top, n)  # a wire edge hanging from the surface
    mesh.edges[-1].vertices = (n + 1, n + 2)  # a free-floating edge
    mesh.vertices.add(1)
    mesh.vertices[n + 3].co = (-3, 0, 0)  # a loose vertex
    hide = np.array([p.center.x > 0.5 for p in mesh.polygons])
    mesh.polygons.foreach_set("hide", hide)
    mesh.update()
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.3, feature_weight=0.0) == {'FINISHED'}
    co = np.array([v.co[:] for v in mesh.vertices])
    in_face = np.zeros(len(co), bool)
    in_face[[i for p in mesh.polygons for i in p.vertices]] = True
    assert sorted(map(tuple, co[~in_face].round(6))) == [(-3, 0, 0), (0, 0, 2), (3, 0, 0), (3, 1, 0)]
    used = {k for p in mesh.polygons for k in p.edge_keys}
    wire = [tuple(sorted(tuple(co[v].round(6)) for v in e.vertices)) for e in mesh.edges if e.key not in used]
    assert len(wire) == 2 and ((3, 0, 0), (3, 1, 0)) in wire
    hanging = next(w for w in wire if (0, 0, 2) in w)
    assert hanging[0] in map(tuple, co[in_face].round(6))  # its other end is on the surface
    assert len(mesh.polygons) < 300
    centres = np.array([p.center.x for p in mesh.polygons])
    hidden = np.array([p.hide for p in mesh.polygons])
    assert hidden.any() and np.all(centres[hidden] > 0.3) and np.all(centres[~hidden] < 0.7)


def test_crest_curve_goes_to_the_scene_the_operator_ran_in(cube):
    """A mesh in two scenes: the curve is linked where the user is working (it went to the first
    scene's collection)."""
    s2 = bpy.data.scenes.new("Scene2")
    s2.collection.objects.link(cube)
    layer = s2.view_layers[0]
    cube.select_set(True, view_layer=layer)
    layer.objects.active = cube
    with bpy.context.temp_override(scene=s2, view_layer=layer, active_object=cube, object=cube,
                                   selected_objects=[cube]):
        assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=8.0, create_curves=True) == {'FINISHED'}
    curve = next(o for o in bpy.data.objects if o.get("dgmesh_crest_lines_of") == cube)
    assert curve.name in s2.objects


def test_crest_curve_for_every_selected_linked_duplicate(cube, capsys):
    """Linked duplicates share the mesh, so both show the marked edges: each selected one gets its
    curve, in its place (the second got none), and the report says so (it said '1 object')."""
    twin = cube.copy()
    twin.location = (3.0, 0.0, 0.0)
    bpy.context.scene.collection.objects.link(twin)
    twin.select_set(True)

    def curves():
        return sorted((o for o in bpy.data.objects if o.type == 'CURVE'), key=lambda o: o.name)

    for _ in range(2):  # a re-run replaces them
        assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=8.0, create_curves=True) == {'FINISHED'}
        bpy.context.view_layer.update()
        assert [(c.parent, c.get("dgmesh_crest_lines_of")) for c in curves()] == [(cube, cube), (twin, twin)]
        assert curves()[0].data == curves()[1].data and len(curves()[0].data.splines) > 0
        assert [c.matrix_world for c in curves()] == [cube.matrix_world, twin.matrix_world]
        out = capsys.readouterr().out
        assert "Crest lines on 1 object:" in out and "curves for 2 objects" in out
    assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=1e9, create_curves=True) == {'FINISHED'}
    assert curves() == [] and len(bpy.data.curves) == 0


def test_crest_lines_report_names_the_fit_and_the_thesis_fit_can_be_chosen(capfd):
    """The jet fit is the default (issue #31); on a noisy mesh it gives way to the thesis fit, and the report says
    which ran; Fit = Thesis gives the thesis fit's lines."""
    bpy.ops.wm.read_homefile(use_empty=True)
    V, F = shapes.grid(40, 40)
    V = (V - 0.5) * 8.0  # cells of 0.2
    V[:, 2] = 0.4 * np.cos(np.hypot(V[:, 0], 1.5 * V[:, 1]))
    obj = make_object("Waves", V, F)
    capfd.readouterr()

    def run(**kw):
        assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=0.0, **kw) == {'FINISHED'}
        return capfd.readouterr().out, edge_attr(obj.data, "dg_ridge")

    out, jet = run()
    assert "jet fit)" in out, out
    out, thesis = run(fit='THESIS')
    assert "thesis fit)" in out, out
    assert (jet != thesis).any()  # the two fits' lines differ on this coarse graph
    rng = np.random.default_rng(1)
    noisy = V + rng.normal(0.0, 0.1 * 0.2, V.shape)
    obj.data.vertices.foreach_set("co", noisy.ravel())
    obj.data.update()
    out, _ = run()
    assert "thesis fit: the mesh looks noisy" in out, out
