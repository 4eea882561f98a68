"""Blender side of the skeletal deformation: bind, live update by frame_set, save/reload, unbind,
bake to a Mesh Cache, error cases."""

import math

import bpy
import numpy as np
import pytest

from dgmesh.skeletal import capsule


def _mesh_co(mesh):
    a = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", a)
    return a.reshape(-1, 3)


def _key_co(obj, name="dg_skeletal"):
    kb = obj.data.shape_keys.key_blocks[name]
    a = np.empty(len(kb.data) * 3, dtype=np.float32)
    kb.data.foreach_get("co", a)
    return a.reshape(-1, 3)


def _evaluated_co(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    me = ev.to_mesh()
    try:
        return _mesh_co(me).copy()
    finally:
        ev.to_mesh_clear()


def _scene(groups=True, with_modifier=True):
    bpy.ops.wm.read_homefile(use_empty=True)
    V, F = capsule(0.5, 6.0, 24, 5, 32)
    me = bpy.data.meshes.new("Capsule")
    me.from_pydata([tuple(v) for v in V], [], [tuple(int(i) for i in f) for f in F])
    me.update()
    obj = bpy.data.objects.new("Capsule", me)
    bpy.context.scene.collection.objects.link(obj)
    ad = bpy.data.armatures.new("Rig")
    arm = bpy.data.objects.new("Rig", ad)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    b1 = ad.edit_bones.new("Upper")
    b1.head, b1.tail = (-3.5, 0, 0), (0, 0, 0)
    b2 = ad.edit_bones.new("Lower")
    b2.head, b2.tail = (0, 0, 0), (3.5, 0, 0)
    b2.parent = b1
    b2.use_connect = True
    bpy.ops.object.mode_set(mode='OBJECT')
    if groups:
        g1, g2 = obj.vertex_groups.new(name="Upper"), obj.vertex_groups.new(name="Lower")
        t = np.clip((V[:, 0] + 0.5) / 1.0, 0, 1)  # linear blend over [-0.5, 0.5]
        for i in range(len(V)):
            if t[i] < 1:
                g1.add([i], float(1 - t[i]), 'REPLACE')
            if t[i] > 0:
                g2.add([i], float(t[i]), 'REPLACE')
    if with_modifier:
        m = obj.modifiers.new("Armature", 'ARMATURE')
        m.object = arm
    for o in bpy.context.view_layer.objects:
        o.select_set(o in (obj, arm))
    bpy.context.view_layer.objects.active = obj
    return obj, arm, V


def _bind(**kw):
    return bpy.ops.dgmesh.skeletal_bind('EXEC_DEFAULT', **kw)


def _pose_lower(arm, angle, frame=None, axis='Z'):
    pb = arm.pose.bones["Lower"]
    pb.rotation_mode = 'XYZ'
    e = [0.0, 0.0, 0.0]
    # Bone space: Y is along the bone; the world Z axis is the bone's Z here.
    e["XYZ".index(axis)] = angle
    pb.rotation_euler = e
    if frame is not None:
        pb.keyframe_insert("rotation_euler", frame=frame)


def test_bind_live_update_unbind():
    obj, arm, V = _scene()
    assert _bind() == {'FINISHED'}
    assert "dg_skeletal" in obj.keys()
    assert obj.modifiers["Armature"].show_viewport is False
    assert np.abs(_key_co(obj) - V).max() < 1e-5  # rest pose
    sk = bpy.data.objects[obj.name + "_skeleton"]
    assert "dg_radius_color" in sk.data.attributes
    _pose_lower(arm, 0.0, frame=1)
    _pose_lower(arm, math.pi / 2, frame=10)
    bpy.context.scene.frame_set(10)
    X = _key_co(obj)
    # The far end follows the bent bone: x -> y.
    tip = np.argmax(V[:, 0])
    assert abs(X[tip, 0]) < 0.05 and abs(X[tip, 1] - 3.5) < 0.05
    # Thickness: distance to the bent bones stays near the rest distance (0.5 on the cylinder).
    b2 = np.c_[np.zeros(len(X)), np.clip(X[:, 1], 0, 3.5), np.zeros(len(X))]
    d_lower = np.linalg.norm(X - b2, axis=1)
    b1 = np.c_[np.clip(X[:, 0], -3.5, 0), np.zeros(len(X)), np.zeros(len(X))]
    d = np.minimum(d_lower, np.linalg.norm(X - b1, axis=1))
    cyl = (np.abs(V[:, 0]) < 3.0)
    assert d[cyl].min() > 0.5 * 0.7  # 2 fairing steps with these blended groups (LBS: ~0.5)
    ev = _evaluated_co(obj)
    assert np.abs(ev - X).max() < 1e-4  # the shape key is what renders
    bpy.context.scene.frame_set(1)
    assert np.abs(_key_co(obj) - V).max() < 1e-4
    assert bpy.ops.dgmesh.skeletal_unbind('EXEC_DEFAULT') == {'FINISHED'}
    assert obj.data.shape_keys is None
    assert obj.modifiers["Armature"].show_viewport is True
    assert "dg_skeletal" not in obj.keys()
    assert obj.name + "_skeleton" not in bpy.data.objects
    assert np.array_equal(_mesh_co(obj.data), V.astype(np.float32))


def test_save_reload_bound(tmp_path):
    obj, arm, V = _scene()
    assert _bind() == {'FINISHED'}
    _pose_lower(arm, 0.0, frame=1)
    _pose_lower(arm, math.pi, frame=10, axis='Y')  # twist
    path = str(tmp_path / "bound.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.context.scene.frame_set(10)
    before = _key_co(obj).copy()
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Capsule"]
    assert "dg_skeletal" in obj.keys()
    bpy.context.scene.frame_set(1)
    bpy.context.scene.frame_set(10)
    assert np.abs(_key_co(obj) - before).max() < 1e-5
    # Twist keeps thickness: radial distance from the x axis.
    r = np.hypot(before[:, 1], before[:, 2])
    cyl = np.abs(V[:, 0]) < 3.0
    assert r[cyl].min() > 0.45


def test_bake_then_unbind_plays_cache(tmp_path):
    obj, arm, V = _scene()
    assert _bind() == {'FINISHED'}
    _pose_lower(arm, 0.0, frame=1)
    _pose_lower(arm, math.pi / 2, frame=5)
    path = str(tmp_path / "anim.pc2")
    assert bpy.ops.dgmesh.skeletal_bake('EXEC_DEFAULT', filepath=path, frame_start=1, frame_end=5) == {'FINISHED'}
    bpy.context.scene.frame_set(5)
    baked = _key_co(obj).copy()
    assert bpy.ops.dgmesh.skeletal_unbind('EXEC_DEFAULT') == {'FINISHED'}
    assert "dg_skeletal_cache" in obj.modifiers
    obj.modifiers["Armature"].show_viewport = False  # compare the cache alone
    bpy.context.scene.frame_set(1)
    bpy.context.scene.frame_set(5)
    assert np.abs(_evaluated_co(obj) - baked).max() < 1e-4
    assert np.array_equal(_mesh_co(obj.data), V.astype(np.float32))


def test_errors():
    obj, arm, V = _scene()
    # no armature
    arm.select_set(False)
    obj.modifiers.remove(obj.modifiers["Armature"])
    with pytest.raises(RuntimeError, match="No armature"):
        _bind()
    arm.select_set(True)
    # no deform bones
    for b in arm.data.bones:
        b.use_deform = False
    with pytest.raises(RuntimeError, match="no deform bones"):
        _bind()
    for b in arm.data.bones:
        b.use_deform = True
    # unweighted region
    obj.vertex_groups["Upper"].remove([i for i in range(len(V)) if V[i, 0] < -2])
    with pytest.raises(RuntimeError, match="no weight"):
        _bind()
    assert "dg_skeletal" not in obj.keys() and obj.data.shape_keys is None
    # binding twice
    obj.vertex_groups.clear()
    assert _bind() == {'FINISHED'}
    with pytest.raises(RuntimeError, match="already bound"):
        _bind()
    bpy.ops.dgmesh.skeletal_unbind('EXEC_DEFAULT')
    # open mesh
    me = bpy.data.meshes.new("Open")
    me.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)], [], [(0, 1, 3, 2)])
    op = bpy.data.objects.new("Open", me)
    bpy.context.scene.collection.objects.link(op)
    bpy.context.view_layer.objects.active = op
    op.select_set(True)
    before = _mesh_co(me).copy()
    with pytest.raises(RuntimeError, match="open"):
        _bind()
    assert np.array_equal(_mesh_co(me), before) and me.shape_keys is None
    # unbind / bake of an unbound mesh
    with pytest.raises(RuntimeError, match="not bound"):
        bpy.ops.dgmesh.skeletal_unbind('EXEC_DEFAULT')
