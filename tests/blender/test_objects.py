"""Object situations of real files: library overrides, overridden collections, results that follow
their mesh (parenting, shear), vertex parents and hooks through renumbering operators."""

import bpy
import numpy as np
import pytest

import helpers
from helpers import select

# Operators that change or annotate a mesh, with quick settings.
MESH_OPERATORS = {
    "denoise": {"iterations": 1},
    "fair": {"max_iterations": 3},
    "regularize": {"iterations": 2},
    "curvature_map": {},
    "crest_lines": {},
    "decimate_features": {"ratio": 0.5},
    "segment": {"segments": 3},
    "remesh": {},
    "stretch_map": {},
    "similarity_map": {},
    "multires_preview": {"control_faces": 200},
}


def _sphere(name, subdivisions=3):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.name = name
    return obj


def _co(mesh):
    co = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def _overridden_sphere(tmp_path):
    """A sphere (with UVs: Stretch Map needs them) in a collection of another file, linked and made
    editable with Make Library Override: the override object, in the overridden collection."""
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = _sphere("LibSphere")
    col = bpy.data.collections.new("LibCol")
    bpy.context.scene.collection.children.link(col)
    for c in obj.users_collection:
        c.objects.unlink(obj)
    col.objects.link(obj)
    lib = tmp_path / "lib.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(lib))
    bpy.ops.wm.read_homefile(use_empty=True)
    helpers.link_and_override(lib, "LibCol")
    return next(o for o in bpy.context.scene.objects if o.type == 'MESH')


@pytest.fixture
def override_sphere(tmp_path):
    """The overridden sphere with its mesh overridden too (a character made editable)."""
    _overridden_sphere(tmp_path).data.override_create(remap_local_usages=True)
    obj = next(o for o in bpy.context.scene.objects if o.type == 'MESH')
    assert obj.data.library is None and obj.data.override_library is not None
    select(obj.name)
    return obj


@pytest.mark.parametrize("op", sorted(MESH_OPERATORS))
def test_library_override_mesh_is_refused(override_sphere, op):
    """Blender ignores foreach_set on an overridden mesh and a save drops what bmesh wrote: Feature
    Decimate left loose vertices, Denoise reported vertices moved and moved none, attributes were
    lost on reload."""
    obj = override_sphere
    before = _co(obj.data).copy(), len(obj.data.polygons), set(obj.data.attributes.keys())
    with pytest.raises(RuntimeError, match="library override"):
        getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **MESH_OPERATORS[op])
    after = _co(obj.data), len(obj.data.polygons), set(obj.data.attributes.keys())
    assert np.array_equal(before[0], after[0]) and before[1:] == after[1:]
    assert not [o for o in bpy.data.objects if o.name.endswith(("Crest Lines", "_control"))]


def test_new_objects_go_to_an_editable_collection(tmp_path):
    """A local mesh in an overridden collection: Multires Preview raised a traceback after writing its
    attributes and leaving an orphan control object; the crest curve failed the same way."""
    obj = _overridden_sphere(tmp_path)
    obj.make_local()
    obj.data = obj.data.copy()  # a local mesh in the overridden collection
    coll = obj.users_collection[0]
    assert coll.override_library is not None
    select(obj.name)
    assert bpy.ops.dgmesh.multires_preview('EXEC_DEFAULT', control_faces=200) == {'FINISHED'}
    assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', create_curves=True) == {'FINISHED'}
    made = [o for o in bpy.data.objects if o.name.endswith(("Crest Lines", "_control"))]
    assert len(made) == 2
    assert all(o.users_collection == (bpy.context.scene.collection,) for o in made)


