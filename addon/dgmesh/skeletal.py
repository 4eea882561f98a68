"""Skeleton-driven, thickness-preserving deformation (thesis chapter 6).

A closed mesh is represented around its skeletal mesh (Voronoi poles with the mesh's connectivity,
one per vertex) and medial-ball radii: M = S + d N (eq. 6.1). Posing bones deforms the skeletal
mesh by skeletal subspace deformation (eq. 6.2); the surface is rebuilt around it so that its
thickness (distance to the skeleton) is kept, which avoids the collapsing joints and candy wrappers
of linear blend skinning.

    rig = dgmesh.SkeletalRig.bind(V, F, bones_rest, weights)
    V_posed = rig.deform(bones_pose)

Bone frames are (B, 4, 4) matrices in the mesh's object space, as Blender gives them
(``armature_world_inv @ pose_bone.matrix`` mapped into the mesh's space): columns X, Y (along the
bone), Z and the head. Dense meshes (more faces than ``control_faces``) go through the
multiresolution layer: the skeletal machinery runs on a decimated control mesh.
"""

import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from .core import MeshError, Progress, _native, as_choice, as_count, as_faces, as_flag, as_real, as_vertices, make_options

__all__ = [
    "SkeletalRig",
    "SkeletalRigOptions",
    "SkeletalDeformOptions",
    "RingWeightOptions",
    "SkeletalMethod",
    "SkeletalMesh",
    "SkeletonOptions",
    "skeletal_mesh",
    "union_of_balls_distance",
    "self_intersecting_pairs",
    "gaussian_bone_weights",
    "skeletal_subspace_deform",
    "ring_weights",
    "delaunay_3d",
    "delaunay_2d",
    "METHODS",
]

# The contract is the C++ one (dgmesh/skeletal.h), bound as it is: the options of the skeletal
# mesh, of bind, of deform and of the ring weights with their defaults, the deformation method and the skeletal mesh.
SkeletonOptions = _native.SkeletonOptions
SkeletalRigOptions = _native.SkeletalRigOptions
SkeletalDeformOptions = _native.SkeletalDeformOptions
RingWeightOptions = _native.RingWeightOptions
SkeletalMethod = _native.SkeletalMethod
SkeletalMesh = _native.SkeletalMesh

METHODS = tuple(SkeletalMethod.__members__)

_SKELETON = SkeletonOptions()
_BIND = SkeletalRigOptions()
_DEFORM = SkeletalDeformOptions()
_RING = RingWeightOptions()


def _mats(M, name, B=None):
    M = np.ascontiguousarray(M, dtype=np.float64)
    if M.ndim == 2 and M.shape == (4, 4):
        M = M[None]
    if M.ndim != 3 or M.shape[1:] != (4, 4):
        raise MeshError(f"{name} must have shape (B, 4, 4), got {M.shape}")
    if B is not None and len(M) != B:
        raise MeshError(f"{name}: expected {B} bone matrices, got {len(M)}")
    if not np.all(np.isfinite(M)):
        raise MeshError(f"{name} must be finite")
    return M


def _default_segments(bones_rest, V):
    """Bone segments from the frames: head = translation, direction = Y axis; the length reaches
    the next head along the axis, or else the mesh's extent along it."""
    heads = bones_rest[:, :3, 3].copy()
    axes = bones_rest[:, :3, 1] / np.maximum(np.linalg.norm(bones_rest[:, :3, 1], axis=1, keepdims=True), 1e-300)
    tails = np.empty_like(heads)
    for j in range(len(heads)):
        rel = heads - heads[j]
        along = rel @ axes[j]
        off = np.linalg.norm(rel - along[:, None] * axes[j], axis=1)
        cand = [along[k] for k in range(len(heads)) if k != j and along[k] > 1e-9 and off[k] < 0.25 * along[k]]
        length = min(cand) if cand else max(float(np.max((V - heads[j]) @ axes[j])), 1e-6)
        tails[j] = heads[j] + length * axes[j]
    return heads, tails


