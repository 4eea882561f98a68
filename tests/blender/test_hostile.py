"""Every dgmesh operator in hostile scenes (issue #34): no Python traceback out of an operator, and
an operator that fails (an error report, CANCELLED) leaves the mesh, its UV maps and custom
properties byte-identical. One test per (operator, scene)."""

import math

import bmesh
import bpy
import pytest

from helpers import add_armature, mesh_snapshot

OPERATORS = sorted(name for name in dir(bpy.ops.dgmesh) if not name.startswith("_"))
KWARGS = {"skeletal_bake": {"filepath": bpy.app.tempdir + "hostile_bake.pc2", "frame_start": 1, "frame_end": 2},
          "remesh": {"target_vertices": 200}}


# Operators that need a disk (one boundary loop) get an open sphere: a closed one fails them first.
DISK_OPERATORS = ("remesh", "unwrap")
_base = {"open": False}


def _sphere(name="Hostile", subdivisions=2):
    """A small triangle mesh with a UV map, closed (open for DISK_OPERATORS), selected and active,
    beside a selected armature."""
    bpy.ops.wm.read_homefile(use_empty=True)
    me = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=subdivisions, radius=1.0, calc_uvs=False)
    if _base["open"]:
        bmesh.ops.delete(bm, geom=[f for f in bm.faces if f.calc_center_median().z > 0.7], context='FACES_ONLY')
    bm.to_mesh(me)
    bm.free()
    me.uv_layers.new(name="UVMap")
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    arm = add_armature([("Bone", (0, 0, -1), (0, 0, 1), None, False)])
    obj.select_set(True)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return obj


def _replace_mesh(obj, verts, edges=(), faces=()):
    me = obj.data
    me.clear_geometry()
    me.from_pydata([tuple(v) for v in verts], list(edges), [tuple(f) for f in faces])
    me.update()
    return obj


def _move_vertex(obj, index, co):
    obj.data.vertices[index].co = co
    obj.data.update()
    return obj


def no_active():
    obj = _sphere()
    bpy.context.view_layer.objects.active = None
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    return obj


