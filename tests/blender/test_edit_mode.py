"""Edit-mode semantics across operators: only the edited objects' selections are targets, hidden
elements are left alone, pinned charts stay where they are, and the objects in Edit mode stay
the same ones."""

import bmesh
import bpy
import mathutils
import numpy as np
import pytest

from dgmesh.blender import compat


def _grid(name, offset=(0.0, 0.0, 0.0), n=14, seed=0):
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=n, y_segments=n, size=1.0)
    rng = np.random.default_rng(seed)
    for v in bm.verts:
        v.co.z = 0.3 * np.sin(2 * v.co.x) * np.cos(2 * v.co.y)
        v.co += mathutils.Vector(rng.normal(size=3) * 0.01) + mathutils.Vector(offset)
    me = bpy.data.meshes.new(name)
    bm.to_mesh(me)
    bm.free()
    me.uv_layers.new(name="UVMap")
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def _edit(*objs):
    """Edit mode for exactly these objects, face select mode, nothing selected."""
    layer = bpy.context.view_layer
    layer.update()  # objects linked since are not in layer.objects before
    for o in layer.objects:
        o.select_set(o in objs)
    layer.objects.active = objs[0]
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.context.tool_settings.mesh_select_mode = (False, False, True)
    bpy.ops.mesh.select_all(action='DESELECT')


def _select_faces(ob, faces):
    bm = bmesh.from_edit_mesh(ob.data)
    bm.faces.ensure_lookup_table()
    for i in faces:
        bm.faces[i].select_set(True)
    bm.select_history.clear()
    bm.select_history.add(bm.faces[faces[0]])
    bmesh.update_edit_mesh(ob.data)


def _middle_faces(ob, r=0.5):
    return [p.index for p in ob.data.polygons if p.center.x ** 2 + p.center.y ** 2 < r * r]


@pytest.fixture
def empty():
    bpy.ops.wm.read_homefile(use_empty=True)


@pytest.mark.parametrize("pinned_first", [False, True])
def test_unwrap_in_edit_mode_leaves_pinned_charts_in_place(empty, pinned_first):
    """Packing took every UV island with a selected face on every edited object, pinned charts
    (reported as left alone) included. Edit mode packs with only the unwrapped corners' UVs
    selected: the other edited object's UV selection is put back, whichever comes first."""
    a, p = _grid("A"), _grid("P", offset=(3, 0, 0), seed=1)
    co = np.array([p.data.vertices[loop.vertex_index].co[:2] for loop in p.data.loops])
    p.data.uv_layers.active.data.foreach_set("uv", (np.array([0.3, 0.2]) + 0.05 * co).astype(np.float32).ravel())
    compat.set_uv_pins(p.data, np.ones(len(p.data.loops), bool))
    compat.set_uv_selection(p.data, [np.arange(len(p.data.loops)) % 3 == 0])
    layer = p.data.uv_layers.active  # taken after the pin and selection layers were made
    before = np.array([d.uv[:] for d in layer.data])
    uv_sel = compat.uv_selection(p.data)
    _edit(*((p, a) if pinned_first else (a, p)))  # the active object comes first
    _select_faces(a, _middle_faces(a))
    _select_faces(p, list(range(len(p.data.polygons))))
    assert bpy.context.objects_in_mode_unique_data[0] == (p if pinned_first else a)
    assert bpy.ops.dgmesh.unwrap('EXEC_DEFAULT', pack=True) == {'FINISHED'}
    assert sorted(o.name for o in bpy.context.objects_in_mode) == ["A", "P"]
    bpy.ops.object.mode_set(mode='OBJECT')
    layer = p.data.uv_layers.active
    assert np.abs(np.array([d.uv[:] for d in layer.data]) - before).max() < 1e-7
    assert all(np.array_equal(x, y) for x, y in zip(compat.uv_selection(p.data), uv_sel))


def test_edited_object_with_nothing_selected_is_no_target_even_with_shape_keys(empty):
    """Its shape keys were an error that cancelled Remesh and reported on the others."""
    a, b = _grid("A"), _grid("B", offset=(3, 0, 0), seed=1)
    b.shape_key_add(name="Basis")
    for op, props in (("remesh", dict(target_vertices=60)), ("denoise", {}), ("fair", {}), ("regularize", {})):
        _edit(a, b)
        _select_faces(a, _middle_faces(a))
        assert getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **props) == {'FINISHED'}, op
        bpy.ops.object.mode_set(mode='OBJECT')


def test_objects_in_edit_mode_stay_the_same(empty):
    """Leaving and re-entering Edit mode to write entered it for the selected objects: an edited
    but unselected one dropped out, a selected one not in Edit mode came in."""
    a, b = _grid("A"), _grid("B", offset=(3, 0, 0), seed=1)
    _edit(a, b)
    b.select_set(False)
    _select_faces(a, _middle_faces(a))
    assert bpy.ops.dgmesh.denoise('EXEC_DEFAULT') == {'FINISHED'}
    assert sorted(o.name for o in bpy.context.objects_in_mode) == ["A", "B"]
    assert not b.select_get()
    bpy.ops.object.mode_set(mode='OBJECT')
    _edit(a)
    b.select_set(True)
    _select_faces(a, _middle_faces(a))
    assert bpy.ops.dgmesh.denoise('EXEC_DEFAULT') == {'FINISHED'}
    assert [o.name for o in bpy.context.objects_in_mode] == ["A"]
    assert b.select_get()


@pytest.mark.parametrize("op, props", [("crest_lines", dict(threshold=0.0, mark_seams=True)),
                                       ("segment", dict(mark_seams=True))])
def test_seams_leave_hidden_edges_alone(empty, op, props):
    a = _grid("A", n=24)
    mesh = a.data
    hide = np.array([p.center.x > 0.3 for p in mesh.polygons])
    mesh.polygons.foreach_set("hide", hide)
    ev = {k: e.index for e in mesh.edges for k in [e.key]}
    hidden_edges = sorted({ev[k] for p in mesh.polygons if p.hide for k in p.edge_keys})
    for i in hidden_edges:
        mesh.edges[i].hide = True
    seam = np.zeros(len(mesh.edges), bool)
    seam[hidden_edges[::3]] = True  # some user seams among the hidden edges
    mesh.edges.foreach_set("use_seam", seam)
    _edit(a)
    bpy.ops.mesh.select_all(action='SELECT')
    assert getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **props) == {'FINISHED'}
    bpy.ops.object.mode_set(mode='OBJECT')
    after = np.array([e.use_seam for e in mesh.edges])
    assert (after & ~seam).any()  # seams were marked on the shown part
    assert np.array_equal(after[hidden_edges], seam[hidden_edges])
    assert np.array_equal([p.hide for p in mesh.polygons], hide)


def test_similarity_map_in_face_mode_compares_a_vertex_of_the_active_face(empty, capsys):
    """It took the lowest-index selected vertex, whatever face was active."""
    a = _grid("A")
    _edit(a)
    bm = bmesh.from_edit_mesh(a.data)
    bm.faces.ensure_lookup_table()
    bm.faces[0].select_set(True)
    bm.faces[100].select_set(True)
    bm.select_history.clear()
    bm.select_history.add(bm.faces[100])
    corners = [v.index for v in bm.faces[100].verts]
    bmesh.update_edit_mesh(a.data)
    assert bpy.ops.dgmesh.similarity_map('EXEC_DEFAULT') == {'FINISHED'}
    out = capsys.readouterr().out
    vertex = int(out.split("to vertex ")[1].split(":")[0])
    assert vertex in corners