def test_results_are_children_of_their_mesh():
    """The crest curve and the control cage copied the mesh's matrix_world: a parent's shear was
    lost (points up to 1.75 off a size-2 cube) and they stayed behind when the mesh moved."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_cube_add(size=2)
    obj = bpy.context.active_object
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.subdivide(number_cuts=6)
    bpy.ops.object.mode_set(mode='OBJECT')
    empty = bpy.data.objects.new("E", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.scale = (3, 1, 1)
    obj.parent = empty
    obj.rotation_euler = (0, 0, np.pi / 4)  # rotated under a non-uniform scale: a sheared world matrix
    select(obj.name)
    assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', create_curves=True) == {'FINISHED'}
    assert bpy.ops.dgmesh.multires_preview('EXEC_DEFAULT', control_faces=50) == {'FINISHED'}
    curve = bpy.data.objects[f"{obj.name} Crest Lines"]
    ctrl = bpy.data.objects[f"{obj.name}_control"]
    for moved in (False, True):
        if moved:
            empty.location = (10, 0, 0)
            # A control object of an earlier run is reused: it is placed the same way.
            ctrl.parent, ctrl.matrix_world = None, ctrl.matrix_world.copy()
            assert bpy.ops.dgmesh.multires_preview('EXEC_DEFAULT', control_faces=50) == {'FINISHED'}
            assert bpy.data.objects[f"{obj.name}_control"] == ctrl
        bpy.context.view_layer.update()
        for child in (curve, ctrl):
            assert child.parent == obj
            assert np.allclose(np.array(child.matrix_world), np.array(obj.matrix_world), atol=1e-6)


def _vertex_child(obj, index, name="Child"):
    child = bpy.data.objects.new(name, None)
    bpy.context.scene.collection.objects.link(child)
    child.parent = obj
    child.parent_type = 'VERTEX'
    child.parent_vertices = (index, 0, 0)
    return child


def _hook(obj, indices):
    target = bpy.data.objects.new("HookTarget", None)
    bpy.context.scene.collection.objects.link(target)
    mod = obj.modifiers.new("Hook", 'HOOK')
    mod.object = target
    mod.vertex_indices_set(indices)
    return mod


def test_feature_decimate_remaps_vertex_parents_and_hooks():
    """The decimated mesh is renumbered: a vertex-parented child pointed at an index that was now
    another vertex 1.6 units away, and hooks at indices beyond the mesh."""
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = _sphere("S", 4)
    far = int(np.argmax(_co(obj.data)[:, 2]))  # the north pole
    pole = _co(obj.data)[far].copy()
    child = _vertex_child(obj, far)
    hook = _hook(obj, [far, len(obj.data.vertices) - 1])
    select(obj.name)
    assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=0.3) == {'FINISHED'}
    co = _co(obj.data)
    j = child.parent_vertices[0]
    assert j < len(co) and np.linalg.norm(co[j] - pole) < 0.2
    assert len(hook.vertex_indices) and max(hook.vertex_indices) < len(co)
    assert np.linalg.norm(co[list(hook.vertex_indices)] - pole, axis=1).min() < 0.2


def test_remesh_region_remaps_vertex_parents_and_hooks():
    """Edit-mode Remesh of a patch deletes its inner vertices: a child parented to a vertex far
    from the patch jumped into it, and a hook dragged the wrong vertices."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=30, y_subdivisions=30, size=2)
    obj = bpy.context.active_object
    co = _co(obj.data)
    corner = int(np.argmin(co[:, 0] + co[:, 1]))  # far from the patch, after its inner vertices
    inner = int(np.argmin(np.linalg.norm(co - [0.05, 0.05, 0], axis=1)))  # removed by the remesh
    child = _vertex_child(obj, corner)
    child_in = _vertex_child(obj, inner, "ChildIn")
    hook = _hook(obj, [corner, inner])
    corner_co, inner_co = co[corner].copy(), co[inner].copy()
    patch = np.linalg.norm(co[:, :2], axis=1) < 0.5
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='DESELECT')
    bpy.ops.object.mode_set(mode='OBJECT')
    obj.data.vertices.foreach_set("select", patch)
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_mode(type='VERT')
    assert bpy.ops.dgmesh.remesh('EXEC_DEFAULT', target_vertices=120) == {'FINISHED'}
    bpy.ops.object.mode_set(mode='OBJECT')
    co = _co(obj.data)
    assert len(co) != 31 * 31
    assert np.array_equal(co[child.parent_vertices[0]], corner_co)
    assert np.linalg.norm(co[child_in.parent_vertices[0]] - inner_co) < 0.2
    hooked = co[list(hook.vertex_indices)]
    assert np.equal(hooked, corner_co).all(1).any()
    assert np.linalg.norm(hooked - inner_co, axis=1).min() < 0.2