def active_not_mesh():
    obj = _sphere()
    empty = bpy.data.objects.new("Empty", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.select_set(True)
    bpy.context.view_layer.objects.active = empty
    return obj


def empty_mesh():
    obj = _sphere()
    obj.data.clear_geometry()
    return obj


def loose_vertices():
    return _replace_mesh(_sphere(), [(0, 0, 0), (1, 0, 0), (0, 1, 0)])


def loose_edges():
    return _replace_mesh(_sphere(), [(0, 0, 0), (1, 0, 0), (0, 1, 0)], edges=[(0, 1), (1, 2)])


def non_manifold():
    # Three triangles on one edge.
    return _replace_mesh(_sphere(), [(0, 0, 0), (0, 0, 1), (1, 0, 0), (-1, 0, 0), (0, 1, 0)],
                         faces=[(0, 1, 2), (1, 0, 3), (0, 1, 4)])


def ngons():
    obj = _sphere()
    bm = bmesh.new()
    bmesh.ops.create_cone(bm, cap_ends=True, cap_tris=False, segments=12, radius1=1, radius2=1, depth=2)
    bm.to_mesh(obj.data)
    bm.free()
    return obj


def zero_area_faces():
    obj = _sphere()
    a, b = obj.data.edges[0].vertices
    return _move_vertex(obj, a, obj.data.vertices[b].co.copy())


def duplicated_vertices():
    obj = _sphere()
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.split_edges(bm, edges=bm.edges[:])  # every face its own vertices
    bm.to_mesh(obj.data)
    bm.free()
    return obj


def nan_coordinates():
    return _move_vertex(_sphere(), 0, (math.nan, 0.0, 0.0))


def huge_coordinates():
    obj = _sphere()
    for v in obj.data.vertices:
        v.co *= 1e30
    obj.data.update()
    return obj


def edit_mode_nothing_selected():
    obj = _sphere()
    obj.data.vertices.foreach_set("select", [False] * len(obj.data.vertices))
    obj.data.edges.foreach_set("select", [False] * len(obj.data.edges))
    obj.data.polygons.foreach_set("select", [False] * len(obj.data.polygons))
    obj.select_set(True)
    bpy.ops.object.mode_set(mode='EDIT')
    return obj


def multi_user_mesh():
    obj = _sphere()
    twin = bpy.data.objects.new("Twin", obj.data)
    bpy.context.scene.collection.objects.link(twin)
    twin.location.x = 3
    twin.select_set(True)
    return obj


def modifiers():
    obj = _sphere(subdivisions=1)
    obj.modifiers.new("Subdivision", 'SUBSURF').levels = 1
    obj.modifiers.new("Mirror", 'MIRROR')
    return obj


def hidden_object():
    obj = _sphere()
    obj.hide_set(True)
    return obj


def negative_scale():
    obj = _sphere()
    obj.scale = (-1.0, 2.0, 0.5)
    return obj


def corrupted_custom_property():
    obj = _sphere()
    obj["dg_skeletal"] = 5
    return obj


def linked_from_library(tmp=[]):
    """The mesh object linked from another .blend (library data: read-only here), alone."""
    if not tmp:
        _sphere()
        path = bpy.app.tempdir + "dgmesh_hostile_library.blend"
        bpy.data.libraries.write(path, {bpy.data.objects["Hostile"]})
        tmp.append(path)
    bpy.ops.wm.read_homefile(use_empty=True)
    with bpy.data.libraries.load(tmp[0], link=True) as (_src, dst):
        dst.objects = ["Hostile"]
    obj = dst.objects[0]
    bpy.context.scene.collection.objects.link(obj)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return obj


def _bind_closed():
    was, _base["open"] = _base["open"], False
    obj = _sphere()
    _base["open"] = was
    assert bpy.ops.dgmesh.skeletal_bind('EXEC_DEFAULT') == {'FINISHED'}
    return obj


def bound():
    return _bind_closed()


def bound_then_opened():
    """Bound, then a face deleted: no longer bindable (Rebind must keep the binding)."""
    obj = _bind_closed()
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.delete(bm, geom=[next(iter(bm.faces))], context='FACES_ONLY')
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()
    return obj


def armature_without_deform_bones():
    obj = _sphere()
    for b in bpy.data.armatures["Rig"].bones:
        b.use_deform = False
    return obj


SCENES = {f.__name__: f for f in (
    no_active, active_not_mesh, empty_mesh, loose_vertices, loose_edges, non_manifold, ngons, zero_area_faces,
    duplicated_vertices, nan_coordinates, huge_coordinates, edit_mode_nothing_selected, multi_user_mesh,
    modifiers, hidden_object, negative_scale, corrupted_custom_property, linked_from_library, bound,
    bound_then_opened, armature_without_deform_bones)}


def _state(obj):
    """The mesh (geometry, UV maps, attributes), the object's modifiers and the custom properties of
    object and mesh, comparable."""
    def props(idblock):
        return {k: repr(v.to_dict() if hasattr(v, "to_dict") else v) for k, v in idblock.items()}

    return {"mesh": mesh_snapshot(obj.data), "props": props(obj), "mesh_props": props(obj.data),
            "modifiers": [(m.name, m.type, m.show_viewport) for m in obj.modifiers]}


def _object_mode_state(obj):
    if obj.mode == 'EDIT':
        bpy.ops.object.mode_set(mode='OBJECT')
    return _state(obj)


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("op", OPERATORS)
def test_operator_in_hostile_scene(op, scene):
    _base["open"] = op in DISK_OPERATORS
    obj = SCENES[scene]()
    edit = obj.mode == 'EDIT'
    if edit:  # the snapshot reads the mesh datablock: take it from a round trip out of Edit mode
        bpy.ops.object.mode_set(mode='OBJECT')
        before = _state(obj)
        bpy.ops.object.mode_set(mode='EDIT')
    else:
        before = _state(obj)
    try:
        result = getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **KWARGS.get(op, {}))
    except RuntimeError as exc:  # an error report, or a poll that refused
        message = str(exc)
        assert "Traceback" not in message, message
        if "poll()" not in message and not edit:  # an error report says which object
            assert repr(obj.name) in message, message
        result = {'CANCELLED'}
    assert result <= {'FINISHED', 'CANCELLED'}
    if result == {'CANCELLED'}:
        assert _object_mode_state(obj) == before


def test_object_mode_unwrap_of_a_faceless_mesh_says_it_has_no_faces(capfd):
    """It said "select faces in Edit mode", which does not help in Object mode."""
    obj = loose_edges()
    assert bpy.ops.dgmesh.unwrap('EXEC_DEFAULT') == {'CANCELLED'}
    out = capfd.readouterr().out
    assert f"'{obj.name}' has no faces" in out and "Edit mode" not in out
