// Bone weights smoothed around the limbs (issue 33: a twisted joint's folds).
//
// Skeletal subspace deformation (thesis eq. 6.2) twists a point about a bone's axis by an angle that
// follows the point's weight. Where the weights vary around the limb (automatic weights at a knee:
// the kneecap and the hollow behind it differ), a point at radius rho and angle phi about the axis
// moves to phi + tau w(phi, t), which folds the surface wherever tau dw/dphi < -1: a 180-degree twist
// folds where the weight changes by more than 1/pi per radian around the limb. A twist whose angle
// depends on the position along the axis alone turns each cross-section rigidly and cannot fold.
// These weights are that: each column of W smoothed across the directions about its bone's axis
// and kept along it,
//   minimise  sum_f A_f |P_f grad w~|^2 + sum_i (M_i / l_i^2) (w~_i - w_i)^2,
// P_f = I - a_f a_f^T the projection off the axis a_f of the face's dominant bone (the largest
// weight summed over its corners), grad over the face's piecewise-linear hat functions, M_i the
// lumped (barycentric) vertex area, l_i = scale * radius_i the length over which a weight is kept
// (radius_i a thickness: a ring's circumference is 2 pi times it). The columns share one SPD system,
// so the rows keep summing to 1. Weights below `floor` are then dropped and the rows renormalised:
// without it the smoothing leaks a trace of every bone along whole bodies (a thousandth of the knee
// bone's weight on the armadillo's head, turning it about the knee's axis).
#pragma once
#include "dgmesh/types.h"

namespace dgmesh {

struct RingWeightOptions {
  double scale = 4.0;   // l_i over radius_i; larger: rings further apart in weight are evened out
  double floor = 0.01;  // smoothed weights below this are dropped
};

// V, F: a closed or open triangle mesh (n vertices); W: n x B weights (rows summing to 1);
// bone_dirs: B x 3 bone axes (any length > 0); radius: n positive thicknesses (clamped below at a
// thousandth of the largest). Returns n x B, rows summing to 1. Throws MeshError on mismatched shapes,
// an index out of range, no positive radius, scale <= 0 or floor outside [0, 1).
Eigen::MatrixXd ring_weights(const MatX3d& V, const MatX3i& F, const Eigen::MatrixXd& W, const MatX3d& bone_dirs,
                             const VecXd& radius, const RingWeightOptions& opt = {});

}  // namespace dgmesh