class SkeletalRig:
    """A mesh bound to a set of bones. Create with :meth:`bind` or :meth:`from_arrays`."""

    def __init__(self, native: _native.SkeletalRig) -> None:
        self._rig = native

    @classmethod
    def bind(
        cls,
        V: npt.ArrayLike,
        F: npt.ArrayLike,
        bones_rest: npt.ArrayLike,
        weights: npt.ArrayLike | None = None,
        *,
        bone_heads: npt.ArrayLike | None = None,
        bone_tails: npt.ArrayLike | None = None,
        control_faces: int = _BIND.control_faces,
        multires_level: int = _BIND.multires_level,
        fit_iterations: int = _BIND.multires_fit_iterations,
        gaussian_sigma: float = _BIND.gaussian_sigma,
        frame_regularization: float = _BIND.frame_regularization,
        presmooth_iterations: int = _BIND.skeleton.presmooth_iterations,
        postsmooth_iterations: int = _BIND.skeleton.postsmooth_iterations,
        progress: Progress | None = None,
    ) -> "SkeletalRig":
        """Binds a closed manifold mesh (V, F) to bones.

        bones_rest: (B, 4, 4) rest frames in the mesh's object space.
        weights: (n, B) per-vertex bone weights (e.g. vertex groups), or None for normalised
            Gaussian weights of the distance of the skeletal vertices to the bone segments.
        bone_heads, bone_tails: (B, 3), the stick skeleton: the segments the bone clearances, the
            joint contact and the twist axes measure against (kept in the bind data); the frames
            give only the motion (pose @ inv(rest)). Default: from the frames, head = translation,
            direction = Y axis (Blender's convention; see ``_default_segments``), which is wrong
            for frames that do not follow it, e.g. identity rest frames: pass the segments then.
        control_faces: meshes with more faces go through the multiresolution layer with a control
            mesh of about this many faces.
        gaussian_sigma: width of the Gaussian weights (0: a fifth of the median medial radius).
        frame_regularization: weight of the bone rotation in the frames of degenerate skeletal
            triangles (relative to the squared skeletal edge length).
        progress: callable(fraction) -> bool|None; returning False raises dgmesh.Cancelled.
        Defaults: ``SkeletalRigOptions()`` (``fit_iterations`` is its ``multires_fit_iterations``,
        the smoothing iterations its ``skeleton``'s).

        Raises MeshError for open or non-manifold meshes, loose vertices, vertices without weight,
        and malformed bones.
        """
        V = as_vertices(V)
        F = as_faces(F, n=len(V))
        if len(V) == 0:
            raise MeshError("skeletal bind: the mesh is empty")
        R = _mats(bones_rest, "bones_rest")
        if len(R) == 0:
            raise MeshError("skeletal bind: no deform bones")
        W = None
        if weights is not None:
            W = np.ascontiguousarray(weights, dtype=np.float64)
            if W.ndim == 1 and len(R) == 1:
                W = W[:, None]
            if W.shape != (len(V), len(R)):
                raise MeshError(f"weights must have shape ({len(V)}, {len(R)}), got {W.shape}")
        heads = tails = None  # with weights and no segments: the native rig takes them from the frames
        if W is None or bone_heads is not None or bone_tails is not None:
            if bone_heads is None or bone_tails is None:
                h, t = _default_segments(R, V)
                bone_heads = h if bone_heads is None else bone_heads
                bone_tails = t if bone_tails is None else bone_tails
            heads = as_vertices(bone_heads, "bone_heads")
            tails = as_vertices(bone_tails, "bone_tails")
            if len(heads) != len(R) or len(tails) != len(R):
                raise MeshError("bone_heads and bone_tails must have one row per bone")
        o = make_options(
            SkeletalRigOptions(), control_faces=as_count(control_faces, "control_faces"),
            multires_level=as_count(multires_level, "multires_level"),
            multires_fit_iterations=as_count(fit_iterations, "fit_iterations"),
            gaussian_sigma=as_real(gaussian_sigma, "gaussian_sigma", 0.0),
            frame_regularization=as_real(frame_regularization, "frame_regularization", 0.0))
        make_options(o.skeleton, presmooth_iterations=as_count(presmooth_iterations, "presmooth_iterations"),
                     postsmooth_iterations=as_count(postsmooth_iterations, "postsmooth_iterations"))
        return cls(_native.SkeletalRig.bind(V, F, R, W, heads, tails, o, progress))

    def deform(self, bones_pose: npt.ArrayLike, *, fairing_steps: int = _DEFORM.fairing_steps,
               method: str | SkeletalMethod = _DEFORM.method.name, fairing_step: float = _DEFORM.fairing_step,
               homotopy_steps: int = _DEFORM.homotopy_steps, fold_iterations: int = _DEFORM.fold_iterations,
               projection: float = _DEFORM.projection, out: np.ndarray | None = None,
               dual_quaternion: bool = _DEFORM.dual_quaternion,
               integrate_skeleton: bool = _DEFORM.integrate_skeleton, ring_twist: bool = _DEFORM.ring_twist,
               joint_fillet: float = _DEFORM.joint_fillet, bone_clearance: float = _DEFORM.bone_clearance,
               contact_slide: float = _DEFORM.contact_slide,
               untangle_iterations: int = _DEFORM.untangle_iterations,
               untangle_rings: int = _DEFORM.untangle_rings, follow_twist: bool = _DEFORM.follow_twist,
               fold_guard: int = _DEFORM.fold_guard, skeleton: npt.ArrayLike | None = None) -> np.ndarray:
        """Deformed vertex positions (n, 3) for the pose frames (B, 4, 4).

        method: "variational" (thesis 6.5, eq. 6.8-6.12, then ``fairing_steps`` steps of the
        shape-preserving self-intersection fairing eq. 6.15, then an explicit step of weight
        ``projection`` that moves each vertex nearer the union of medial balls than at rest out
        towards its rest distance (one-sided: flesh a bend squeezes out of the union bulges), repeated
        in up to 8 passes (3 on a dense mesh through the layer) over the vertices it still moves,
        0 = off) or
        "basic" (thesis 6.3: homotopy with ``homotopy_steps`` steps, ``fold_iterations`` steps of
        eq. 6.5, 5 * ``fairing_steps`` of eq. 6.6). Through the multiresolution layer the dense
        vertices get the same explicit ``projection`` step against the control mesh's medial balls
        (variational method with fairing on): the layer's limit surface thins where a pose shears
        the coarse control triangles.
        ``dual_quaternion``: pose the skeletal mesh by dual quaternion blending of the bone motions
        (rigid per skeletal vertex; default) or, False, by the linear blend of eq. 6.2, which pulls
        skeletal vertices that lie off a bone's axis towards it under a twist: where a limb's medial
        surface is a sheet (most scanned limbs) the sheet collapses halfway through the joint's
        blend and the mesh rebuilt on it tears open there; about even in a bend (see
        bench/RESULTS.md). Either way the posed skeletal vertices are then pushed back out to their
        rest distance from the posed bone segments they have weight on (the stick skeleton of
        :meth:`bind`), which undoes most of the blend's pull towards the bones in a joint's inner
        crease.
        ``integrate_skeleton`` (default True): then rebuild the posed skeletal mesh from its rest
        edges, each turned by its ends' mean blended rotation and stretched as a beam's (its offset
        from the stick skeleton turned with its ends; least squares, as eq. 6.11 rebuilds the
        surface), held where one bone moves a vertex alone and anchored softly to those positions
        where one bone dominates (largest weight above 0.9). The blend alone swings the skeletal
        vertices behind a joint backwards, and the posed axis turns by up to twice the bend inside
        the blend; the union of balls then has a concave corner in the crease that the thickness
        steps fold the surface into (e.g. skeletal_joints' capsule bent 90 degrees through the
        layer: 218 crossing pairs without, 83 with; DQS 95). The posed axis then cuts the joint's
        corner (its vertices keep at least half their rest distance from their bones), so the bone
        clearance pushes more of the outer side back out (bench/notes/skeletal.md, sessions 32-33).
        Not applied where ``follow_twist`` acts.
        ``ring_twist`` (default True): the twists that dominate their bone's swing (a forearm's or a
        knee's turn about the bone) are blended with the weights smoothed around each limb
        (:attr:`ring_weights`) instead of the weights, so each cross-section of the skeletal mesh turns
        as one. Where the weights vary around the limb (automatic weights at a knee) the blend turns
        neighbours by different angles and a large twist folds the skeletal mesh and the surface rebuilt
        on it, as it folds dual quaternion skinning (skeletal_joints' armadillo knee twisted 180 degrees
        through the layer: 275 crossing pairs without, 4 with; DQS 123). Bends keep the weights.
        ``joint_fillet`` (default 2; 0 = off): at each bent joint (a bone whose head starts at its
        parent's tail) the posed skeletal mesh follows an arc tangent to both bones instead of the
        blend's swing about the joint, and the reconstructed surface is moved to the same map of the
        rest surface before the thickness steps: each cross-section of the joint's band turned rigidly
        along the arc, the band's axis shortened to it (a fillet). The band is the joint's weight
        blend, widened until the fillet's radius is ``joint_fillet`` times the limb's radius, within
        half the shorter bone and without carrying the outer side past the joint. A blend's axis
        swings through the joint and a tube around an axis bent tighter than its radius crosses
        itself on the inner side (skeletal_joints' capsule bent 90 degrees on the whole mesh: 762
        crossing pairs without, 0 with; DQS 95). A vertex follows by its share of weight on the
        joint's two bones, and turns by its share of the child's twist from the :attr:`ring_weights`
        (with ``ring_twist``; the weights, where they vary around the limb, fold a bent and twisted
        joint). Replaces the integration on poses with a bent joint; with
        ``untangle_iterations`` > 0 it fades out where its radius falls below 1.2 limb radii (tight
        bends) and is blended from the integrated skeleton, from which the untangling slides colliding
        limbs apart. Rest pose, rigid motions and pure twists are unchanged (bench/notes/skeletal.md,
        session 35).
        ``bone_clearance`` (variational method): after the thickness steps each control vertex is
        pushed radially out until its distance to the posed segments of the bones it has weight on
        and of their parent bones (their union) is at least this fraction of its rest distance to
        them (a joint's crease where the medial surface is a sheet off the stick bones); through the
        multiresolution layer the dense vertices too (against the bones of their base face's control
        vertices); 0 = off, 1 = every rest distance kept (costs thickness under twists).
        ``contact_slide`` (variational method, fairing on; kappa >= 1, 0 = off): at each joint whose
        bend the pose changes, the bisector plane of the two posed bones is the contact surface of
        the two limbs' flesh; each vertex near the joint slides along its own bone, away from the
        joint, the band up to kappa times its line's crossing depth compressed so that no vertex
        stays on the other limb's side (distance to its bone kept; none in the rest pose, under
        rigid motions or twists). It removes the limb-against-limb self-intersections of a bent
        joint, not the folds inside each limb (it runs before ``fold_guard``, which smooths the faces
        it turns with the others and keeps each slid vertex on its side; on the whole mesh it then also
        smooths the faces turned against dual quaternion skinning); off by default (it adds pairs on
        the armadillo's knee through the multiresolution layer; 3 is the measured setting, see
        bench/notes/skeletal.md).
        ``untangle_iterations`` (variational method, fairing on; 0 = off): the thesis's smoothing
        term of eq. 6.15 where the surface folds: each iteration finds the self-intersecting triangle
        pairs of the control mesh, smooths their vertices and ``untangle_rings`` rings around them
        (umbrella steps) and pushes them back out to at least max(0.9, ``bone_clearance``) of their
        rest distance to their bones (and their parents and children); an iteration that does not
        lower the count is undone and the next takes one ring more. Pairs that cross at rest are
        left alone. Through the multiresolution layer the dense mesh too. Off by default (each
        iteration is a self-intersection search); see bench/notes/skeletal.md for what it measured.
        ``follow_twist`` (default False; variational method with the dual quaternion skeleton): measure
        the thickness (eq. 6.13) and fit the frames (eq. 6.8) in the twist-free pose (each bone's twist
        about its own axis relative to its parent dropped), each vertex carried there by its own
        blended twist: a twisted medial sheet's balls then stay where the twisted flesh is, instead of
        pushing it out (bench skeletal_blender's armadillo twisted 180 degrees at the waist: 2500
        crossing pairs and volume 1.125 without, 0 and 0.998 with; DQS 0; see bench/notes/skeletal.md,
        sessions 25 and 36). Only a twist that dominates its bone's swing is dropped (a bend that
        carries a twist keeps it). Same result as without it for poses without such a twist. Off by
        default: against the posed skeletal mesh a twisted leg's thickness error grows (skeletal_limb's
        legs twisted 180 degrees: 0.05 -> 0.5 of DQS's).
        ``fold_guard`` (variational method, fairing on; iterations, 0 = off; on by default): after
        the thickness steps, the faces they turned over (normal against the bare reconstruction's,
        eq. 6.11; through the multiresolution layer, against the dense mesh's limit surface before
        its own step) have their vertices' displacement averaged with their neighbours' until none is
        turned, each smoothed vertex pushed back out to ``bone_clearance`` of its rest distance to its
        bones (and their parents and children). No search: fewer crossings in a bent joint's crease at
        a small cost (see bench/notes/skeletal.md).
        ``out``: a C-contiguous float64 or float32 (n, 3) array to write into (returned), for
        repeated poses: no allocation of the dense result, GIL released. float32 (computed in
        double, rounded on output; through the multiresolution layer the dense thickness step
        reads the rounded values back, within 1e-6 of the float64 result) goes straight to Blender, e.g.
        ``mesh.shape_keys.key_blocks["dg_skeletal"].data.foreach_set("co", out.ravel())``.
        ``skeleton``: an edited skeletal mesh, see :meth:`deform_skeleton`.
        Defaults: ``SkeletalDeformOptions()``.
        """
        o = self._deform_options(method, fairing_steps, fairing_step, homotopy_steps, fold_iterations, projection,
                                 dual_quaternion, integrate_skeleton, ring_twist, joint_fillet, bone_clearance,
                                 contact_slide, untangle_iterations, untangle_rings, follow_twist, fold_guard)
        P = _mats(bones_pose, "bones_pose", self.n_bones)
        if out is not None:
            if (not isinstance(out, np.ndarray) or out.dtype not in (np.float64, np.float32)
                    or out.shape != (self.n_vertices, 3) or not out.flags.c_contiguous or not out.flags.writeable):
                raise MeshError("deform: out must be a writeable C-contiguous float64 or float32 array of shape "
                                "(%d, 3)" % self.n_vertices)
        return self._rig.deform(P, o, out, self._skeleton(skeleton))

    def deform_skeleton(self, skeleton: npt.ArrayLike, bones_pose: npt.ArrayLike | None = None,
                        **options: Any) -> np.ndarray:
        """Free-form skeleton editing (thesis 6.2: any space deformation of the skeletal mesh):
        deformed vertex positions (n, 3) rebuilt around ``skeleton``, the skeletal vertices
        (n_control, 3) moved by any deformation (a lattice, hooks, sculpting; start from
        :attr:`skeleton_vertices`), with the thickness (medial radii) kept.

        ``bones_pose`` (B, 4, 4), optional: the edit is made in the rest space and the bones then pose
        the edited skeleton (each skeletal vertex's offset turns with its blended bone frame); without
        it the rest pose, i.e. ``skeleton`` is the posed skeletal mesh itself. The bone clearance
        leaves the vertices on moved skeletal vertices alone (an edit may bring flesh to a bone).
        ``options``: as :meth:`deform` (``out`` included).
        """
        pose = self.bones_rest if bones_pose is None else bones_pose
        return self.deform(pose, skeleton=skeleton, **options)

    def _skeleton(self, skeleton):
        if skeleton is None:
            return None
        S = as_vertices(skeleton, "skeleton")
        if len(S) != self.n_control:
            raise MeshError(f"skeleton must have one row per skeletal vertex ({self.n_control}), got {len(S)}")
        if not np.isfinite(S).all():
            raise MeshError("skeleton has non-finite coordinates")
        return S

    def deform_control(self, bones_pose: npt.ArrayLike, *, fairing_steps: int = _DEFORM.fairing_steps,
                       method: str | SkeletalMethod = _DEFORM.method.name, fairing_step: float = _DEFORM.fairing_step,
                       homotopy_steps: int = _DEFORM.homotopy_steps, fold_iterations: int = _DEFORM.fold_iterations,
                       projection: float = _DEFORM.projection, dual_quaternion: bool = _DEFORM.dual_quaternion,
                       integrate_skeleton: bool = _DEFORM.integrate_skeleton,
                       ring_twist: bool = _DEFORM.ring_twist, joint_fillet: float = _DEFORM.joint_fillet,
                       bone_clearance: float = _DEFORM.bone_clearance, contact_slide: float = _DEFORM.contact_slide,
                       untangle_iterations: int = _DEFORM.untangle_iterations,
                       untangle_rings: int = _DEFORM.untangle_rings, follow_twist: bool = _DEFORM.follow_twist,
                       fold_guard: int = _DEFORM.fold_guard,
                       skeleton: npt.ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(control mesh positions, deformed skeletal vertices) for a pose; options as :meth:`deform`."""
        o = self._deform_options(method, fairing_steps, fairing_step, homotopy_steps, fold_iterations, projection,
                                 dual_quaternion, integrate_skeleton, ring_twist, joint_fillet, bone_clearance,
                                 contact_slide, untangle_iterations, untangle_rings, follow_twist, fold_guard)
        return self._rig.deform_control(_mats(bones_pose, "bones_pose", self.n_bones), o, self._skeleton(skeleton))

    def skeleton_pose(self, bones_pose: npt.ArrayLike) -> np.ndarray:
        """Skeletal vertices posed as :meth:`deform` poses them with its defaults (the blend of eq. 6.2,
        the bone clearance, and the joints' fillets where a joint is bent, else the integration;
        ``deform_control(pose, integrate_skeleton=False, joint_fillet=0)[1]`` for the blend's skeletal
        mesh)."""
        return self._rig.skeleton_pose(_mats(bones_pose, "bones_pose", self.n_bones))

    @staticmethod
    def _deform_options(method, fairing_steps, fairing_step, homotopy_steps, fold_iterations, projection,
                        dual_quaternion, integrate_skeleton, ring_twist, joint_fillet, bone_clearance, contact_slide,
                        untangle_iterations, untangle_rings, follow_twist, fold_guard):
        return make_options(SkeletalDeformOptions(), method=as_choice(method, SkeletalMethod, "method"),
                            fairing_steps=as_count(fairing_steps, "fairing_steps"), fairing_step=fairing_step,
                            homotopy_steps=as_count(homotopy_steps, "homotopy_steps"),
                            fold_iterations=as_count(fold_iterations, "fold_iterations"), projection=projection,
                            dual_quaternion=dual_quaternion, integrate_skeleton=bool(integrate_skeleton),
                            ring_twist=bool(ring_twist), joint_fillet=joint_fillet,
                            bone_clearance=bone_clearance, contact_slide=contact_slide,
                            untangle_iterations=as_count(untangle_iterations, "untangle_iterations"),
                            untangle_rings=as_count(untangle_rings, "untangle_rings"),
                            follow_twist=bool(follow_twist), fold_guard=as_count(fold_guard, "fold_guard"))

    # --- bind data ---------------------------------------------------------------------------
    def __reduce__(self) -> tuple[Any, tuple[dict[str, np.ndarray]]]:
        # pickle / copy.deepcopy through the exact array round trip (e.g. to send it to another process)
        return (type(self).from_arrays, (self.to_arrays(),))

    # Bind data entries that are single values (the rest are arrays).
    _SCALARS = {"frame_regularization": as_real, "has_multires": as_flag, "mr_level": as_count}

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The bind data as a dict of numpy arrays (np.savez-able); :meth:`from_arrays` restores it.
        Single values are 0-d arrays."""
        return {k: np.asarray(v) if k in self._SCALARS else np.ascontiguousarray(v) for k, v in self._rig.data().items()}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, npt.ArrayLike]) -> "SkeletalRig":
        """Restores a binding from :meth:`to_arrays` output (a dict or an ``np.load`` archive)."""
        if not isinstance(arrays, Mapping) and not hasattr(arrays, "files"):
            raise MeshError(f"bind data must be a dict of arrays, got {type(arrays).__name__}")
        d = dict(arrays)
        for k, kind in cls._SCALARS.items():
            # Data saved before 0-d arrays holds these as 1-element arrays (numpy 2.4 no longer
            # converts those to scalars by itself).
            if k in d:
                v = np.asarray(d[k])
                if v.size != 1:
                    raise MeshError(f"bind data {k!r} must be a single value, got shape {v.shape}")
                d[k] = kind(v.reshape(-1)[0], f"bind data {k!r}")
        for k in ("control_F", "mr_control_F", "mr_face", "mr_dense_F"):
            if k in d:
                d[k] = np.ascontiguousarray(d[k], dtype=np.int32)
        return cls(_native.SkeletalRig.from_data(d))

    def save(self, path: str | bytes | os.PathLike) -> None:
        """Writes the bind data to a .npz file."""
        with open(path, "wb") as fh:  # a file object: numpy would add ".npz" to a path without it
            np.savez_compressed(fh, **self.to_arrays())

    @classmethod
    def load(cls, path: str | bytes | os.PathLike) -> "SkeletalRig":
        """Reads bind data written by :meth:`save`."""
        with np.load(path) as z:
            return cls.from_arrays({k: z[k] for k in z.files})

    def control_crossings(self, F: npt.ArrayLike) -> tuple[int, int]:
        """Self-intersecting triangle pairs at rest of the control mesh and of the bound mesh (faces F):
        where the control mesh crosses itself and the mesh does not, a pose folds the dense mesh there.
        (The control mesh's fit once made a 45K-vertex capsule's 1000-face control mesh cross itself at
        5280 pairs, and the capsule twisted 180 degrees at 2752; the fit now keeps it uncrossed,
        bench/notes/skeletal.md, session 37.) Without the multiresolution layer both counts are the
        mesh's."""
        F = as_faces(F, n=self.n_vertices)
        dense = len(self_intersecting_pairs(self.deform(self.bones_rest), F))
        if not self.has_multires:
            return dense, dense
        return len(self_intersecting_pairs(self.control_vertices, self.control_faces)), dense

    # --- properties --------------------------------------------------------------------------
    n_vertices = property(lambda self: self._rig.n_vertices)
    n_control = property(lambda self: self._rig.n_control)
    n_bones = property(lambda self: self._rig.n_bones)
    has_multires = property(lambda self: self._rig.has_multires)
    control_vertices = property(lambda self: self._rig.control_vertices)
    control_faces = property(lambda self: self._rig.control_faces)
    skeleton_vertices = property(lambda self: self._rig.skeleton_vertices, doc="(n_control, 3) skeletal mesh")
    skeleton_faces = property(lambda self: self._rig.control_faces, doc="faces of the skeletal mesh")
    radii = property(lambda self: self._rig.radii, doc="medial-ball radius per skeletal vertex (eq. 6.7)")
    weights = property(lambda self: np.ascontiguousarray(self._rig.weights), doc="(n_control, B) bone weights of the skeletal vertices")
    ring_weights = property(lambda self: np.ascontiguousarray(self._rig.ring_weights),
                            doc="(n_control, B) the weights smoothed around each limb that twists are blended with "
                                "(``deform(ring_twist=True)``; :func:`ring_weights` with the medial radii)")
    bones_rest = property(lambda self: self._rig.bones_rest, doc="(B, 4, 4) rest frames the mesh was bound with")


