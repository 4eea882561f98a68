"""dgmesh.auto_unwrap inside Blender: disk charts of closed meshes, seams, packing, partial selection, undo."""

import bpy
import numpy as np

from helpers import layer_uv, mesh_snapshot, open_fixture, select


def auto_unwrap(**props):
    """Run the operator the way the UI does: with an undo push."""
    return bpy.ops.dgmesh.auto_unwrap('EXEC_DEFAULT', True, **props)


def seams(mesh):
    s = np.empty(len(mesh.edges), bool)
    mesh.edges.foreach_get("use_seam", s)
    return s


def seam_charts(mesh, faces):
    """The polygons ``faces`` joined across non-seam edges (a plain Python flood fill, independent
    of the add-on): a list of polygon sets."""
    seam = seams(mesh)
    by_edge = {}
    for p in faces:
        for e in mesh.polygons[p].loop_indices:
            by_edge.setdefault(mesh.loops[e].edge_index, []).append(p)
    adj = {p: [] for p in faces}
    for e, ps in by_edge.items():
        if len(ps) == 2 and not seam[e]:
            adj[ps[0]].append(ps[1])
            adj[ps[1]].append(ps[0])
    left, charts = set(faces), []
    while left:
        todo = [left.pop()]
        chart = set(todo)
        while todo:
            for q in adj[todo.pop()]:
                if q in left:
                    left.remove(q)
                    chart.add(q)
                    todo.append(q)
        charts.append(chart)
    return charts


def euler(mesh, chart):
    """V - E + F of a set of polygons cut open where their UVs differ (one vertex per vertex and
    UV, as the charts are laid out: a chart may be cut inside along a seam) and the number of its
    boundary edges."""
    uv = np.round(layer_uv(mesh).astype(np.float64), 5)
    verts, edges = set(), {}
    for p in chart:
        poly = mesh.polygons[p]
        corners = [(mesh.loops[i].vertex_index, tuple(uv[i])) for i in poly.loop_indices]
        verts.update(corners)
        for k in range(len(corners)):
            e = tuple(sorted((corners[k], corners[(k + 1) % len(corners)])))
            edges[e] = edges.get(e, 0) + 1
    return len(verts) - len(edges) + len(chart), sum(1 for c in edges.values() if c == 1)