def _mirrored_half():
    """A noisy sphere cut at x = 0, modelled as a half with a Mirror modifier (Merge, Clipping)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = _sphere("Half", 4)
    co = _co(obj.data)
    rng = np.random.default_rng(0)
    co += 0.02 * rng.standard_normal((len(co), 1)) * co
    obj.data.vertices.foreach_set("co", co.ravel())
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    bpy.ops.mesh.bisect(plane_co=(0, 0, 0), plane_no=(1, 0, 0), clear_inner=True)
    bpy.ops.object.mode_set(mode='OBJECT')
    co = _co(obj.data)
    co[np.abs(co[:, 0]) < 1e-5, 0] = 0.0
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    mod = obj.modifiers.new("Mirror", 'MIRROR')
    mod.use_clip = mod.use_mirror_merge = True
    select(obj.name)
    return obj


def _open_and_nonmanifold_edges(obj):
    import bmesh
    dg = bpy.context.evaluated_depsgraph_get()
    me = obj.evaluated_get(dg).to_mesh()
    bm = bmesh.new()
    bm.from_mesh(me)
    counts = (sum(e.is_boundary for e in bm.edges), sum(len(e.link_faces) > 2 for e in bm.edges))
    bm.free()
    obj.evaluated_get(dg).to_mesh_clear()
    return counts


def test_feature_decimate_keeps_a_mirrored_half_closed():
    """Collapses made faces with three corners on the mirror plane: the face and its mirror twin
    coincide, and the mirrored mesh had 14 open and 5 non-manifold edges at ratio 0.3."""
    obj = _mirrored_half()
    assert _open_and_nonmanifold_edges(obj) == (0, 0)
    for ratio in (0.3, 0.1):
        assert bpy.ops.dgmesh.decimate_features('EXEC_DEFAULT', ratio=ratio) == {'FINISHED'}
        assert _open_and_nonmanifold_edges(obj) == (0, 0)


def test_remesh_keeps_a_mirrored_half_closed():
    """A kept boundary along the mirror plane: triangles of three boundary vertices in a row lay in
    the plane, on their mirror twins; the mirrored mesh had 4 open and 2 non-manifold edges."""
    obj = _mirrored_half()
    for target in (300, 800):
        assert bpy.ops.dgmesh.remesh('EXEC_DEFAULT', target_vertices=target) == {'FINISHED'}
        co = _co(obj.data)
        F = np.array([p.vertices[:] for p in obj.data.polygons])
        assert not (np.abs(co[F][:, :, 0]) < 1e-6).all(1).any()
        assert _open_and_nonmanifold_edges(obj) == (0, 0)
        obj = _mirrored_half()


def test_shown_shape_notes():
    """The mesh datablock in object space is what the operators read; a shown shape key mix or a
    non-uniform scale made Crest Lines find nothing on a sphere shown as a lens, without a word."""
    from dgmesh.blender.common import shown_shape_notes
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = _sphere("S", 2)
    assert shown_shape_notes(obj) == []
    obj.scale = (1, 1, 0.15)
    bpy.context.view_layer.update()
    assert [n for n in shown_shape_notes(obj) if "non-uniform scale" in n]
    obj.scale = (-2, 2, 2)  # mirrored but uniform
    bpy.context.view_layer.update()
    assert shown_shape_notes(obj) == []
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="Lens")
    key.value = 0.0  # 5.x starts a new key at 1.0 (3.4/4.x at 0.0)
    assert shown_shape_notes(obj) == []  # a key at value 0 does not change the shown shape
    key.value = 1.0
    assert [n for n in shown_shape_notes(obj) if "shape keys" in n]
    key.mute = True
    assert shown_shape_notes(obj) == []


@pytest.mark.parametrize("op", sorted(set(MESH_OPERATORS) | {"unwrap"}))
def test_every_reading_operator_reports_the_shown_shape(op, monkeypatch):
    import importlib
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = _sphere("S", 3)
    if op in ("remesh", "unwrap"):  # one disk-like chart
        bpy.ops.object.mode_set(mode='EDIT')
        bpy.ops.mesh.select_all(action='DESELECT')
        bpy.ops.object.mode_set(mode='OBJECT')
        obj.data.vertices.foreach_set("select", _co(obj.data)[:, 2] > 0.3)
        bpy.ops.object.mode_set(mode='EDIT')
    seen = []
    for name in ("ops_crest", "ops_curvature", "ops_denoise", "ops_fair", "ops_multires", "ops_remesh",
                 "ops_unwrap"):
        module = importlib.import_module(f"dgmesh.blender.{name}")
        monkeypatch.setattr(module, "report_shown_shape", lambda _op, objs: seen.extend(o.name for o in objs))
    assert getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **MESH_OPERATORS.get(op, {})) == {'FINISHED'}
    assert seen == ["S"]


@pytest.mark.parametrize("op", ["multires_preview", "similarity_map"])
def test_active_object_operators_refuse_a_hidden_active_object(op, capsys):
    """A hidden object stays the active one (the eye icon keeps it active); the operators that act on
    the active object refuse it, as Blender's own do, instead of changing what the user cannot see."""
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = _sphere("S", 2)
    obj.hide_set(True)
    assert bpy.context.active_object == obj
    assert not getattr(bpy.ops.dgmesh, op).poll()
    with pytest.raises(RuntimeError, match="hidden"):
        getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **MESH_OPERATORS[op])
    assert not [a for a in obj.data.attributes if a.name.startswith("dg_")]
    obj.hide_set(False)
    assert getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **MESH_OPERATORS[op]) == {'FINISHED'}
