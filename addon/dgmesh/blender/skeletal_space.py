"""The space a skeletal rig works in: bone frames as the Armature modifier applies them, and the
maps between a bound mesh's object space and the rig's (the armature's, when the mesh's transform
relative to it is not a similarity)."""

import mathutils
import numpy as np


# The rig-space maps call no numpy.linalg and no large matrix product: Debian's numpy runs them on
# OpenBLAS, which threads even a 4x4 inverse (dgetrs) and whose worker then spin-waits (sched_yield)
# for ~0.1 s on the cores the native deform's OpenMP loops need (measured: the deform in the frame
# handler at 30-40 ms instead of 15-19 ms). Blender's mathutils and numpy's elementwise loops do not.
def inverse(M):
    """Inverse of a 4x4 matrix (array), without LAPACK."""
    return np.array(mathutils.Matrix(M.tolist()).inverted())


def transformed(P, M):
    """Points (n, 3) mapped by the 4x4 affine matrix M, in P's dtype, without BLAS."""
    M = M.astype(P.dtype)
    out = P[:, :1] * M[:3, 0]
    out += P[:, 1:2] * M[:3, 1]
    out += P[:, 2:3] * M[:3, 2]
    out += M[:3, 3]
    return out


def pose_matrices(mesh_obj, arm, names, rest=False, space=None, bind=None):
    """Bone frames in the rig's space (the mesh's object space, or ``space`` (4x4) times it).

    Rest: the bones' rest frames. Pose: each bone's motion as the Armature modifier applies it,
    D = T P R^-1 T^-1 (T: armature -> rig space now, P/R: pose/rest frame in armature space), times
    the rig's rest frame T_bind R (``bind``: the armature -> mesh map at bind time; None = now). So
    moving the mesh object or the armature object later moves the mesh as Blender's modifier would
    (it stayed where it was bound). A pose-bone scale stays in D: the rig's linear blend of the
    skeleton follows it, the thickness does not (making D rigid, each head kept where D puts it,
    measured worse: a parent bone scaled 0.5 stretched edges 7.4x against 2.3x)."""
    S = np.eye(4) if space is None else space
    T = S @ np.array(mesh_obj.matrix_world.inverted() @ arm.matrix_world)  # armature -> rig space now
    T_bind = T if bind is None else S @ bind
    T_inv = inverse(T)
    out = np.empty((len(names), 4, 4))
    for j, name in enumerate(names):
        bone = arm.data.bones[name]
        R = np.array(bone.matrix_local)
        if rest:
            out[j] = T @ R
        else:
            R_inv = np.array(bone.matrix_local.inverted())
            out[j] = T @ np.array(arm.pose.bones[name].matrix) @ R_inv @ T_inv @ T_bind @ R
    return out


def rig_space(obj, arm):
    """None when the mesh's object space suits the rig: its transform relative to the armature is a
    similarity, so the bone frames stay rigid in it. Otherwise (non-uniform or negative scale left
    unapplied) the 4x4 map from the mesh's object space to the armature's, in which the rig works:
    bone frames there are rigid, and the mesh keeps its shape as the Armature modifier shows it."""
    A = np.array(arm.matrix_world.inverted() @ obj.matrix_world)
    M = A[:3, :3]
    G = M.T @ M
    s2 = np.trace(G) / 3
    if np.linalg.det(M) > 0 and np.abs(G - s2 * np.eye(3)).max() <= 1e-6 * s2:
        return None
    return A


def stored_space(info):
    """The 4x4 map from the mesh's object space to the rig's stored at bind (``rig_space``), or None."""
    sp = info.get("space")
    return None if sp is None else np.array(sp, dtype=float).reshape(4, 4)