def skeletal_mesh(V: npt.ArrayLike, F: npt.ArrayLike, *, presmooth_iterations: int = _SKELETON.presmooth_iterations,
                  presmooth_step: float = _SKELETON.presmooth_step,
                  postsmooth_iterations: int = _SKELETON.postsmooth_iterations,
                  postsmooth_step: float = _SKELETON.postsmooth_step, spike_factor: float = _SKELETON.spike_factor,
                  max_pole_angle: float = _SKELETON.max_pole_angle) -> tuple[np.ndarray, np.ndarray]:
    """Skeletal mesh of a closed mesh (thesis 6.1): (S (n, 3), radii (n,)), views of one
    :class:`SkeletalMesh`. Faces are F's. Defaults: ``SkeletonOptions()``."""
    V = as_vertices(V)
    o = make_options(
        SkeletonOptions(), presmooth_iterations=as_count(presmooth_iterations, "presmooth_iterations"),
        presmooth_step=as_real(presmooth_step, "presmooth_step", 0.0, 1.0),  # umbrella steps: stable to 1
        postsmooth_iterations=as_count(postsmooth_iterations, "postsmooth_iterations"),
        postsmooth_step=as_real(postsmooth_step, "postsmooth_step", 0.0, 1.0),
        spike_factor=as_real(spike_factor, "spike_factor", 0.0, lo_open=True),
        max_pole_angle=as_real(max_pole_angle, "max_pole_angle", 0.0, np.pi, lo_open=True))
    s = _native.skeletal_mesh(V, as_faces(F, n=len(V)), o)
    return s.S, s.radii


