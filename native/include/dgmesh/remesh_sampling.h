/// \file
/// Sampling of a chart for the remesher (thesis 5.4, with the relaxation beyond it): the boundary
/// samples, the control map rasterized over the sampling map (density per unit of map area), error
/// diffusion of the interior samples (serpentine Floyd-Steinberg), their density-weighted Lloyd
/// relaxation and a minimum separation, repeated until the count meets the target. Used by remesh()
/// (remesh.h); not part of the library's interface.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "dgmesh/detail/math.h"
#include "dgmesh/detail/remesh_map.h"
#include "dgmesh/detail/timer.h"
#include "dgmesh/mesh.h"
#include "dgmesh/progress.h"
#include "dgmesh/remesh.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/surface_projection.h"

namespace dgmesh::detail {

constexpr double kSqrt3 = 1.7320508075688772;

/// Target edge length of a near-equilateral mesh with `density` vertices per unit area: each vertex
/// owns sqrt(3)/2 h^2 of area.
inline double spacing(double density) { return std::sqrt(2.0 / (kSqrt3 * std::max(density, 1e-300))); }

/// Deterministic sub-pixel offset in [-0.5, 0.5): breaks the co-circularity of pixel-centred samples
/// so the Delaunay triangulation is unique (Qhull's Qt could otherwise emit flat triangles).
inline double jitter(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return (x & 0xffffff) / double(1 << 24) - 0.5;
}

/// Point-in-polygon for a (weakly) convex counter-clockwise polygon in O(log n): binary search of
/// the wedge around an inner point, then one edge test. `margin` is a distance.
class ConvexPolygon {
 public:
  explicit ConvexPolygon(std::vector<Vec2> pts) : p_(std::move(pts)) {
    c_ = Vec2::Zero();
    for (const Vec2& q : p_) c_ += q;
    c_ /= double(p_.size());
    const int n = int(p_.size());
    int start = 0;
    ang_.resize(n);
    for (int k = 0; k < n; ++k) {
      ang_[k] = std::atan2(p_[k].y() - c_.y(), p_[k].x() - c_.x());
      if (ang_[k] < ang_[start]) start = k;
    }
    std::rotate(p_.begin(), p_.begin() + start, p_.end());
    std::rotate(ang_.begin(), ang_.begin() + start, ang_.end());
  }
  /// Signed distance-like test: true when q is inside by more than margin from the wedge's edge.
  bool inside(const Vec2& q, double margin) const {
    const int n = int(p_.size());
    const double a = std::atan2(q.y() - c_.y(), q.x() - c_.x());
    // Edge k -> k+1 covers angles [ang_k, ang_{k+1}); the last edge wraps around.
    int k = int(std::upper_bound(ang_.begin(), ang_.end(), a) - ang_.begin()) - 1;
    if (k < 0) k = n - 1;
    const Vec2& p0 = p_[k];
    const Vec2& p1 = p_[(k + 1) % n];
    const Vec2 e = p1 - p0;
    const double len = e.norm();
    if (len <= 0) return false;
    return cross2(e, q - p0) / len > margin;
  }

 private:
  std::vector<Vec2> p_;
  std::vector<double> ang_;
  Vec2 c_;
};

/// Distance from a 3D point to the chart's boundary polyline: a kd-tree over points placed densely
/// along the loop, then exact distances to the segment of the nearest point and its neighbours.
class BoundaryDistance {
 public:
  BoundaryDistance(const MatX3d& V, const std::vector<int>& loop, double step) : V_(V), loop_(loop) {
    const int nb = int(loop.size());
    double total = 0;
    for (int k = 0; k < nb; ++k) total += (row3(V, loop[(k + 1) % nb]) - row3(V, loop[k])).norm();
    step = std::max(step, total / 400000.0);  // bounded memory on long, dense boundaries
    std::vector<Vec3> pts;
    for (int k = 0; k < nb; ++k) {
      const Vec3 a = row3(V, loop[k]), b = row3(V, loop[(k + 1) % nb]);
      const int m = std::max(1, int(std::ceil((b - a).norm() / step)));
      for (int s = 0; s < m; ++s) {
        pts.push_back(a + (b - a) * (double(s) / m));
        seg_.push_back(k);
      }
    }
    MatX3d P(int(pts.size()), 3);
    for (int i = 0; i < P.rows(); ++i) P.row(i) = pts[i].transpose();
    tree_ = std::make_unique<KdTree>(P);
  }
  double operator()(const Vec3& q) const {
    const int i = tree_->nearest(q);
    const int nb = int(loop_.size());
    const int k = seg_[i];
    double d = std::numeric_limits<double>::infinity();
    for (int o = -1; o <= 1; ++o) {
      const int s = ((k + o) % nb + nb) % nb;
      d = std::min(d, point_segment_distance(q, row3(V_, loop_[s]), row3(V_, loop_[(s + 1) % nb])));
    }
    return d;
  }