def uv_triangles(mesh):
    mesh.calc_loop_triangles()
    loops = np.empty(3 * len(mesh.loop_triangles), np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    return loops.reshape(-1, 3)


def signed_uv_areas(uv, tri_loops):
    T = uv[tri_loops].astype(np.float64)
    e1, e2 = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    return 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def test_torus_is_cut_into_disk_charts_with_seams_and_uvs(capsys):
    open_fixture("shapes")
    mesh = bpy.data.objects["Torus"].data
    assert not seams(mesh).any()
    select("Torus")
    assert auto_unwrap(max_stretch=1.1) == {'FINISHED'}
    assert "Auto unwrap:" in capsys.readouterr().out
    s = seams(mesh)
    assert s.any()
    charts = seam_charts(mesh, range(len(mesh.polygons)))
    assert len(charts) >= 2
    for chart in charts:
        chi, n_boundary = euler(mesh, chart)
        assert chi == 1 and n_boundary > 0, "every chart cut by the seams is a disk"
    uv = layer_uv(mesh)
    a = signed_uv_areas(uv, uv_triangles(mesh))
    assert (a > 0).all() or (a < 0).all(), "no flipped UV triangle"
    assert uv.min() >= -1e-4 and uv.max() <= 1 + 1e-4
    # The seams written are the cuts of a disk layout: the seam-based unwrap takes them as they are.
    assert bpy.ops.dgmesh.unwrap('EXEC_DEFAULT', True) == {'FINISHED'}


def test_chart_count_target_and_polygons_stay_whole():
    open_fixture("shapes")
    mesh = bpy.data.objects["QuadSphere"].data
    select("QuadSphere")
    assert auto_unwrap(target='CHARTS', charts=6, pack=False) == {'FINISHED'}
    charts = seam_charts(mesh, range(len(mesh.polygons)))
    assert len(charts) >= 6
    for chart in charts:
        assert euler(mesh, chart)[0] == 1
    # Each polygon's corners were written from one chart: a quad's UVs have positive area.
    uv = layer_uv(mesh)
    a = signed_uv_areas(uv, uv_triangles(mesh))
    assert (a > 0).all() or (a < 0).all()


def test_partial_selection_leaves_other_uvs_and_seams_alone():
    open_fixture("shapes")
    obj = bpy.data.objects["QuadSphere"]
    mesh = obj.data
    rng = np.random.default_rng(0)
    layer = mesh.uv_layers.new(name="Existing")
    layer.data.foreach_set("uv", rng.random(2 * len(mesh.loops)).astype(np.float32))
    other = mesh.uv_layers.new(name="Other")
    other.data.foreach_set("uv", rng.random(2 * len(mesh.loops)).astype(np.float32))
    mesh.uv_layers.active = layer
    user_seams = rng.random(len(mesh.edges)) < 0.3
    mesh.edges.foreach_set("use_seam", user_seams)
    sel = np.array([p.center.z for p in mesh.polygons]) > 0.0  # the northern half: a disk
    mesh.polygons.foreach_set("select", sel)
    mesh.update()
    before, before_other = layer_uv(mesh).copy(), layer_uv(mesh, "Other").copy()
    select("QuadSphere")
    bpy.ops.object.mode_set(mode='EDIT')
    assert auto_unwrap() == {'FINISHED'}
    assert bpy.context.mode == 'EDIT_MESH'
    bpy.ops.object.mode_set(mode='OBJECT')
    after = layer_uv(mesh)
    poly_of_loop = np.repeat(np.arange(len(mesh.polygons)), [p.loop_total for p in mesh.polygons])
    untouched = ~sel[poly_of_loop]
    assert after[untouched].tobytes() == before[untouched].tobytes()
    assert np.abs(after[~untouched] - before[~untouched]).max() > 1e-3
    assert layer_uv(mesh, "Other").tobytes() == before_other.tobytes()
    # Seams: edges touching an unselected face keep the user's; the selected faces' inner edges
    # now cut them into disk charts.
    loop_edge = np.array([l.edge_index for l in mesh.loops])
    touches_other = np.zeros(len(mesh.edges), bool)
    touches_other[loop_edge[untouched]] = True
    s = seams(mesh)
    assert (s[touches_other] == user_seams[touches_other]).all()
    assert (s[~touches_other] != user_seams[~touches_other]).any()
    for chart in seam_charts(mesh, np.flatnonzero(sel).tolist()):
        assert euler(mesh, chart)[0] == 1


def test_undo_restores_uvs_and_seams():
    open_fixture("shapes")
    mesh = bpy.data.objects["Torus"].data
    mesh.uv_layers.new(name="UVMap")
    select("Torus")
    before, before_seams = mesh_snapshot(mesh), seams(mesh).copy()
    bpy.ops.ed.undo_push(message="before")
    assert auto_unwrap() == {'FINISHED'}
    mesh = bpy.data.objects["Torus"].data
    assert mesh_snapshot(mesh)["uv_layers"] != before["uv_layers"]
    assert (seams(mesh) != before_seams).any()
    assert bpy.ops.ed.undo() == {'FINISHED'}
    mesh = bpy.data.objects["Torus"].data
    assert mesh_snapshot(mesh) == before
    assert (seams(mesh) == before_seams).all()


def test_menu_lists_it_next_to_unwrap():
    from dgmesh.blender import ui
    ids = [op[0] for op in ui.OPERATORS]
    assert ids.index("dgmesh.auto_unwrap") == ids.index("dgmesh.unwrap") + 1


def test_open_tube_becomes_one_chart_with_one_rim_to_rim_seam():
    # Known answer: an open cylinder of n x rows quads (developable) unwraps into one chart, cut
    # along a single path of `rows` edges from the bottom rim to the top one, without stretch.
    open_fixture("shapes")
    n, rows, h = 16, 4, 2.0
    t = 2 * np.pi * np.arange(n) / n
    verts = [(np.cos(a), np.sin(a), h * k / rows) for k in range(rows + 1) for a in t]
    quads = [(k * n + i, k * n + (i + 1) % n, (k + 1) * n + (i + 1) % n, (k + 1) * n + i)
             for k in range(rows) for i in range(n)]
    mesh = bpy.data.meshes.new("Tube")
    mesh.from_pydata(verts, [], quads)
    mesh.update()
    obj = bpy.data.objects.new("Tube", mesh)
    bpy.context.scene.collection.objects.link(obj)
    select("Tube")
    assert auto_unwrap() == {'FINISHED'}
    charts = seam_charts(mesh, range(len(mesh.polygons)))
    assert len(charts) == 1
    assert euler(mesh, charts[0]) == (1, 2 * n + 2 * rows), "cut open: one disk, both rims and the cut's two sides"
    s = np.flatnonzero(seams(mesh))
    assert len(s) == rows
    ev = np.array([mesh.edges[e].vertices[:] for e in s])
    v, deg = np.unique(ev, return_counts=True)
    assert sorted(deg.tolist()) == [1, 1] + [2] * (rows - 1)
    z = sorted(mesh.vertices[int(i)].co.z for i in v[deg == 1])
    assert abs(z[0]) < 1e-6 and abs(z[1] - h) < 1e-6
    uv = layer_uv(mesh)
    a = signed_uv_areas(uv, uv_triangles(mesh))
    assert (a > 0).all() or (a < 0).all()