def union_of_balls_distance(X: npt.ArrayLike, centers: npt.ArrayLike, radii: npt.ArrayLike) -> np.ndarray:
    """Signed distance of points to the union of balls (eq. 6.13): min_j |x - c_j| - r_j."""
    return _native.union_of_balls_distance(as_vertices(X), as_vertices(centers, "centers"),
                                           np.ascontiguousarray(radii, dtype=np.float64))


def self_intersecting_pairs(V: npt.ArrayLike, F: npt.ArrayLike, touching: npt.ArrayLike | None = None) -> np.ndarray:
    """Self-intersecting triangle pairs (k, 2), sorted, i < j: faces sharing no vertex where an
    edge of one crosses the other's interior (native, through a bounding-volume hierarchy that skips
    patches which cannot cross themselves). ``touching`` (one flag per face): only the pairs with a
    flagged face (what the untangling searches after moving a region)."""
    V = as_vertices(V)
    if not np.isfinite(V).all():
        raise MeshError("V has non-finite coordinates")
    F = as_faces(F, n=len(V))
    if touching is None:
        return _native.self_intersecting_pairs(V, F)
    t = np.asarray(touching)
    if t.shape != (len(F),):
        raise MeshError(f"touching needs one flag per face ({len(F)}), got shape {t.shape}")
    return _native.self_intersecting_pairs(V, F, t.astype(bool).astype(np.int32).tolist())


