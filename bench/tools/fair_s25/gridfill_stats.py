"""Blender (run: blender --background --factory-startup --python bench/tools/fair_s25/gridfill_stats.py):
tests/blender/test_fair.py's Grid Fill of a UV sphere's side hole (x > 0.7 R) and the statistics the
session-25 start selector tried (mean face area of the faces with a movable vertex over the ring's
around them; largest distance of the movable vertices from the rim's least-squares plane over the
rim's mean radius). Movable: selected vertices whose polygons are all selected."""
import sys
from pathlib import Path

import bmesh
import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "addon"))
from dgmesh.blender import bridge  # noqa: E402

bpy.ops.wm.read_homefile(use_empty=True)
bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=1.0)
obj = bpy.context.object
bpy.ops.object.mode_set(mode='EDIT')
bm = bmesh.from_edit_mesh(obj.data)
for v in bm.verts:
    v.select = v.co.x > 0.7
bm.select_flush(True)
bmesh.update_edit_mesh(obj.data)
bpy.ops.mesh.delete(type='VERT')
bpy.ops.mesh.select_all(action='DESELECT')
bpy.ops.mesh.select_non_manifold()
bpy.ops.mesh.fill_grid()
bpy.ops.object.mode_set(mode='OBJECT')
F = bridge.read_object(obj).F
V = np.array([v.co[:] for v in obj.data.vertices])
sel = np.array([v.select for v in obj.data.vertices])
border = np.zeros(len(V), bool)
for p in obj.data.polygons:
    if not p.select:
        border[list(p.vertices)] = True
mov = sel & ~border
reg = mov[F].any(1)
ring = np.zeros(len(V), bool)
ring[F[reg].ravel()] = True
around = ring[F].any(1) & ~reg
A = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
rim = ring & ~mov
c = V[rim].mean(0)
nrm = np.linalg.svd(V[rim] - c)[2][2]
print(f"movable {int(mov.sum())}, area ratio {A[reg].mean() / A[around].mean():.2f}, off the rim's plane "
      f"{np.abs((V[mov] - c) @ nrm).max() / np.linalg.norm(V[rim] - c, axis=1).mean():.2f} rim radii")