 private:
  const MatX3d& V_;
  const std::vector<int>& loop_;
  std::vector<int> seg_;
  std::unique_ptr<KdTree> tree_;
};

/// The boundary samples, in loop order, in 3D, in the triangulation map (u) and the sampling map (s),
/// and on the input (face and barycentric weights).
struct BoundarySamples {
  std::vector<Vec3> x;
  std::vector<Vec2> u;
  std::vector<Vec2> s;
  std::vector<Sample> src;
};

/// Boundary samples: the input's boundary vertices (o.boundary Keep; res.boundary_source set), or
/// new ones along the boundary polyline at the target spacing of the density rho (Resample; the
/// square's corners are kept). (Us, Ut): the sampling and triangulation maps.
BoundarySamples sample_boundary(const MatX3d& V, const MatX3i& F, const Topology& topo, const MatX2d& Us,
                                const MatX2d& Ut, const VecXd& rho, double rho_integral, const RemeshOptions& o,
                                RemeshResult& res);

/// An ear of a kept boundary: a boundary vertex with a single input face, glued onto the chord
/// (prev, next) of the convex core in the triangulation map.
struct Ear {
  int tip, prev, next;  // boundary sample indices
  int face;             // the ear's input face
};

/// The chart in the triangulation map as a convex core polygon (the boundary samples that are not
/// ear tips) with the ears of a kept boundary glued onto its chords; every input face belongs to
/// one piece (an ear's face to the ear).
struct ChartPieces {
  std::vector<Ear> ears;
  std::vector<int> ear_of_face;    // per input face: its ear, or -1 (the core)
  std::vector<int> core;           // boundary samples of the core, in loop order
  ConvexPolygon polygon;           // the core, counter-clockwise
  const std::vector<Vec2>* bnd_u;  // the boundary samples in the triangulation map

  /// Whether a point u of the triangulation map on input face f is strictly inside (by margin) its
  /// piece of the chart: the ear's triangle for an ear's face, the core polygon for any other.
  bool inside(int f, const Vec2& u, double margin) const;
};

ChartPieces chart_pieces(const Topology& topo, const std::vector<Vec2>& bnd_u, const RemeshOptions& o);

/// What the interior sampling reads: the chart (V, F, topo), its sampling and triangulation maps, the
/// density rho and its surface integral, the interior target and the boundary samples.
struct SamplingChart {
  const MatX3d& V;
  const MatX3i& F;
  const Topology& topo;
  const MatX2d& Us;
  const MatX2d& Ut;
  const VecXd& rho;
  double rho_integral;
  int n_int;
  const BoundarySamples& bnd;
  const ChartPieces& pieces;
};

/// The control map (density per unit of sampling-map area) rasterized at R x R for the error
/// diffusion, and at RL x RL (a multiple of R) as the Lloyd relaxation's quadrature grid: per pixel
/// the covering face (-1 outside), the value and (relaxing in the surface metric) the surface point.
struct ControlRaster {
  int R = 0, RL = 0;
  std::vector<int> pix_face, lpix_face_own;
  std::vector<double> pix_val, lpix_val_own;
  std::vector<float> pix_x, lpix_x_own;
  double pix_sum = 0;  // sum of the R x R values
};

/// Chooses R (o.resolution, coarser for small targets; MeshError when the target does not fit the
/// chart's pixels) and RL, and rasterizes. Sets res.resolution and warns when R is low.
ControlRaster control_raster(const SamplingChart& c, const VecXd& area3, const RemeshOptions& o, RemeshResult& res);

/// The interior samples (step 4 of remesh): rounds of error diffusion (density rescaled until the
/// count is met), Lloyd relaxation and minimum separation. samples: every diffused sample, keep: the
/// ones kept. Sets the sampling counters and times of res; MeshError when no sample could be kept.
void sample_interior(const SamplingChart& c, const ControlRaster& raster, const RemeshOptions& o, Progress& report,
                     Clock::time_point t_sample, std::vector<Sample>& samples, std::vector<char>& keep,
                     RemeshResult& res);

}  // namespace dgmesh::detail