def gaussian_bone_weights(P: npt.ArrayLike, heads: npt.ArrayLike, tails: npt.ArrayLike, sigma: float) -> np.ndarray:
    """Normalised Gaussian weights (n, B) of the distances of points to bone segments."""
    return _native.gaussian_bone_weights(as_vertices(P), as_vertices(heads, "heads"), as_vertices(tails, "tails"),
                                         as_real(sigma, "sigma", 0.0, lo_open=True))


def ring_weights(V: npt.ArrayLike, F: npt.ArrayLike, weights: npt.ArrayLike, bone_dirs: npt.ArrayLike,
                 radius: npt.ArrayLike, *, scale: float = _RING.scale, floor: float = _RING.floor) -> np.ndarray:
    """Bone weights (n, B) smoothed around the limbs: each column evened out across the directions
    about its bone's axis (``bone_dirs`` (B, 3); per face, the axis of the bone with the largest weight
    on its corners) and kept along it, over ``scale`` times each vertex's ``radius`` (n,), then weights
    below ``floor`` dropped and the rows renormalised. A twist blended with them turns each cross-section
    of a limb as one (see ring_weights.h)."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    return _native.ring_weights(V, F, np.ascontiguousarray(weights, dtype=np.float64),
                                as_vertices(bone_dirs, "bone_dirs"), np.ascontiguousarray(radius, dtype=np.float64),
                                make_options(RingWeightOptions(), scale=as_real(scale, "scale", 0.0, lo_open=True),
                                             floor=as_real(floor, "floor", 0.0)))


def skeletal_subspace_deform(P: npt.ArrayLike, weights: npt.ArrayLike, bones_rest: npt.ArrayLike,
                             bones_pose: npt.ArrayLike, *, dual_quaternion: bool = False) -> np.ndarray:
    """Linear blend skinning / SSD (eq. 6.2) of points with (n, B) weights, or with
    ``dual_quaternion`` dual quaternion blending of the bone motions (how SkeletalRig poses its
    skeletal mesh by default, before its bone clearance)."""
    R = _mats(bones_rest, "bones_rest")
    return _native.skeletal_subspace_deform(as_vertices(P), np.asarray(weights, dtype=np.float64), R,
                                            _mats(bones_pose, "bones_pose", len(R)),
                                            as_flag(dual_quaternion, "dual_quaternion"))


def delaunay_3d(points: npt.ArrayLike) -> dict[str, np.ndarray]:
    """Delaunay tetrahedralisation (Qhull): dict with tets (m, 4), circumcenters (m, 3) (the Voronoi
    vertices), circumradii, and the tets around each point as CSR point_offset / point_tets."""
    return _native.delaunay_3d(as_vertices(points, "points"))


def delaunay_2d(points: npt.ArrayLike) -> np.ndarray:
    """Delaunay triangulation (Qhull) of (n, 2) points: (m, 3) counter-clockwise triangles."""
    P = np.ascontiguousarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2:
        raise MeshError(f"points must have shape (n, 2), got {P.shape}")
    return _native.delaunay_2d(P)


def capsule(radius: float = 0.5, length: float = 6.0, around: int = 32, cap_rings: int = 6,
            cylinder_rings: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """Closed capsule along x (cylinder of ``length`` plus two hemispherical caps), centred at the
    origin, with alternating ring offsets so that triangles are near-equilateral: (V, F).
    The same bits on every machine: the sines and cosines are the C library's (numpy's own, with
    AVX-512, differ from it by an ulp, and a symmetric mesh's decimation turns on such ties)."""
    prof = []
    for k in range(1, cap_rings + 1):
        a = math.pi / 2 * k / cap_rings
        prof.append((-length / 2 - radius * math.cos(a), radius * math.sin(a)))
    for k in range(1, cylinder_rings):
        prof.append((-length / 2 + length * k / cylinder_rings, radius))
    for k in range(cap_rings, 0, -1):
        a = math.pi / 2 * k / cap_rings
        prof.append((length / 2 + radius * math.cos(a), radius * math.sin(a)))
    nr = len(prof)
    V = np.zeros((nr * around + 2, 3))
    # Each ring's angles: the even rings' and the odd rings' (half a step on).
    t = [[2 * math.pi * (j + 0.5 * odd) / around for j in range(around)] for odd in (0, 1)]
    cos = [np.array([math.cos(a) for a in ts]) for ts in t]
    sin = [np.array([math.sin(a) for a in ts]) for ts in t]
    for i, (x, rho) in enumerate(prof):
        V[i * around:(i + 1) * around] = np.stack([np.full(around, x), rho * cos[i % 2], rho * sin[i % 2]], 1)
    s, e = nr * around, nr * around + 1
    V[s] = (-length / 2 - radius, 0, 0)
    V[e] = (length / 2 + radius, 0, 0)
    F = [(s, (k + 1) % around, k) for k in range(around)]
    for i in range(nr - 1):
        for k in range(around):
            a, b = i * around + k, i * around + (k + 1) % around
            c, d = (i + 1) * around + k, (i + 1) * around + (k + 1) % around
            F += [(a, b, c), (b, d, c)] if i % 2 == 0 else [(a, d, c), (a, b, d)]
    last = (nr - 1) * around
    F += [(e, last + k, last + (k + 1) % around) for k in range(around)]
    return V, np.asarray(F, dtype=np.int32)
