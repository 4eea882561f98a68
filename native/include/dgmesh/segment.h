// Feature-guided mesh segmentation (thesis 4.9): variational shape approximation (Cohen-Steiner,
// Alliez, Desbrun 2004) with the L^{2,1} metric and Lloyd iterations, where region growing weighs
// the error of a face T_j reached from a region's face T_i by w_ij = 2 / (F(T_i) + F(T_j)), F the
// crest-line distance function of eq. 4.12.
#pragma once
#include <vector>

#include "dgmesh/mesh.h"
#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh {

struct SegmentOptions {
  int segments = 25;    // the thesis's figures 4.25-4.27
  int iterations = 30;  // Lloyd iterations once every seed is placed (stops early when stable)
  VecXd face_feature;   // F(T) per face (feature_function of crest_lines.h); empty: all 1 (plain VSA)
};

struct SegmentResult {
  std::vector<int> labels;  // segment of each face, 0 .. n_segments-1; every segment is connected
  MatX3d proxy_normals;     // one unit normal per segment
  int n_segments = 0;       // > segments only when the mesh has more connected components
  int iterations = 0;       // Lloyd iterations run
  double error = 0.0;       // total L^{2,1} distortion: sum of area |n_f - N_k|^2
};

SegmentResult segment(const Mesh& mesh, const SegmentOptions& opt, const ProgressFn& progress = {});

}  // namespace dgmesh
