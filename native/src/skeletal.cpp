// Skeleton-driven deformation (thesis chapter 6). See skeletal.h.
#include "dgmesh/skeletal.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "dgmesh/delaunay.h"
#include "dgmesh/detail/math.h"
#include "dgmesh/detail/skeletal_util.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/joint_fillet.h"
#include "dgmesh/parallel.h"
#include "dgmesh/ring_weights.h"
#include "dgmesh/self_intersection.h"
#include "dgmesh/sparse_solver.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/validate.h"

namespace dgmesh {

using detail::blended_rotation;
using detail::dual_quaternion_motion;
using detail::Mat3;
using detail::MatX9d;
using detail::nearest_rotation;
using detail::segment_closest;
using detail::segment_sq_dist;
using detail::signed_volume;
using detail::union_distance;

namespace {

// The per-pose loops over the control mesh whose items cost a microsecond or more (3x3 polar
// decompositions, eq. 6.12's corner sums, kd-tree queries of eq. 6.13) go parallel from about a
// thousand items, below kParallelMin (the dense reconstruction of the same deform needs the threads
// anyway). Control deform of bench skeletal_speed's 2502-vertex control mesh, A/B interleaved:
// 6.4 -> 4.0 ms; the whole 178K-vertex deform 16.6 -> 13.2 ms.
constexpr int kParallelHeavy = 1024;

// The same polar factor from a nearby rotation G (the triangle's blended bone rotation, usually a
// few degrees off): Newton's method for max tr(R^T A) over rotations R = G exp([w]). With
// B = R^T A, S = sym(B): tr(R^T A) grows as w.g - w^T H w / 2, g = 2 axial(skew(B)),
// H = tr(S) I - S, so w = H^-1 g; H is positive definite near the maximum, where S is the polar
// factor's symmetric part. Quadratic convergence: 2-3 steps of about 100 flops instead of the
// scaled Newton iteration's 6-10 3x3 inverses. Returns false (caller falls back) if H is not
// positive definite or the steps do not become negligible.
bool polar_near(const Mat3& A, const Mat3& G, Mat3& R) {
  R = G;
  const double scale = A.squaredNorm();
  if (!(scale > 1e-300) || !A.allFinite()) return false;
  for (int it = 0; it < 6; ++it) {
    const Mat3 B = R.transpose() * A;
    const Vec3 g(B(2, 1) - B(1, 2), B(0, 2) - B(2, 0), B(1, 0) - B(0, 1));
    const Mat3 S = 0.5 * (B + B.transpose());
    const Mat3 H = S.trace() * Mat3::Identity() - S;
    Eigen::LLT<Mat3> llt(H);
    if (llt.info() != Eigen::Success || !(H.diagonal().minCoeff() > 1e-12 * std::sqrt(scale))) return false;
    const Vec3 w = llt.solve(g);
    const double t2 = w.squaredNorm();
    if (!std::isfinite(t2) || t2 > 1.0) return false;  // far from the guess: not Newton's region
    Mat3 K;
    K << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
    const double t = std::sqrt(t2);
    // Rodrigues; the series where t is tiny (its error, t^3/6, is below rounding there).
    const double a = t > 1e-6 ? std::sin(t) / t : 1 - t2 / 6, b = t > 1e-6 ? (1 - std::cos(t)) / t2 : 0.5 - t2 / 24;
    R = R * (Mat3::Identity() + a * K + b * (K * K));
    if (t2 < 1e-26) return true;
  }
  return false;
}

// Rotation taking unit a to unit b by the shortest arc (identity when they coincide).
Mat3 rotation_between(const Vec3& a, const Vec3& b) {
  const Vec3 c = a.cross(b);
  const double s = c.norm(), co = a.dot(b);
  if (s < 1e-12) {
    if (co > 0) return Mat3::Identity();
    // opposite: a half turn about any axis perpendicular to a
    Vec3 p = std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    p = (p - p.dot(a) * a).normalized();
    return 2 * p * p.transpose() - Mat3::Identity();
  }
  return Eigen::AngleAxisd(std::atan2(s, co), c / s).toRotationMatrix();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Push p out to at least distance e from the segment (h, h + v) (a point on the segment itself has
// no direction: kept). Returns whether p moved.
inline bool push_from_segment(Vec3& p, const Vec3& h, const Vec3& v, double e) {
  const double vv = v.squaredNorm();
  const double t = vv > 0 ? std::clamp((p - h).dot(v) / vv, 0.0, 1.0) : 0.0;
  const Vec3 c = h + t * v;
  const double d = (p - c).norm();
  if (!(d < e * (1 - 1e-9) && d > 1e-6 * e)) return false;
  p = c + (p - c) * (e / d);
  return true;
}

// Push p out to at least distance fraction * e[j] from each posed segment j with e[j] > 0 (two
// Gauss-Seidel passes over the bones; the second only when the first moved p).
template <class Row>
inline Vec3 push_out(Vec3 p, const Row& e, double fraction, const std::vector<Vec3>& h, const std::vector<Vec3>& v) {
  for (int pass = 0; pass < 2; ++pass) {
    bool moved = false;
    for (int j = 0; j < static_cast<int>(h.size()); ++j)
      if (e[j] > 0) moved |= push_from_segment(p, h[j], v[j], fraction * e[j]);
    if (!moved) break;
  }
  return p;
}

// Surface bone clearance data: for each point, the bones it follows (CSR) and its rest distance to
// the union of their segments (-1: none).
struct BoneClearance {
  std::vector<int> offset{0}, bones;
  VecXd rest;

  // Point i at p, pushed out to at least fraction * rest[i] from each of its posed segments (h, v)
  // (two Gauss-Seidel passes; the second only when the first moved p).
  Vec3 push(int i, Vec3 p, double fraction, const std::vector<Vec3>& h, const std::vector<Vec3>& v) const {
    const double e = fraction * rest[i];
    if (!(e > 0)) return p;
    for (int pass = 0; pass < 2; ++pass) {
      bool moved = false;
      for (int k = offset[i]; k < offset[i + 1]; ++k) moved |= push_from_segment(p, h[bones[k]], v[bones[k]], e);
      if (!moved) break;
    }
    return p;
  }
  // Whether p is at least fraction * rest[i] (less a rounding tolerance) from the union of its
  // posed segments.
  bool clear(int i, const Vec3& p, double fraction, const std::vector<Vec3>& h, const std::vector<Vec3>& v) const {
    const double e = fraction * rest[i];
    if (!(e > 0)) return true;
    double d2 = std::numeric_limits<double>::infinity();
    for (int k = offset[i]; k < offset[i + 1]; ++k)
      d2 = std::min(d2, segment_sq_dist(p, h[bones[k]], h[bones[k]] + v[bones[k]]));
    return d2 >= e * e * (1 - 1e-9);
  }
};

}  // namespace

namespace {

// Bounding-volume tree over medial balls for the exact minimum of eq. 6.13, min_j |x - s_j| - r_j:
// the balls of a node are at least dist(x, box of their centres) - (their largest radius) from x, a
// bound that prunes exactly. A kd-tree over the centres finds the nearest centres, not the deepest
// ball: in a joint's crease the other limb's large balls lie farther away than the small ones nearby.
class BallTree {
 public:
  // The balls (centers, radii) of the indices `ids`.
  BallTree(const MatX3d& centers, const VecXd& radii, const std::vector<int>& ids) : idx_(ids) {
    const int n = static_cast<int>(ids.size());
    c_.resize(n);
    r_.resize(n);
    order_.resize(n);
    for (int k = 0; k < n; ++k) c_[k] = row3(centers, ids[k]), r_[k] = radii[ids[k]], order_[k] = k;
    nodes_.reserve(2 * n / kLeaf + 2);
    if (n > 0) build(0, n);
    // Leaves read their balls contiguously, in tree order.
    std::vector<Vec3> c(n);
    std::vector<double> r(n);
    std::vector<int> idx(n);
    for (int k = 0; k < n; ++k) c[k] = c_[order_[k]], r[k] = r_[order_[k]], idx[k] = idx_[order_[k]];
    c_.swap(c);
    r_.swap(r);
    idx_.swap(idx);
    order_ = {};
  }
  // Lowers (best, arg) to the minimum of |x - s_j| - r_j over the balls and its ball (an index of
  // `centers`); (best, arg) comes in as any ball's value, or +inf.
  void query(const Vec3& x, double& best, int& arg) const {
    visit(
        x, [&] { return best; },
        [&](double f, int j) {
          if (f < best) best = f, arg = j;
        });
  }
  // The K deepest balls at x (lowest values |x - s_j| - r_j), deepest first: (ids, val)[0..K) come
  // in as some balls' values, ascending (padded with -1 and +inf), e.g. nearby balls that make a
  // tight first bound, and leave as the K deepest of all (-1 where there are fewer than K balls).
  template <int K>
  void deepest(const Vec3& x, int* ids, double* val) const {
    visit(
        x, [&] { return val[K - 1]; }, [&](double f, int j) { insert_sorted<K>(f, j, ids, val); });
  }
  // Inserts ball j of value f into the ascending (ids, val)[0..K) unless it is there or not lower.
  template <int K>
  static void insert_sorted(double f, int j, int* ids, double* val) {
    if (!(f < val[K - 1])) return;
    for (int k = 0; k < K; ++k)
      if (ids[k] == j) return;
    int k = K - 1;
    for (; k > 0 && val[k - 1] > f; --k) val[k] = val[k - 1], ids[k] = ids[k - 1];
    val[k] = f, ids[k] = j;
  }

 private:
  // Depth first, the child with the lower bound first; a node is skipped once its bound reaches
  // limit() (which only falls). take(f, j) sees every ball below the limit when its leaf is visited.
  template <class Limit, class Take>
  void visit(const Vec3& x, Limit limit, Take take) const {
    if (nodes_.empty()) return;
    struct Item {
      int id;
      double lb;
    };
    Item stack[kStack];
    int top = 0;
    stack[top++] = {0, bound(nodes_[0], x)};
    while (top > 0) {
      const Item it = stack[--top];
      if (it.lb >= limit()) continue;
      const Node& nd = nodes_[it.id];
      if (nd.left < 0) {
        for (int k = nd.begin; k < nd.end; ++k) take((x - c_[k]).norm() - r_[k], idx_[k]);
        continue;
      }
      const double bl = bound(nodes_[nd.left], x), br = bound(nodes_[nd.right], x);
      const Item lo = bl <= br ? Item{nd.left, bl} : Item{nd.right, br};
      const Item hi = bl <= br ? Item{nd.right, br} : Item{nd.left, bl};
      if (hi.lb < limit()) stack[top++] = hi;
      if (lo.lb < limit()) stack[top++] = lo;
    }
  }

  static constexpr int kLeaf = 8;
  static constexpr int kStack = 128;  // a balanced tree of depth log2(n / kLeaf) needs depth + 1
  struct Node {
    Eigen::AlignedBox3d box;  // of the centres
    double rmax = 0;
    int begin = 0, end = 0, left = -1, right = -1;
  };
  static double bound(const Node& nd, const Vec3& x) { return std::sqrt(nd.box.squaredExteriorDistance(x)) - nd.rmax; }
  int build(int b, int e) {
    const int id = static_cast<int>(nodes_.size());
    nodes_.emplace_back();
    Node nd;
    nd.begin = b, nd.end = e;
    for (int k = b; k < e; ++k) nd.box.extend(c_[order_[k]]), nd.rmax = std::max(nd.rmax, r_[order_[k]]);
    if (e - b > kLeaf) {
      int axis;
      nd.box.sizes().maxCoeff(&axis);
      const int mid = (b + e) / 2;  // median split: balanced
      std::nth_element(order_.begin() + b, order_.begin() + mid, order_.begin() + e,
                       [&](int u, int v) { return c_[u][axis] < c_[v][axis]; });
      nd.left = build(b, mid);
      nd.right = build(mid, e);
    }
    nodes_[id] = nd;
    return id;
  }
  std::vector<int> idx_, order_;
  std::vector<Vec3> c_;
  std::vector<double> r_;
  std::vector<Node> nodes_;
};

// Local version of eq. 6.13 for the fairing: the balls of the vertex's rest minimiser p (exact at
// bind time) and of its skeletal 1-ring, plus the k nearest deformed centres (balls of other parts
// the pose brought close). A fixed-size query instead of the radius query over r_max, which on a
// tube returns a large part of its (collapsed) skeleton. p is a global minimiser at rest, so the
// value is exact at rest and under rigid motions (fixed points of the fairing). `hint` adds a
// ball and its ring (the previous projection pass's minimiser); `query` = false skips the kd-tree.
constexpr int kUnionNeighbours = 4;
// Deepest balls kept per control vertex for the dense vertices' thickness step (see project_dense).
constexpr int kDenseBalls = 4;
// The joint contact moves a vertex past the joint onto the plane only where it keeps at least this
// fraction of its rest distance to the joint's two bones (issue 33's thickness bar).
constexpr double kContactClearance = 0.9;
// `tree` holds the deformed centres `reps` (a subset of the skeletal vertices, see Impl::reps),
// rebuilt per pose with small leaves; its queries are exact k nearest: an approximate search barely
// prunes on a tube, whose collapsed skeleton puts hundreds of centres at almost the same distance
// from a surface point, and would change the candidate balls.
// `cand` (kUnionNeighbours slots, -1 = empty): with `query` the k nearest centres found are stored
// there; without, the stored ones are the candidates (a later step of the same pose reuses them).
double union_distance_local(const KdTree& tree, const std::vector<int>& reps, const MatX3d& centers, const VecXd& radii,
                            double r_max, const Topology& topo, const Vec3& x, int p, int& arg, int hint = -1,
                            bool query = true, int* cand = nullptr) {
  double best = (x - row3(centers, p)).norm() - radii[p];
  arg = p;
  auto ring = [&](int c) {
    for (int k = topo.vv_offset[c]; k < topo.vv_offset[c + 1]; ++k) {
      const int j = topo.vv_index[k];
      const double f = (x - row3(centers, j)).norm() - radii[j];
      if (f < best) best = f, arg = j;
    }
  };
  ring(p);
  if (hint >= 0 && hint != p) {
    const double f = (x - row3(centers, hint)).norm() - radii[hint];
    if (f < best) best = f, arg = hint;
    ring(hint);
  }
  if (!query) {
    for (int t = 0; cand && t < kUnionNeighbours && cand[t] >= 0; ++t) {
      const int j = cand[t];
      const double f = (x - row3(centers, j)).norm() - radii[j];
      if (f < best) best = f, arg = j;
    }
    return best;
  }
  if (cand) std::fill(cand, cand + kUnionNeighbours, -1);
  // (Re-using the first step's minimisers in later steps instead of this query saves a third of
  // the deform's instructions but loses the balls a bend's inner crease runs into: min ratio 0.82.)
  // Of the k nearest centres only those within best + r_max can lower the minimum (|x - s_j| - r_j
  // >= |x - s_j| - r_max): the same result as an unbounded query, whose search the bound may prune.
  const double bound = best + r_max;
  if (!(bound > 0)) return best;
  int idx[kUnionNeighbours];
  double d2[kUnionNeighbours];
  const int k = tree.knn(x, kUnionNeighbours, idx, d2, bound * bound);
  for (int t = 0; t < k; ++t) {
    const int j = reps[idx[t]];
    if (cand) cand[t] = j;
    const double f = std::sqrt(d2[t]) - radii[j];
    if (f < best) best = f, arg = j;
  }
  return best;
}

}  // namespace

namespace {

// Each control vertex's own twist (SkeletalDeformOptions::follow_twist): the rigid motion
// M_i(p) = R[i] p + t[i] from the vertex's blend of the twist-free pose to its blend of the pose, and
// the posed skeletal vertices carried back by their own twist, Ss.row(j) = M_j^-1(s^d_j): the ball
// centres of the thickness measured in the twist-free pose. qr, qd: M_i as a unit dual quaternion
// (the dense vertices blend their base face's corners').
struct Twist {
  std::vector<Mat3> R;
  std::vector<Vec3> t;
  MatX3d Ss;
  std::vector<Eigen::Quaterniond> qr, qd;
  std::vector<Mat4> free_pose;  // the twist-free pose's matrices
  Vec3 to_free(int i, const Vec3& x) const { return R[i].transpose() * (x - t[i]); }
  // A point's twist from weights b over the control vertices c (dual quaternion blend).
  void blend(const int* c, const double* b, int k, Mat3& Rb, Vec3& tb) const {
    Eigen::Vector4d r = Eigen::Vector4d::Zero(), d = Eigen::Vector4d::Zero();
    for (int m = 0; m < k; ++m) {
      const double sgn = qr[c[m]].coeffs().dot(qr[c[0]].coeffs()) < 0 ? -1.0 : 1.0;
      r += sgn * b[m] * qr[c[m]].coeffs();
      d += sgn * b[m] * qd[c[m]].coeffs();
    }
    if (!dual_quaternion_motion(r, d, Rb, tb)) Rb = R[c[0]], tb = t[c[0]];
  }
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// The rig

struct SkeletalRig::Impl {
  Mesh control;
  VertexCorners corners;
  MatX3d S;
  VecXd radii;
  MatX3d dirs;                // (x - s) / d: the rest unit normals of representation (6.1)
  VecXd f_rest;               // eq. 6.13 at rest (the fairing targets the rest thickness)
  std::vector<int> rest_arg;  // the minimising ball of eq. 6.13 at rest, per vertex
  // Skeletal vertices whose rest centre lies within a small distance of another's with a larger
  // ball are left out of the fairing's kd-tree (a tube's ring collapses to one skeletal point: tens
  // of coincident centres make every k-nearest query scan them all). Their balls are covered.
  std::vector<int> reps;
  std::vector<int> rep_of;  // per skeletal vertex, the index in reps of the one that covers it (itself)
  Eigen::MatrixXd W;        // n_control x B
  // W smoothed around the limbs (ring_weights.h): the weights a twist is blended with
  // (SkeletalDeformOptions::ring_twist, see ring_twist).
  Eigen::MatrixXd W_ring;
  std::vector<Mat4> rest;
  std::optional<Multires> multires;
  // Through the multiresolution layer: eq. 6.13 at rest for every dense vertex against the control
  // mesh's medial balls, and its minimising ball (see project_dense).
  VecXd dense_f_rest;
  std::vector<int> dense_arg;
  // Dense vertices whose limit surface moves rigidly with one bone (project_dense skips them).
  std::vector<char> dense_rigid;
  // Surface bone clearance (see clear_surface) of the control vertices and, through the
  // multiresolution layer, of the dense ones (see project_dense).
  BoneClearance surface_clearance, dense_clearance;
  // The untangling's clearance (see untangle): against the bones of surface_clearance and their
  // children as well (a smoothed crease vertex must not sink onto the other limb's bone either).
  BoneClearance untangle_clearance, dense_untangle_clearance;
  // Joint contact (see contact_slide): the dense rest positions through the multiresolution layer,
  // and the contact plane's margin (a hundredth of the median medial radius).
  MatX3d dense_rest;
  double contact_margin = 0;
  // Untangling through the multiresolution layer (see untangle_dense): the dense faces (empty for
  // data saved without them), their one-ring CSR and the faces with a vertex not in dense_rigid.
  MatX3i dense_F;
  std::vector<int> dense_vv_offset, dense_vv_index, dense_faces;
  // Triangle pairs that cross at rest (the untangling leaves them alone), control and dense.
  std::vector<std::pair<int, int>> rest_pairs, dense_rest_pairs;
  // The untangling's searches (self_intersection.h), control mesh and dense faces, split at rest.
  SelfIntersectionTree control_tree, dense_tree;
  // Fold guard (SkeletalDeformOptions::fold_guard) over the control mesh and the dense one.
  FoldGuard control_guard, dense_guard;
  MatX3d cot;           // per face corner: cot of the rest angle at that corner
  SparseSolver solver;  // I + L_M (the upper block of L0, eq. 6.10; the lower block is I)
  // Skeletal mesh integration (SkeletalDeformOptions::integrate_skeleton): per skeletal vertex its
  // anchor weight, and the factorised system (graph Laplacian of the control mesh's edges + the
  // anchors), and per control edge the offset of its rest midpoint from the stick skeleton; see
  // integrate_skeleton.
  VecXd sk_anchor;
  MatX3d sk_offset;
  SparseSolver sk_solver;
  double mu = 0;  // frame regularisation weight (absolute)
  double frame_regularization = 0.05;
  double r_max = 0;
  MatX3d rest_normals;  // vertex normals of the control mesh (basic method)
  // Bone clearance (see clear_bones): each bone's rest segment (head, axis scaled to its length)
  // and each skeletal vertex's rest distance to the segments of the bones it has weight on (-1: none).
  std::vector<Vec3> bone_head, bone_vec;
  // The stick skeleton given at bind (SkeletalRigData::bone_heads / bone_tails), B x 3 each; empty:
  // the segments come from the rest frames.
  MatX3d seg_heads, seg_tails;
  std::vector<std::vector<int>> children;  // per bone, the bones it is the parent of (see setup_clearance)
  std::vector<int> parent;                 // per bone, its parent (-1: none)
  Eigen::MatrixXd clearance;

  void setup();
  void setup_clearance();
  void posed_segments(const std::vector<Mat4>& pose, std::vector<Vec3>& h, std::vector<Vec3>& v) const;
  void clear_bones(MatX3d& Sd, const std::vector<Mat4>& pose, double fraction = 1) const;
  void setup_integration();
  void integrate_skeleton(MatX3d& Sd, const MatX9d& lin, const std::vector<Mat4>& pose) const;
  // Joint fillets (SkeletalDeformOptions::joint_fillet): per joint (a bone p and a child c whose head
  // starts at p's tail) the extent of its weight blend along the joint's mean rest axis and the limb's
  // radius there (see setup_fillets); per pose, the bent joints' fillets (joint_fillet.h) with the
  // parent's motion and the child's motion relative to it.
  struct FilletJoint {
    int p = -1, c = -1;
    double blend_extent = 0, radius = 0;
    // The control vertices with a share of the joint (fillet_share > 0), by their own weights (the
    // surface) and by their coincident group's (the skeletal mesh): a pose visits only these.
    std::vector<int> surface, skeleton;
  };
  std::vector<FilletJoint> fillet_joints;
  struct PosedFillet {
    const FilletJoint* joint = nullptr;
    JointFillet fillet;
    Mat4 parent;        // the parent bone's motion pose * rest^-1
    bool ring = false;  // the child's twist shared by the ring weights (SkeletalDeformOptions::ring_twist)
  };
  void setup_fillets();
  std::vector<PosedFillet> pose_fillets(const std::vector<Mat4>& pose, double radius_scale, bool ring,
                                        double fade) const;
  void fillet_skeleton(MatX3d& Sd, MatX9d& lin, const std::vector<PosedFillet>& fillets) const;
  void fillet_surface(MatX3d& X, const std::vector<PosedFillet>& fillets, const std::vector<char>& edited) const;
  double fillet_twist_share(const PosedFillet& pf, int i, double wc) const {
    if (!pf.ring) return wc;
    const double s = W_ring(i, pf.joint->p) + W_ring(i, pf.joint->c);
    return s > 1e-12 ? W_ring(i, pf.joint->c) / s : wc;
  }
  bool ring_twist(const std::vector<Mat4>& pose, bool dual_quaternion, MatX3d& Sd, MatX9d& lin) const;
  MatX3d pose_skeleton(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt, MatX9d& lin,
                       MatX3d* blend = nullptr, std::vector<PosedFillet>* fillets = nullptr) const;
  void clear_surface(MatX3d& X, const std::vector<Mat4>& pose, double fraction, const std::vector<char>& edited) const;
  // The fold guard's constraint (SkeletalDeformOptions::fold_guard): a smoothed vertex is pushed back
  // out to `fraction` of its rest distance to the bones of `c` (the untangling's clearance: its own
  // bones, their parents and children; in a tight bend the smoothing pulls crease flesh towards the
  // other limb's bone), and keeps its position where the push cannot clear it (deep in a bend's
  // corner, away from one bone is towards the other) or where skip(i) (on a skeleton edit). None
  // when the clearance is off.
  template <class Skip>
  FoldGuard::Constrain clearance_constraint(const BoneClearance& c, Eigen::Index n, const std::vector<Mat4>& pose,
                                            double fraction, Skip skip) const {
    if (!(fraction > 0) || rest.size() < 2 || c.rest.size() != n) return {};
    auto hv = std::make_shared<std::pair<std::vector<Vec3>, std::vector<Vec3>>>();
    posed_segments(pose, hv->first, hv->second);
    return [&c, hv, fraction, skip](int i, Vec3& x) {
      if (skip(i)) return false;
      x = c.push(i, x, fraction, hv->first, hv->second);
      return c.clear(i, x, fraction, hv->first, hv->second);
    };
  }
  // The fold guard's trust in its reference (SkeletalDeformOptions::fold_guard): face f (corners
  // F.row(f) of the rest positions V0, the reference positions `ref`) is trusted when its normal in
  // `ref` does not point against its rest normal turned by the pose's bone rotations blended with
  // weights(f) (a bone weight row, see detail::blended_rotation). Where the reference
  // itself folds (a narrow blend's bare reconstruction in a tight bend) the thickness steps unfold
  // it; smoothing their displacement there would fold it again.
  template <class Ref, class Weights>
  FoldGuard::Trusted reference_trust(const MatX3i& F, const MatX3d& V0, const Ref& ref, const std::vector<Mat4>& pose,
                                     Weights weights) const {
    auto q = std::make_shared<std::vector<Eigen::Quaterniond>>();
    for (size_t j = 0; j < rest.size(); ++j)
      q->emplace_back(nearest_rotation((pose[j] * rest[j].inverse()).topLeftCorner<3, 3>()));
    return [&F, &V0, &ref, q, weights](int f) {
      const Mat3 r = blended_rotation(weights(f), *q);
      const auto normal = [&](const auto& P) {
        const Vec3 a = P.row(F(f, 0)).transpose().template cast<double>();
        return Vec3((Vec3(P.row(F(f, 1)).transpose().template cast<double>()) - a)
                        .cross(Vec3(P.row(F(f, 2)).transpose().template cast<double>()) - a));
      };
      return !(normal(ref).dot(r * normal(V0)) < 0);
    };
  }
  // A joint whose bend the pose changes (contact_slide): parent p, child c, unit bone directions a,
  // b, the bisector plane's normal m through the joint J (rest: the same with 0), cos of half the
  // bend co, and the squared reach L2 from the joint at rest.
  struct ContactJoint {
    int p, c;
    Vec3 a0, b0, a, b, m0, m, J0, J;
    double co0 = 0, co = 0, L2 = 0, lp = 0, lc = 0;  // (lp, lc: the bones' lengths)
    // Distance from x to the two bones' segments, posed (J, a, b) or at rest (J0, a0, b0).
    double bone_distance(const Vec3& x, bool posed) const {
      const Vec3 &j = posed ? J : J0, &u = posed ? a : a0, &w = posed ? b : b0;
      return std::sqrt(std::min(segment_sq_dist(x, j - lp * u, j), segment_sq_dist(x, j, j + lc * w)));
    }
    // The limb of a vertex at rest position x0 with weight w on p and c together: +1 the child's,
    // -1 the parent's, 0 none (out of reach, on the plane, or mostly on other bones).
    double side(const Vec3& x0, double w) const {
      const double d = (x0 - J0).dot(m0);
      return d == 0 || (x0 - J0).squaredNorm() >= L2 || w <= 0.5 ? 0.0 : d > 0 ? 1.0 : -1.0;
    }
  };
  std::vector<ContactJoint> contact_joints(const std::vector<Mat4>& pose, double reach) const;
  // Returns whether some joint's bend changed (the slide acted; false when kappa < 1).
  template <class Out, class Weight>
  bool contact_slide(Out& X, const MatX3d& V0, const std::vector<Mat4>& pose, double kappa, Weight weight,
                     double reach = 1) const;
  // The fold guard's constraint with the joint contact on (kappa >= 1; else `inner` alone): after
  // `inner`, a smoothed vertex may not end deeper on the other limb's side of a joint's posed
  // bisector plane than it is in X (the slide has put it on its own side; averaging displacements
  // across the plane would pull it back over). X: the guard's positions, read before each write.
  template <class Cur, class Weight>
  FoldGuard::Constrain contact_constraint(FoldGuard::Constrain inner, const MatX3d& V0, const Cur& X,
                                          const std::vector<Mat4>& pose, double kappa, Weight weight) const {
    if (!(kappa >= 1)) return inner;
    auto joints = std::make_shared<std::vector<ContactJoint>>(contact_joints(pose, 1));
    if (joints->empty()) return inner;
    return [inner = std::move(inner), joints, &V0, &X, weight](int i, Vec3& x) {
      if (inner && !inner(i, x)) return false;
      const Vec3 x0 = row3(V0, i), now = X.row(i).transpose().template cast<double>();
      for (const ContactJoint& j : *joints) {
        const double s = j.side(x0, weight(i, j.p) + weight(i, j.c));
        if (s != 0 && s * (x - j.J).dot(j.m) < std::min(0.0, s * (now - j.J).dot(j.m))) return false;
      }
      return true;
    };
  }
  // A dense vertex's weight to bone j (multiresolution layer): the mean over its base face's corners.
  double dense_weight(int i, int j) const {
    const int f = multires->base_face()[i];
    return (W(control.F(f, 0), j) + W(control.F(f, 1), j) + W(control.F(f, 2), j)) / 3;
  }
  bool follows_or_parent(const Eigen::Ref<const Eigen::RowVectorXd>& w, int j) const;
  bool follows_or_adjacent(const Eigen::Ref<const Eigen::RowVectorXd>& w, int j) const;
  void untangle(MatX3d& X, const MatX3d& Sd, const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt,
                const std::vector<char>& edited) const;
  template <class Out>
  void untangle_dense(Out& out, const MatX3d& Sd, const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt,
                      const std::vector<char>& edited) const;
  MatX3d solve(const MatX3d& b) const {
    Eigen::MatrixXd B = b;
    Eigen::MatrixXd X = solver.solve(B);
    return X;
  }
  std::vector<Mat3> triangle_rotations(const MatX3d& Sd, const MatX9d& lin, const Twist* tw) const;
  void fair_variational(MatX3d& X, const MatX3d& Sd, const SkeletalDeformOptions& opt, std::vector<int>* deep,
                        const Twist* tw) const;
  std::vector<Mat4> twist_free_pose(const std::vector<Mat4>& pose, double& max_twist) const;
  bool make_twist(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt, const MatX3d& Sd_blend,
                  const MatX9d& lin, const MatX3d& Sd, Twist& tw) const;
  template <class Follows>
  BoneClearance union_clearance(const MatX3d& P, Follows follows) const;
  template <class Out>
  void project_dense(const MatX3d& Sd, const std::vector<int>& deep, const std::vector<Mat4>& pose,
                     const SkeletalDeformOptions& opt, const std::vector<char>& edited, const Twist* tw,
                     Out& out) const;
  // `edited` (when `skeleton` is given) receives, per control vertex, whether the edit moved it;
  // `tw` the vertices' twists (follow_twist; left empty when the option is off or the pose has none).
  MatX3d control_pose(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt, MatX3d* Sd_out,
                      std::vector<int>* deep = nullptr, const MatX3d* skeleton = nullptr,
                      std::vector<char>* edited = nullptr, Twist* tw = nullptr) const;
  MatX3d variational(const MatX3d& Sd, const MatX9d& lin, const SkeletalDeformOptions& opt, std::vector<int>* deep,
                     const Twist* tw, MatX3d* bare = nullptr, const std::vector<PosedFillet>* fillets = nullptr,
                     const std::vector<char>* edited = nullptr) const;
  MatX3d basic(const MatX3d& Sd, const SkeletalDeformOptions& opt) const;
};

void SkeletalRig::Impl::setup() {
  const MatX3d& X = control.V;
  const MatX3i& F = control.F;
  const int n = static_cast<int>(X.rows()), m = static_cast<int>(F.rows());
  corners = vertex_corners(F, n);
  radii.resize(n);
  dirs.resize(n, 3);
  rest_normals = vertex_normals(X, F, control.topo, NormalWeights::Area);
  if (signed_volume(X, F) < 0) rest_normals = -rest_normals;
  for (int i = 0; i < n; ++i) {
    const Vec3 d = row3(X, i) - row3(S, i);
    radii[i] = d.norm();
    // A vertex on its own skeleton (radius 0) keeps a direction: its normal.
    dirs.row(i) =
        radii[i] > 1e-12 ? Eigen::RowVector3d((d / radii[i]).transpose()) : Eigen::RowVector3d(rest_normals.row(i));
  }
  r_max = radii.maxCoeff();
  setup_clearance();
  {
    MatX3d dir(bone_vec.size(), 3);
    for (size_t j = 0; j < bone_vec.size(); ++j) dir.row(static_cast<Eigen::Index>(j)) = bone_vec[j].transpose();
    W_ring = dgmesh::ring_weights(X, F, W, dir, radii);
  }
  cot.resize(m, 3);
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(m) * 9 + n);
  for (int i = 0; i < n; ++i) trip.emplace_back(i, i, 1.0);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3), c = F(f, (k + 2) % 3);
      const Vec3 u = row3(X, b) - row3(X, a), v = row3(X, c) - row3(X, a);
      const double s = u.cross(v).norm();
      const double ct = s > 1e-300 ? u.dot(v) / s : 0.0;
      cot(f, k) = ct;  // weight of the opposite edge (b, c)
      trip.emplace_back(b, b, ct);
      trip.emplace_back(c, c, ct);
      trip.emplace_back(b, c, -ct);
      trip.emplace_back(c, b, -ct);
    }
  SpMat A(n, n);
  A.setFromTriplets(trip.begin(), trip.end());
  // L0 is factorised once (the thesis's UMFPACK); each pose is a right-hand side (eq. 6.11).
  // The block I + L_M is symmetric (cotangent weights), so LDL^T (fewer instructions per solve than
  // UMFPACK's, which adds iterative refinement; measured with callgrind).
  solver.factor(A, SparseSolver::Kind::Cholesky);
  double e2 = 0;
  int ne = 0;
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) e2 += (row3(S, F(f, k)) - row3(S, F(f, (k + 1) % 3))).squaredNorm(), ++ne;
  mu = frame_regularization * std::max(e2 / std::max(ne, 1), 1e-20);
  f_rest = union_of_balls_distance(X, S, radii, &rest_arg);
  if (multires) {
    // The dense rest positions as the layer reconstructs them (equal to the bound mesh up to
    // rounding), so that the rest pose is a fixed point of project_dense.
    const MatX3d Xd = multires->reconstruct(X);
    dense_rest = Xd;
    dense_f_rest = union_of_balls_distance(Xd, S, radii, &dense_arg);
    // A dense vertex's limit point and frame depend on the control vertices of its base face and
    // their 1-rings (Loop stencils); where all of them follow one bone alone, SSD and the
    // reconstruction move the neighbourhood rigidly and, when its rest minimising ball follows the
    // same bone alone too, eq. 6.13 keeps its rest value (up to the global solve's small spread), so
    // the dense step is skipped there (most of a body whose limb alone moves). The ball condition
    // matters where a pole lies across the limb (camel knee through a 5000-face control mesh: 18
    // vertices whose ball follows the knee's blend were skipped; bones min ratio 0.82 -> 0.95 in the
    // bench skeletal_limb's bend).
    std::vector<int> solo(n, -1);
    for (int i = 0; i < n; ++i) {
      Eigen::Index j;
      if (W.row(i).maxCoeff(&j) >= 1 - 1e-9) solo[i] = static_cast<int>(j);
    }
    std::vector<int> ring_solo(n, -1);
    for (int i = 0; i < n; ++i) {
      int b = solo[i];
      for (int k = control.topo.vv_offset[i]; b >= 0 && k < control.topo.vv_offset[i + 1]; ++k)
        if (solo[control.topo.vv_index[k]] != b) b = -1;
      ring_solo[i] = b;
    }
    const VecXi& face = multires->base_face();
    dense_rigid.assign(Xd.rows(), 0);
    for (Eigen::Index i = 0; i < Xd.rows(); ++i) {
      const int b = ring_solo[F(face[i], 0)];
      dense_rigid[i] =
          b >= 0 && ring_solo[F(face[i], 1)] == b && ring_solo[F(face[i], 2)] == b && ring_solo[dense_arg[i]] == b;
    }
    // A dense vertex is driven by the control vertices of its base face (and their rings): it
    // follows the bones those three have weight on, and their parents (adding the rings' bones
    // changed no minimum ratio of bench skeletal_limb). Vertices that move rigidly with one bone (dense_rigid) are
    // skipped by project_dense, as by its thickness step.
    if (dense_F.rows() > 0) {
      const int nd = static_cast<int>(Xd.rows());
      std::vector<std::pair<int, int>> edges;
      edges.reserve(static_cast<size_t>(dense_F.rows()) * 6);
      dense_faces.clear();
      for (Eigen::Index f = 0; f < dense_F.rows(); ++f) {
        bool rigid = true;
        for (int k = 0; k < 3; ++k) {
          const int a = dense_F(f, k), b = dense_F(f, (k + 1) % 3);
          edges.emplace_back(a, b), edges.emplace_back(b, a);
          rigid = rigid && dense_rigid[a];
        }
        if (!rigid) dense_faces.push_back(static_cast<int>(f));
      }
      std::sort(edges.begin(), edges.end());
      edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
      dense_vv_offset.assign(nd + 1, 0);
      dense_vv_index.resize(edges.size());
      for (size_t k = 0; k < edges.size(); ++k)
        ++dense_vv_offset[edges[k].first + 1], dense_vv_index[k] = edges[k].second;
      for (int i = 0; i < nd; ++i) dense_vv_offset[i + 1] += dense_vv_offset[i];
      dense_tree = SelfIntersectionTree(Xd, dense_F, &dense_faces);
      dense_rest_pairs = dense_tree.pairs(Xd);
      dense_guard = FoldGuard(dense_F, nd);
    }
    dense_untangle_clearance = union_clearance(Xd, [&](int i, int j) {
      const int f = face[i];
      return follows_or_adjacent(W.row(F(f, 0)), j) || follows_or_adjacent(W.row(F(f, 1)), j) ||
             follows_or_adjacent(W.row(F(f, 2)), j);
    });
    dense_clearance = union_clearance(Xd, [&](int i, int j) {
      const int f = face[i];
      return follows_or_parent(W.row(F(f, 0)), j) || follows_or_parent(W.row(F(f, 1)), j) ||
             follows_or_parent(W.row(F(f, 2)), j);
    });
  }
  {
    std::vector<double> rs(radii.data(), radii.data() + n);
    const double eps = 1e-3 * std::max(median(rs), 1e-12);
    contact_margin = 10 * eps;
    std::vector<int> order(n);
    for (int i = 0; i < n; ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](int a, int b) { return radii[a] > radii[b]; });
    std::vector<char> covered(n, 0);
    const KdTree tree(S);
    std::vector<std::pair<int, double>> near;
    reps.clear();
    rep_of.assign(n, -1);
    for (int i : order) {
      if (covered[i]) continue;
      reps.push_back(i);
      tree.radius(row3(S, i), eps, near);
      for (const auto& [j, d2] : near)
        if (!covered[j]) covered[j] = 1, rep_of[j] = static_cast<int>(reps.size()) - 1;
    }
  }
  setup_integration();
  setup_fillets();
}

std::vector<Mat3> SkeletalRig::Impl::triangle_rotations(const MatX3d& Sd, const MatX9d& lin, const Twist* tw) const {
  // follow_twist: the frames are fitted in the twist-free pose (the skeletal vertices carried back by
  // their own twist, whose blended rotations are R_i^T lin_i) and turned by the triangle's twist, the
  // rotation nearest its corners' mean. (Each corner's displacement turned by its own vertex's twist
  // instead makes a pure twist exactly the dual quaternion skinning of the surface, DQS's folds
  // included: the capsule of bench/tools/skeletal_twist_capsule.py twisted 180 degrees over its
  // narrow Gaussian blend had 191 self-intersecting pairs, DQS 155, the triangle's twist 0.)
  const bool free = tw != nullptr;
  const MatX3i& F = control.F;
  const int m = static_cast<int>(F.rows());
  std::vector<Mat3> R(m);
#pragma omp parallel for schedule(static) if (m >= kParallelHeavy)
  for (int f = 0; f < m; ++f) {
    // Frame change B_d B_0^-1 of the skeletal triangle (eq. 6.8) as the rotation that best maps
    // its rest edges to its deformed edges; the blended bone rotation fills the directions a
    // degenerate (collinear or collapsed) triangle leaves undetermined.
    const MatX3d& P = free ? tw->Ss : Sd;
    auto frame = [&](int v) -> Mat3 {
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> L(lin.row(v).data());
      return free ? Mat3(tw->R[v].transpose() * L) : Mat3(L);
    };
    Mat3 C = Mat3::Zero();
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      C += (row3(P, b) - row3(P, a)) * (row3(S, b) - row3(S, a)).transpose();
    }
    Mat3 M = Mat3::Zero();
    for (int k = 0; k < 3; ++k) M += frame(F(f, k));
    const Mat3 A = C + (mu / 3) * M;
    // The first corner's frame rotation (exactly orthonormal) seeds Newton's method.
    const Mat3 G = frame(F(f, 0));
    if (!polar_near(A, G, R[f])) R[f] = nearest_rotation(A);
    if (free) {
      const Mat3 T = tw->R[F(f, 0)] + tw->R[F(f, 1)] + tw->R[F(f, 2)];
      Mat3 Rt;
      if (!polar_near(T, tw->R[F(f, 0)], Rt)) Rt = nearest_rotation(T);
      R[f] = Rt * R[f];
    }
  }
  return R;
}

// bare (optional): receives the reconstruction before the fairing (eq. 6.11).
MatX3d SkeletalRig::Impl::variational(const MatX3d& Sd, const MatX9d& lin, const SkeletalDeformOptions& opt,
                                      std::vector<int>* deep, const Twist* tw, MatX3d* bare,
                                      const std::vector<PosedFillet>* fillets, const std::vector<char>* edited) const {
  const int n = static_cast<int>(S.rows());
  const std::vector<Mat3> R = triangle_rotations(Sd, lin, tw);
  // Right-hand side (eq. 6.12) summed over the fragments x^T of the triangles around each vertex
  // (eq. 6.8), plus the s^d column moved over from L0 u (the skeleton is the fixed boundary).
  MatX3d b(n, 3);
#pragma omp parallel for schedule(static) if (n >= kParallelHeavy)
  for (int i = 0; i < n; ++i) {
    Vec3 acc = row3(Sd, i);
    const int c0 = corners.offset[i], c1 = corners.offset[i + 1];
    const double inv_T = c1 > c0 ? 1.0 / (c1 - c0) : 0.0;
    for (int c = c0; c < c1; ++c) {
      const Corner& cr = corners.corners[c];
      const Mat3& Rf = R[cr.face];
      const int j = cr.next, k = cr.prev;
      const Vec3 xi = row3(Sd, i) + radii[i] * (Rf * row3(dirs, i));
      const Vec3 xj = row3(Sd, j) + radii[j] * (Rf * row3(dirs, j));
      const Vec3 xk = row3(Sd, k) + radii[k] * (Rf * row3(dirs, k));
      const double w1 = cot(cr.face, (cr.local + 2) % 3);  // angle at k, opposite edge (i, j)
      const double w2 = cot(cr.face, (cr.local + 1) % 3);  // angle at j, opposite edge (i, k)
      acc += w1 * (xi - xj) + w2 * (xi - xk) + inv_T * (xi - row3(Sd, i));
    }
    b.row(i) = acc.transpose();
  }
  MatX3d X = solve(b);
  if (fillets) fillet_surface(X, *fillets, edited ? *edited : std::vector<char>{});
  if (bare) *bare = X;
  if (opt.fairing_steps > 0) fair_variational(X, Sd, opt, deep, tw);
  return X;
}

// The dense mesh through the multiresolution layer (thesis 6.4 / end of 6.5) is the Loop limit
// surface of the deformed control mesh plus the displacements, and a limit surface is not
// thickness-preserving: where a bend or twist shears the coarse control triangles (a 180-degree
// twist turns a ring of the control mesh by up to ~0.6 rad against the next), the limit surface
// cuts the chords of the sheared, helical control polygon and the tube thins (capsule: the dense
// distance to the skeleton drops to 0.92 of its rest value while the control vertices keep 0.994).
// So the explicit step of the flow eq. 6.14 that ends the control mesh's fairing
// (SkeletalDeformOptions::projection) is applied to the dense vertices as well: each moves by w
// times its offset from its rest signed distance to the union of the control mesh's deformed medial
// balls (eq. 6.13), along the direction from the minimising ball's centre, in up to
// dense_projection_passes passes (a vertex pushed out of one ball may land in another).
// Candidate balls: the vertex's rest minimiser and its skeletal 1-ring, the previous pass's
// minimiser and its ring, and the kDenseBalls deepest balls at each of the three control vertices
// of the vertex's base face (exact, from the control mesh's projection over all posed balls: balls
// of other parts a pose brought close; see fair_variational). A tree query per dense vertex would
// cost more than the rest of the deform (capsule of bench skeletal_speed: 27 instead of 11 ms); the
// skeletal 1-ring alone misses where a pose folds or turns the medial sheet, whose graph neighbours
// are then not its spatial ones (camel leg twisted 180 degrees through a 5000-face control mesh,
// linear skeleton blend: the worst vertices' deepest ball lay 2-5 rings from their rest one; with the
// corners' 1, 2, 4, 8 deepest balls, 0%, 92%, 99.6%, 100% of that error sat on vertices whose
// deepest ball was among them). Bench skeletal_limb's legs through the layer, dual-quaternion
// skeleton, sum (f - f_rest)^2 against the control skeleton over DQS's, without / with the corners'
// balls: camel bend 0.16 / 0.019, twist 0.49 / 0.17; armadillo 0.25 / 0.034, 0.62 / 0.049. At rest
// and under rigid motions f equals f_rest: a fixed point.
// tw (follow_twist): the thickness is measured in the twist-free pose, as in fair_variational: each
// dense vertex the step visits is carried there by its twist, the dual quaternion blend of its base
// face's corners' twists (barycentric weights), measured against the balls carried back (tw->Ss) and
// turned back before the bone clearance. `out` is the limit surface of the posed control mesh.
// Armadillo waist twisted 180 degrees through a 5000-face control mesh
// (bench/tools/skeletal_twist_probe.py), self-intersecting pairs: measured in the pose 973 (DQS 0);
// rebuilt from the control mesh carried to the twist-free pose, measured there and turned by each
// dense vertex's own bone weights' twist 1, but the 178K capsule of skeletal_speed (bound without
// weights, its Gaussian weights blending the bones over a tenth of their length) twisted 180 degrees
// 3037: carried back vertex by vertex, the coarse control mesh around so narrow a twist is no longer
// its rest shape, and the limit surface of it folds; rebuilt in the pose and measured in the
// twist-free pose, as here, 16 and 0 (bench/notes/skeletal.md, session 36).
template <class Out>
void SkeletalRig::Impl::project_dense(const MatX3d& Sd_pose, const std::vector<int>& deep,
                                      const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt,
                                      const std::vector<char>& edited, const Twist* tw, Out& out) const {
  const MatX3d& Sd = tw ? tw->Ss : Sd_pose;
  const MatX2d& st = multires->base_st();
  const int n = static_cast<int>(out.rows());
  const Topology& topo = control.topo;
  const VecXi& face = multires->base_face();
  const MatX3i& F = control.F;
  const double w = opt.projection;
  const int passes = w > 0 ? std::max(opt.dense_projection_passes, 1) : 0;
  const bool have_deep = deep.size() == static_cast<size_t>(control.V.rows()) * kDenseBalls;
  // Then the surface bone clearance, as clear_surface does for the control vertices (a limit
  // surface rounds the control mesh's crease and comes closer to the bones than its vertices: camel
  // knee through a 5000-face control mesh, min ratio 0.19 without this step).
  const bool clear = opt.bone_clearance > 0 && dense_clearance.rest.size() == out.rows();
  std::vector<Vec3> h, v;
  if (clear) posed_segments(pose, h, v);
    // Dynamic chunks: the vertices that are not skipped cluster where the pose bends the mesh, and a
    // static split can hand most of them to one thread.
#pragma omp parallel for schedule(dynamic, 4096) if (n >= kParallelMin)
  for (int i = 0; i < n; ++i) {
    // A vertex that one bone moves rigidly skips the thickness step but not the bone clearance: the
    // global solve's small spread moves it slightly, which matters next to its bone (camel shin,
    // 1.7 mm from the bone: bones min ratio 0.84 in bench skeletal_limb's twist without it).
    // A skeleton edit on the vertex's base face makes it move non-rigidly: no skip, no clearance.
    const bool on_edit = !edited.empty() && (edited[F(face[i], 0)] || edited[F(face[i], 1)] || edited[F(face[i], 2)]);
    const bool rigid = dense_rigid[i] && !on_edit;
    if (rigid && !clear) continue;
    Vec3 x = out.row(i).transpose().template cast<double>();
    Mat3 Rt;
    Vec3 tt;
    const bool turn = tw && !rigid;  // (a rigid vertex's turn there and back cancels)
    if (turn) {
      const int c[3] = {F(face[i], 0), F(face[i], 1), F(face[i], 2)};
      const double b[3] = {1 - st(i, 0) - st(i, 1), st(i, 0), st(i, 1)};
      tw->blend(c, b, 3, Rt, tt);
      x = Rt.transpose() * (x - tt);
    }
    int prev = -1;
    for (int pass = 0; pass < (rigid ? 0 : passes); ++pass) {
      int arg = dense_arg[i];
      double best = (x - row3(Sd, arg)).norm() - radii[arg];
      double second = std::numeric_limits<double>::infinity();
      auto consider = [&](int j) {
        const double f = (x - row3(Sd, j)).norm() - radii[j];
        if (f < best) {
          if (j != arg) second = best;
          best = f, arg = j;
        } else if (f < second && j != arg) {
          second = f;
        }
      };
      auto ring = [&](int c) {
        for (int k = topo.vv_offset[c]; k < topo.vv_offset[c + 1]; ++k) consider(topo.vv_index[k]);
      };
      ring(dense_arg[i]);
      if (have_deep)
        for (int k = 0; k < 3; ++k) {
          const int* d = deep.data() + static_cast<size_t>(F(face[i], k)) * kDenseBalls;
          for (int m = 0; m < kDenseBalls && d[m] >= 0; ++m) consider(d[m]);
        }
      if (prev >= 0) consider(prev), ring(prev);
      const double f = std::min(best - dense_f_rest[i], 0.0);  // one-sided, as the control step
      if (std::abs(f) <= 1e-6 * r_max) break;
      const Vec3 d = x - row3(Sd, arg);
      const double len = d.norm();
      if (!(len > 1e-300)) break;
      x -= (w * f / len) * d;
      // With w = 1 the vertex now lies at its target for this ball, and the move changed every
      // ball's value by at most |f|. Another pass sees the same candidates unless the minimiser is
      // new (its ring joins), and can only find one below its target if it was within |f| of it.
      if (w == 1 && (arg == prev || arg == dense_arg[i]) && second - dense_f_rest[i] >= std::abs(f)) break;
      prev = arg;
    }
    if (turn) x = Rt * x + tt;
    if (clear && !on_edit) x = dense_clearance.push(i, x, opt.bone_clearance, h, v);
    out.row(i) = x.transpose().template cast<typename Out::Scalar>();
  }
}

// deep: when given, receives n x kDenseBalls deepest balls per vertex from the first projection
// pass (padded with -1; for project_dense).
// tw (follow_twist): the thickness is measured in the twist-free pose: vertex i at tw->to_free(i, x)
// against the balls centred at tw->Ss, its step turned back by its twist.
void SkeletalRig::Impl::fair_variational(MatX3d& X, const MatX3d& Sd_pose, const SkeletalDeformOptions& opt,
                                         std::vector<int>* deep, const Twist* tw) const {
  const int n = static_cast<int>(X.rows());
  const MatX3d& Sd = tw ? tw->Ss : Sd_pose;
  MatX3d C(static_cast<Eigen::Index>(reps.size()), 3);
  for (size_t r = 0; r < reps.size(); ++r) C.row(static_cast<Eigen::Index>(r)) = Sd.row(reps[r]);
  const KdTree tree(C, 8);
  // The explicit projection passes move each vertex out to its rest distance to the union of the
  // balls, which needs the ball that minimises eq. 6.13, not a near one: the local candidates
  // (rest minimiser's ring, the k nearest centres) miss the large balls of the other limb that a
  // joint's crease runs into, and the vertex stays inside them. Armadillo knee bent 90 degrees (bench
  // skeletal_limb): sum (f - f_rest)^2 276 -> 83 (DQS 1197). Its cost (skeletal_speed): the 2502-vertex
  // control mesh deforms in 4.2 ms instead of 3.3, a whole 178K-vertex deform in 9.7 instead of 8.6.
  std::optional<BallTree> balls;
  if (opt.projection > 0) balls.emplace(Sd, radii, reps);
  if (deep) deep->assign(opt.projection > 0 ? static_cast<size_t>(n) * kDenseBalls : 0, -1);
  MatX3d G(n, 3);
  // The explicit projection step is repeated (at most opt.projection_passes, until a pass moves no
  // vertex): in a bend's inner crease one step moves a vertex out of one ball into a neighbour's
  // (camel knee, 90 degrees: sum (f - f_rest)^2 1.9e-4 after one pass, 8e-5 after three). A vertex
  // whose pass moved it by less than `tol` has converged (its balls are fixed; only its own move
  // changes f) and is skipped: the extra passes cost only where the pose changed the thickness.
  const int total = opt.fairing_steps + (opt.projection > 0 ? std::max(opt.projection_passes, 1) - 1 : 0);
  const double tol2 = 1e-12 * r_max * r_max;
  std::vector<int> prev(n, -1);
  // The kd-tree candidates of each vertex are queried in the first step and again only when the
  // vertex has moved by more than 1% of its medial radius since its last query (its nearest centres
  // can have changed); otherwise the stored ones are reused (with the rest minimiser's ring and the
  // previous step's minimiser's ring, always candidates). Most vertices of a pose move rigidly or
  // barely between steps: the queries were ~60% of the control deform (capsule of bench
  // skeletal_speed: 8.5 -> 5.2 ms CPU per control deform). Against querying in every step, the camel
  // knee (bench skeletal_limb) keeps the same minimum ratios and a slightly lower sum (f - f_rest)^2
  // (0.063 vs 0.086 of DQS's in the bend: the previous minimiser's ring now joins every step).
  constexpr double kRequery2 = 1e-4;
  std::vector<int> cand(static_cast<size_t>(n) * kUnionNeighbours, -1);
  MatX3d Xq(n, 3);
  for (int step = 0, moved = 1; step <= total && moved; ++step) {
    const bool last = step >= opt.fairing_steps;
    if (last && !(opt.projection > 0)) break;
    moved = 0;
    // F(u) = f grad f at the mesh vertices, 0 at the skeleton (eq. 6.14); f is measured against
    // its rest value so that the rest pose and rigid motions are fixed points.
#pragma omp parallel for schedule(dynamic, 64) if (n >= kParallelHeavy) reduction(| : moved)
    for (int i = 0; i < n; ++i) {
      const bool extra = step > opt.fairing_steps;
      if (extra && G.row(i).squaredNorm() <= tol2) {
        G.row(i).setZero();
        continue;
      }
      int p;
      const Vec3 x = tw ? tw->to_free(i, row3(X, i)) : row3(X, i);
      const bool query = step == 0 || (x - row3(Xq, i)).squaredNorm() > kRequery2 * radii[i] * radii[i];
      if (query) Xq.row(i) = x.transpose();
      double f;
      if (last) {
        // The projection passes take the exact minimum (see `balls`), from the rest minimiser's
        // ball: exact at rest and under rigid motions, so those stay fixed points.
        p = rest_arg[i];
        f = (x - row3(Sd, p)).norm() - radii[p];
        balls->query(x, f, p);
        if (deep && !extra) {
          // Where the pose changed this vertex's thickness (by over 1% of its ball's radius), the
          // kDenseBalls deepest balls, else the deepest alone: a K-deepest search prunes far less
          // than the deepest's (on the capsule of bench skeletal_speed, 142 tree nodes per query
          // against 35), and where the thickness is unchanged the pose has brought no ball close.
          // Camel and armadillo legs (bench skeletal_limb, linear skeleton blend): the same sum
          // (f - f_rest)^2 with 1% or 3% as with every vertex; 10% lets the camel's twist rise from
          // 0.20 to 0.26 of DQS's.
          int* d = deep->data() + static_cast<size_t>(i) * kDenseBalls;
          double val[kDenseBalls];
          std::fill(val, val + kDenseBalls, std::numeric_limits<double>::infinity());
          std::fill(d, d + kDenseBalls, -1);
          d[0] = p, val[0] = f;
          if (std::abs(f - f_rest[i]) > 0.01 * radii[i]) balls->template deepest<kDenseBalls>(x, d, val);
        }
      } else {
        f = union_distance_local(tree, reps, Sd, radii, r_max, control.topo, x, rest_arg[i], p, step > 0 ? prev[i] : -1,
                                 query, cand.data() + static_cast<size_t>(i) * kUnionNeighbours);
      }
      f -= f_rest[i];
      if (last) f = std::min(f, 0.0);  // one-sided (see SkeletalDeformOptions::projection)
      prev[i] = p;
      const Vec3 d = x - row3(Sd, p);
      const double len = d.norm();
      G.row(i) = len > 1e-300 ? Eigen::RowVector3d((f / len * d).transpose()) : Eigen::RowVector3d::Zero();
      if (tw) G.row(i) = (tw->R[i] * row3(G, i)).transpose();
      moved |= !last || G.row(i).squaredNorm() > tol2;
    }
    if (last) {
      X -= opt.projection * G;  // explicit step (see SkeletalDeformOptions::projection)
      continue;
    }
    // Semi-implicit step (eq. 6.15): u <- u - eps L0^-1 F(u), a descent step on f^2.
    X -= opt.fairing_step * solve(G);
  }
}

MatX3d SkeletalRig::Impl::basic(const MatX3d& Sd, const SkeletalDeformOptions& opt) const {
  const MatX3i& F = control.F;
  const Topology& topo = control.topo;
  const int n = static_cast<int>(S.rows()), m = static_cast<int>(F.rows());
  const double sign = signed_volume(control.V, F) < 0 ? -1.0 : 1.0;
  // Homotopy (eq. 6.3-6.4): the directions N_j follow the rotation of the mesh normals of M_{j-1}
  // (so that the rest pose is a fixed point; N_0 = (x - s)/d).
  MatX3d N = dirs, X = control.V;
  const int L = std::max(opt.homotopy_steps, 1);
  for (int j = 1; j <= L; ++j) {
    if (j > 1) {
      const MatX3d Nm = sign * vertex_normals(X, F, topo, NormalWeights::Area);
#pragma omp parallel for schedule(static)
      for (int i = 0; i < n; ++i)
        N.row(i) = (rotation_between(row3(rest_normals, i), row3(Nm, i)) * row3(dirs, i)).transpose();
    }
    const double t = double(j) / L;
    for (int i = 0; i < n; ++i) X.row(i) = (1 - t) * S.row(i) + t * Sd.row(i) + radii[i] * N.row(i);
  }
  const SpMatR Wu = umbrella_matrix(X, topo, Umbrella::Uniform);
  const double dt = 0.5;
  // Folds and protrusions (eq. 6.5): bi-umbrella relaxation where the umbrella field is regular,
  // the pull E_T grad E_T of each mesh triangle's centroid to the convex hull of its skeletal
  // triangle's balls, averaged over a vertex's triangles, and the tangential bi-umbrella drift V.
  std::vector<Vec3> g(m);
  for (int it = 0; it < opt.fold_iterations; ++it) {
    const MatX3d U = Wu * X;
    const MatX3d U2 = Wu * U;
#pragma omp parallel for schedule(static) if (m >= kParallelMin)
    for (int f = 0; f < m; ++f) {
      const Vec3 C = (row3(X, F(f, 0)) + row3(X, F(f, 1)) + row3(X, F(f, 2))) / 3;
      Vec3 grad;
      const double E = ball_hull_distance(C, {row3(Sd, F(f, 0)), row3(Sd, F(f, 1)), row3(Sd, F(f, 2))},
                                          Vec3(radii[F(f, 0)], radii[F(f, 1)], radii[F(f, 2)]), &grad);
      g[f] = E * grad;
    }
    MatX3d Fe = MatX3d::Zero(n, 3);
    std::vector<int> cnt(n, 0);
    for (int f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k) Fe.row(F(f, k)) += g[f].transpose(), ++cnt[F(f, k)];
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
      if (cnt[i] == 0) continue;
      const Vec3 Fi = row3(Fe, i) / cnt[i];
      const Vec3 u = row3(U, i);
      int obtuse = 0, c = 0;
      for (int k = topo.vv_offset[i]; k < topo.vv_offset[i + 1]; ++k, ++c)
        if (u.dot(row3(U, topo.vv_index[k])) < 0) ++obtuse;
      const double alpha = c > 0 && obtuse < 0.3 * c ? 0.25 : 0.0;
      const Vec3 b2 = row3(U2, i);
      const double fl = Fi.norm();
      const Vec3 Vt = fl > 1e-300 ? Vec3(b2 - b2.dot(Fi / fl) * (Fi / fl)) : b2;
      X.row(i) += dt * (-alpha * b2 - Fi - Vt).transpose();
    }
  }
  // Global and local self-intersections (eq. 6.6): pull to the union of the balls (eq. 6.13
  // through the kd-tree in place of the thesis's 20^3 voxel grid), bi-umbrella weighted by how far
  // the union departs from the vertex's own ball.
  const KdTree tree(Sd);
  for (int it = 0; it < opt.fairing_steps * 5; ++it) {
    const MatX3d U2 = Wu * (Wu * X);
    MatX3d G(n, 3);
    VecXd Wd(n);
#pragma omp parallel
    {
      std::vector<std::pair<int, double>> scratch;
#pragma omp for schedule(dynamic, 256)
      for (int i = 0; i < n; ++i) {
        int p;
        const Vec3 x = row3(X, i);
        const double f = union_distance(tree, Sd, radii, r_max, x, i, p, scratch) - f_rest[i];
        const double own = (x - row3(Sd, i)).norm() - radii[i];
        Wd[i] = std::abs(f - own);
        const Vec3 d = x - row3(Sd, p);
        const double len = d.norm();
        G.row(i) = len > 1e-300 ? Eigen::RowVector3d((f / len * d).transpose()) : Eigen::RowVector3d::Zero();
      }
    }
    const double wmax = Wd.maxCoeff();
    for (int i = 0; i < n; ++i) {
      const double w = wmax > 0 ? Wd[i] / wmax : 0.0;
      X.row(i) -= dt * (G.row(i) + w * U2.row(i));
    }
  }
  return X;
}

// ---------------------------------------------------------------------------------------------

namespace {
// The stick skeleton (bone_heads, bone_tails) given at bind or in saved data: both empty, or B x 3,
// finite, every bone of non-zero length.
void check_segments(const MatX3d& heads, const MatX3d& tails, int B, const char* what) {
  if (heads.rows() == 0 && tails.rows() == 0) return;
  if (heads.rows() != B || tails.rows() != B)
    throw MeshError(std::string(what) + ": bone heads and tails must have one row per bone (" + std::to_string(B) +
                    "), got " + std::to_string(heads.rows()) + " and " + std::to_string(tails.rows()));
  if (!heads.allFinite() || !tails.allFinite())
    throw MeshError(std::string(what) + ": bone heads and tails must be finite");
  for (int j = 0; j < B; ++j)
    if (!((row3(tails, j) - row3(heads, j)).norm() > 0))
      throw MeshError(std::string(what) + ": bone " + std::to_string(j) + " has its tail at its head (zero length)");
}
}  // namespace

SkeletalRig SkeletalRig::bind(const MatX3d& V, const MatX3i& F, const std::vector<Mat4>& bones_rest,
                              const Eigen::MatrixXd& weights, const MatX3d& bone_heads, const MatX3d& bone_tails,
                              const SkeletalRigOptions& opt, const ProgressFn& progress) {
  Progress prog(progress);
  prog(0);
  const int B = static_cast<int>(bones_rest.size());
  if (B == 0) throw MeshError("skeletal bind: no deform bones");
  for (int j = 0; j < B; ++j)
    if (!bones_rest[j].allFinite() || std::abs(bones_rest[j].topLeftCorner<3, 3>().determinant()) < 1e-12)
      throw MeshError("skeletal bind: rest matrix of bone " + std::to_string(j) + " is singular or not finite");
  Mesh dense = make_mesh(V, F, kSurface | kNoLooseVertices);
  const int n = static_cast<int>(V.rows());
  if (!dense.topo.boundary_loops.empty())
    throw MeshError("skeletal bind: the mesh is open (" + std::to_string(dense.topo.boundary_loops.size()) +
                    " boundary loops); the skeletal representation M = S + dN needs a closed surface. Fill the "
                    "holes first, or use the Armature modifier for open meshes");
  const bool have_w = weights.size() > 0;
  if (have_w) {
    if (weights.rows() != n || weights.cols() != B)
      throw MeshError("skeletal bind: weights must be " + std::to_string(n) + " x " + std::to_string(B) + ", got " +
                      std::to_string(weights.rows()) + " x " + std::to_string(weights.cols()));
    if (!weights.allFinite() || weights.minCoeff() < 0)
      throw MeshError("skeletal bind: weights must be finite and >= 0");
    int zero = 0, first = -1;
    for (int i = 0; i < n; ++i)
      if (!(weights.row(i).sum() > 1e-12)) {
        if (first < 0) first = i;
        ++zero;
      }
    if (zero)
      throw MeshError("skeletal bind: " + std::to_string(zero) + " vertices (first: " + std::to_string(first) +
                      ") have no weight in any deform bone; weight them (e.g. automatic weights) or remove the weights "
                      "to use distance-based weights");
  } else if (bone_heads.rows() != B || bone_tails.rows() != B) {
    throw MeshError("skeletal bind: without weights, bone heads and tails (B x 3) are needed");
  }
  check_segments(bone_heads, bone_tails, B, "skeletal bind");

  auto impl = std::make_shared<Impl>();
  impl->rest = bones_rest;
  impl->seg_heads = bone_heads;
  impl->seg_tails = bone_tails;
  impl->frame_regularization = opt.frame_regularization;
  if (F.rows() > opt.control_faces) {
    MultiresOptions mo;
    mo.control_faces = opt.control_faces;
    mo.level = opt.multires_level;
    mo.fit_iterations = opt.multires_fit_iterations;
    impl->multires = Multires::build(dense, mo, [&](double f) {
      prog(0.6 * f);
      return true;
    });
    impl->dense_F = F;
    impl->control =
        make_mesh(impl->multires->control_vertices(), impl->multires->control_faces(), kSurface | kNoLooseVertices);
  } else {
    impl->control = std::move(dense);
  }
  prog(0.6);
  const SkeletalMesh sk = skeletal_mesh(impl->control, opt.skeleton);
  impl->S = sk.S;
  prog(0.85);
  const int nc = static_cast<int>(impl->control.V.rows());
  if (have_w) {
    Eigen::MatrixXd Wc(nc, B);
    if (impl->multires) {
      // Control vertices take the weights of their nearest dense vertex among those bound to the
      // faces around them (a Euclidean nearest can lie on another part that touches this one: three
      // control vertices of the camel's leg took the other leg's weights); the nearest of all where
      // none is bound there.
      const VecXi& face = impl->multires->base_face();
      const MatX3i& Fc = impl->control.F;
      std::vector<int> near(nc, -1);
      std::vector<double> near_d2(nc, std::numeric_limits<double>::infinity());
      for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
          const int c = Fc(face[i], k);
          const double d2 = (row3(V, i) - row3(impl->control.V, c)).squaredNorm();
          if (d2 < near_d2[c]) near_d2[c] = d2, near[c] = i;
        }
      std::optional<KdTree> tree;  // only for control vertices no dense vertex is bound near
      for (int i = 0; i < nc; ++i) {
        if (near[i] < 0) {
          if (!tree) tree.emplace(V);
          near[i] = tree->nearest(row3(impl->control.V, i));
        }
        Wc.row(i) = weights.row(near[i]);
      }
    } else {
      Wc = weights;
    }
    for (int i = 0; i < nc; ++i) Wc.row(i) /= Wc.row(i).sum();
    impl->W = std::move(Wc);
  } else {
    std::vector<double> r(nc);
    for (int i = 0; i < nc; ++i) r[i] = sk.radii[i];
    const double sigma = opt.gaussian_sigma > 0 ? opt.gaussian_sigma : 0.2 * std::max(median(r), 1e-9);
    impl->W = gaussian_bone_weights(impl->S, bone_heads, bone_tails, sigma);
  }
  impl->setup();
  prog(1);
  return SkeletalRig(impl);
}

SkeletalRig SkeletalRig::from_data(const SkeletalRigData& d) {
  auto impl = std::make_shared<Impl>();
  const int B = static_cast<int>(d.bones_rest.size());
  impl->control = make_mesh(d.control_V, d.control_F, kSurface | kNoLooseVertices);
  const int nc = static_cast<int>(d.control_V.rows());
  if (d.S.rows() != nc || d.weights.rows() != nc || d.weights.cols() != B || B == 0)
    throw MeshError("skeletal data: skeleton / weights do not match the control mesh and bones");
  if (!d.S.allFinite() || !d.weights.allFinite()) throw MeshError("skeletal data: not finite");
  impl->S = d.S;
  impl->W = d.weights;
  impl->rest = d.bones_rest;
  check_segments(d.bone_heads, d.bone_tails, B, "skeletal data");
  impl->seg_heads = d.bone_heads;
  impl->seg_tails = d.bone_tails;
  impl->frame_regularization = d.frame_regularization;
  if (d.has_multires) {
    impl->multires = Multires::from_data(d.multires);
    if (impl->multires->n_control() != nc) throw MeshError("skeletal data: multires control mesh does not match");
    if (d.dense_F.rows() > 0) {
      if (d.dense_F.minCoeff() < 0 || d.dense_F.maxCoeff() >= impl->multires->n_dense())
        throw MeshError("skeletal data: dense faces index vertices out of range");
      impl->dense_F = d.dense_F;
    }
  }
  impl->setup();
  return SkeletalRig(impl);
}

SkeletalRigData SkeletalRig::data() const {
  SkeletalRigData d;
  d.control_V = impl_->control.V;
  d.control_F = impl_->control.F;
  d.S = impl_->S;
  d.weights = impl_->W;
  d.bones_rest = impl_->rest;
  d.bone_heads = impl_->seg_heads;
  d.bone_tails = impl_->seg_tails;
  d.has_multires = impl_->multires.has_value();
  if (d.has_multires) d.multires = impl_->multires->data();
  d.dense_F = impl_->dense_F;
  d.frame_regularization = impl_->frame_regularization;
  return d;
}

// Bone segments: the stick skeleton given at bind (seg_heads, seg_tails), else from the rest frames
// (data saved without it): head = translation, direction = Y axis, length to the next head along
// the axis, else the extent along it of the control vertices weighted to the bone.
void SkeletalRig::Impl::setup_clearance() {
  const int B = static_cast<int>(rest.size()), n = static_cast<int>(S.rows());
  bone_head.assign(B, Vec3::Zero());
  bone_vec.assign(B, Vec3::Zero());
  clearance.setConstant(n, B, -1.0);
  if (seg_heads.rows() == B) {
    for (int j = 0; j < B; ++j) bone_head[j] = row3(seg_heads, j), bone_vec[j] = row3(seg_tails, j) - bone_head[j];
  } else {
    std::vector<Vec3> axis(B);
    for (int j = 0; j < B; ++j) {
      bone_head[j] = rest[j].block<3, 1>(0, 3);
      axis[j] = rest[j].block<3, 1>(0, 1).normalized();
    }
    for (int j = 0; j < B; ++j) {
      double len = std::numeric_limits<double>::infinity();
      for (int k = 0; k < B; ++k) {
        const Vec3 rel = bone_head[k] - bone_head[j];
        const double along = rel.dot(axis[j]);
        if (k != j && along > 1e-9 && (rel - along * axis[j]).norm() < 0.25 * along) len = std::min(len, along);
      }
      if (!std::isfinite(len)) {
        len = 0;
        for (int i = 0; i < n; ++i)
          if (W(i, j) > 0) len = std::max(len, (row3(control.V, i) - bone_head[j]).dot(axis[j]));
      }
      bone_vec[j] = std::max(len, 1e-9) * axis[j];
    }
  }
  if (B < 2) return;  // one bone moves everything rigidly
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < B; ++j)
      if (W(i, j) > 1e-3)
        clearance(i, j) = std::sqrt(segment_sq_dist(row3(S, i), bone_head[j], bone_head[j] + bone_vec[j]));
  // A surface vertex keeps its distance to the stick skeleton of its bones (the union of their
  // segments), not to each of them: in a bend's inner crease the flesh near one bone folds towards
  // the other, which is closer than at rest, and must (capsule, 90 degrees: 0.7 of its rest distance
  // to the other bone).
  // A bone's parent: the bone whose tail its head starts from (within a tenth of the shorter).
  children.assign(B, {});
  parent.assign(B, -1);
  for (int k = 0; k < B; ++k) {
    double best = std::numeric_limits<double>::infinity();
    int parent = -1;
    for (int j = 0; j < B; ++j) {
      const double d = ((bone_head[j] + bone_vec[j]) - bone_head[k]).norm();
      if (j != k && d <= 0.1 * std::min(bone_vec[j].norm(), bone_vec[k].norm()) && d < best) best = d, parent = j;
    }
    if (parent >= 0) children[parent].push_back(k), this->parent[k] = parent;
  }
  surface_clearance = union_clearance(control.V, [&](int i, int j) { return follows_or_parent(W.row(i), j); });
  untangle_clearance = union_clearance(control.V, [&](int i, int j) { return follows_or_adjacent(W.row(i), j); });
  control_tree = SelfIntersectionTree(control.V, control.F);
  rest_pairs = control_tree.pairs(control.V);
  control_guard = FoldGuard(control.F, static_cast<int>(control.V.rows()));
}

// Whether a point with bone weights w keeps its distance to bone j: j is one of its bones or the
// parent of one. In a bend the child limb's flesh folds against the parent limb's but must not sink
// onto the parent's bone (armadillo knee bent 90 degrees, bench skeletal_limb: a calf vertex
// weighted to the shin alone came to 0.87 of its rest distance to the bones, now 0.95, the same
// thickness error). Not the other way: the parent limb's flesh near the joint must yield to the
// child bone swinging into it (with children as well the armadillo's bend error rose from 0.07 to
// 33 times DQS's).
bool SkeletalRig::Impl::follows_or_parent(const Eigen::Ref<const Eigen::RowVectorXd>& w, int j) const {
  if (w[j] > 1e-3) return true;
  for (int k : children[j])
    if (w[k] > 1e-3) return true;
  return false;
}

// follows_or_parent, or j is a child of one of the bones w has weight on (the untangling's clearance).
bool SkeletalRig::Impl::follows_or_adjacent(const Eigen::Ref<const Eigen::RowVectorXd>& w, int j) const {
  if (follows_or_parent(w, j)) return true;
  for (size_t p = 0; p < children.size(); ++p)
    if (w[static_cast<Eigen::Index>(p)] > 1e-3)
      for (int k : children[p])
        if (k == j) return true;
  return false;
}

// Bone sets (follows(i, j): point i follows bone j) and rest distances of the points P to the union
// of their bones' rest segments; nothing when one bone moves everything rigidly.
template <class Follows>
BoneClearance SkeletalRig::Impl::union_clearance(const MatX3d& P, Follows follows) const {
  const int B = static_cast<int>(rest.size()), n = static_cast<int>(P.rows());
  BoneClearance c;
  c.rest.setConstant(n, -1.0);
  if (B < 2) return c;
  c.offset.reserve(n + 1);
  for (int i = 0; i < n; ++i) {
    double d2 = std::numeric_limits<double>::infinity();
    for (int j = 0; j < B; ++j)
      if (follows(i, j)) {
        c.bones.push_back(j);
        d2 = std::min(d2, segment_sq_dist(row3(P, i), bone_head[j], bone_head[j] + bone_vec[j]));
      }
    c.offset.push_back(static_cast<int>(c.bones.size()));
    if (std::isfinite(d2)) c.rest[i] = std::sqrt(d2);
  }
  return c;
}

void SkeletalRig::Impl::posed_segments(const std::vector<Mat4>& pose, std::vector<Vec3>& h,
                                       std::vector<Vec3>& v) const {
  const int B = static_cast<int>(rest.size());
  h.resize(B);
  v.resize(B);
  for (int j = 0; j < B; ++j) {
    const Mat4 A = pose[j] * rest[j].inverse();
    h[j] = A.block<3, 3>(0, 0) * bone_head[j] + A.block<3, 1>(0, 3);
    v[j] = A.block<3, 3>(0, 0) * bone_vec[j];
  }
}

// Surface bone clearance (SkeletalDeformOptions::bone_clearance): the surface counterpart of
// clear_bones, after the thickness steps of eq. 6.14. Where the limb's medial surface is a sheet
// off the stick bones, the posed sheet (SSD blends it across a joint) and the surface rebuilt on it
// can bring a vertex in a joint's crease closer to the bones that drive it than at rest; the vertex
// is pushed back out radially from the segments it is too close to, until its distance to their
// union is `fraction` of its rest distance to it. Rest pose and rigid motions keep every distance:
// no push.
void SkeletalRig::Impl::clear_surface(MatX3d& X, const std::vector<Mat4>& pose, double fraction,
                                      const std::vector<char>& edited) const {
  const int B = static_cast<int>(rest.size()), n = static_cast<int>(X.rows());
  if (B < 2 || surface_clearance.rest.size() != n || !(fraction > 0)) return;
  std::vector<Vec3> h, v;
  posed_segments(pose, h, v);
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int i = 0; i < n; ++i)
    if (edited.empty() || !edited[i]) X.row(i) = surface_clearance.push(i, row3(X, i), fraction, h, v).transpose();
}

// SSD (eq. 6.2) blends the bone motions, and where a limb's medial surface is a sheet rather than a
// curve, the sheet's part in a joint's inner crease is pulled towards the bones (to cos(45 deg) of its
// distance at a 90-degree bend with equal weights) and the balls around it with it. Each posed
// skeletal vertex is pushed back out to its rest distance (times `fraction`) from the posed segments
// of the bones it has weight on (two Gauss-Seidel passes). Rest pose and rigid motions keep every
// distance: no push.
void SkeletalRig::Impl::clear_bones(MatX3d& Sd, const std::vector<Mat4>& pose, double fraction) const {
  const int B = static_cast<int>(rest.size()), n = static_cast<int>(Sd.rows());
  if (B < 2 || clearance.rows() != n) return;
  std::vector<Vec3> h, v;
  posed_segments(pose, h, v);
  for (int i = 0; i < n; ++i) Sd.row(i) = push_out(row3(Sd, i), clearance.row(i), fraction, h, v).transpose();
}

// Anchor weights of the skeletal mesh integration (SkeletalDeformOptions::integrate_skeleton),
// relative to the unit weight of an edge: a vertex one bone moves alone is held where the bone puts
// it (kRigidAnchor: the parts away from the joint do not drift); one dominated by a bone (largest
// weight a in [0.9, 1)) softly, with kSkeletonAnchor a'^2, a' = (a - 0.9) / 0.09 clamped to 1.
// A joint's blend rebuilt from turned edges does not end where the child bone's pivot puts its
// rigid part; the soft anchors let the difference spread over the blend's ends instead of folding
// them. (Soft anchors on the rigid parts as well moved them off their bones: 0.025 at the far end
// of a 6-long capsule through the layer.)
constexpr double kRigidAnchor = 1e6;
constexpr double kSkeletonAnchor = 0.1;
// The integrated skeletal vertices' clearance from their bones, as a fraction of the rest distance
// (see pose_skeleton).
constexpr double kIntegrationClearance = 0.5;
// The joint fillet's fade with the untangling on, in limb radii of the fillet's radius (see
// pose_skeleton and JointFilletOptions::fade).
constexpr double kUntangleFilletFade = 1.2;
// Below this share of weight on a joint's two bones a vertex does not follow its fillet (fillet_share).
constexpr double kFilletShareMin = 0.25;

void SkeletalRig::Impl::setup_integration() {
  const int n = static_cast<int>(S.rows()), g = static_cast<int>(reps.size());
  const MatX2i& E = control.topo.edges;
  const int B = static_cast<int>(rest.size());
  sk_anchor = VecXd::Constant(g, 1e-6);  // the floor keeps the system definite where no bone dominates
  sk_offset = MatX3d::Zero(E.rows(), 3);
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(E.rows()) * 4 + g);
  for (int e = 0; e < E.rows(); ++e) {
    const int i = rep_of[E(e, 0)], j = rep_of[E(e, 1)];
    if (i == j) continue;
    // The midpoint's offset from its nearest point on the segments of the bones either end has
    // weight on.
    const Vec3 m = 0.5 * (row3(S, reps[i]) + row3(S, reps[j]));
    double best = std::numeric_limits<double>::infinity();
    for (int b = 0; b < B; ++b) {
      if (!(W(E(e, 0), b) > 1e-3 || W(E(e, 1), b) > 1e-3)) continue;
      const Vec3 o = m - segment_closest(m, bone_head[b], bone_head[b] + bone_vec[b]);
      if (o.squaredNorm() < best) best = o.squaredNorm(), sk_offset.row(e) = o.transpose();
    }
    trip.emplace_back(i, i, 1.0), trip.emplace_back(j, j, 1.0), trip.emplace_back(i, j, -1.0),
        trip.emplace_back(j, i, -1.0);
  }
  for (int v = 0; v < n; ++v) {
    const double w = W.row(v).maxCoeff(), a = std::clamp((w - 0.9) / 0.09, 0.0, 1.0);
    sk_anchor[rep_of[v]] += w >= 1 - 1e-6 ? kRigidAnchor : kSkeletonAnchor * a * a;
  }
  for (int i = 0; i < g; ++i) trip.emplace_back(i, i, sk_anchor[i]);
  SpMat A(g, g);
  A.setFromTriplets(trip.begin(), trip.end());
  sk_solver.factor(A, SparseSolver::Kind::Cholesky);
}

// Skeletal mesh integration (SkeletalDeformOptions::integrate_skeleton) over the coincident groups
// of skeletal vertices (reps: a tube's ring collapses to one point): the groups' positions minimise
// sum over edges ij |(s_j - s_i) - t_ij|^2 + sum_i anchor_i |s_i - Sd_i|^2 (edges between groups,
// once per control edge; s0 and Sd the representatives' rest and blended positions, anchor_i the sum
// over the group), every vertex then moving as its group's representative does. The edge target is
// a beam's ("plane sections stay plane"): t_ij = R_ij (s0_j - s0_i) + (R_j - R_i) o_ij, R_i and R_j
// the ends' blended rotations (lin), R_ij their normalised mean (as quaternions), o_ij the edge's rest
// offset from the stick skeleton (sk_offset). The blend's own edge is, to first order, that plus
// (R_j - R_i) times the offset along the bones from the joint: the swing behind the joint, dropped. With
// the rotated rest edge alone (before the offset term) the parts that a bend or a twist stretches
// were pulled in: the flattened test limb (a sheet skeleton) bent 90 degrees in the sheet's plane
// had its outer side pulled onto the bones (skeleton ratio 0.018 to the bones), and a twisted
// sheet's helix shrank towards its axis. (Solved per vertex, the coincident centres of a capsule's
// ring drifted apart by 1.5 % of the radius and uncovered the balls the fairing's tree leaves out.)
// A pose that moves every bone alike (the rest pose, rigid motions) keeps Sd.
void SkeletalRig::Impl::integrate_skeleton(MatX3d& Sd, const MatX9d& lin, const std::vector<Mat4>& pose) const {
  const int n = static_cast<int>(Sd.rows()), g = static_cast<int>(reps.size()), B = static_cast<int>(rest.size());
  if (!sk_solver.factored() || sk_solver.rows() != g) return;
  const Mat4 A0 = pose[0] * rest[0].inverse();
  bool rigid = true;
  for (int j = 1; j < B && rigid; ++j)
    rigid = ((pose[j] * rest[j].inverse()) - A0).cwiseAbs().maxCoeff() <= 1e-12 * (1 + A0.cwiseAbs().maxCoeff());
  if (rigid) return;
  std::vector<Eigen::Quaterniond> q(g);
  std::vector<Mat3> R(g);
  Eigen::MatrixXd rhs(g, 3);
  for (int i = 0; i < g; ++i) {
    R[i] = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(lin.row(reps[i]).data());
    q[i] = Eigen::Quaterniond(R[i]);
    rhs.row(i) = sk_anchor[i] * Sd.row(reps[i]);
  }
  const MatX2i& E = control.topo.edges;
  for (int e = 0; e < E.rows(); ++e) {
    const int i = rep_of[E(e, 0)], j = rep_of[E(e, 1)];
    if (i == j) continue;
    Eigen::Vector4d c = q[j].coeffs();
    if (q[i].coeffs().dot(c) < 0) c = -c;
    Eigen::Quaterniond m;
    m.coeffs() = (q[i].coeffs() + c).normalized();
    const Vec3 t = m * (row3(S, reps[j]) - row3(S, reps[i])) + (R[j] - R[i]) * row3(sk_offset, e);
    rhs.row(i) -= t.transpose(), rhs.row(j) += t.transpose();
  }
  const Eigen::MatrixXd X = sk_solver.solve(rhs);
  MatX3d shift(g, 3);
  for (int i = 0; i < g; ++i) shift.row(i) = X.row(i) - Sd.row(reps[i]);
  for (int v = 0; v < n; ++v) Sd.row(v) += shift.row(rep_of[v]);
}

// Joint fillets (SkeletalDeformOptions::joint_fillet, joint_fillet.h). Per joint, at bind: the
// extent of its weight blend, the largest |t| (along the joint's mean rest axis, within the two
// bones' lengths) of a skeletal vertex that the two bones carry most of (w_p + w_c > 1/2) and that
// mixes them (w_c / (w_p + w_c) in (0.02, 0.98)); and the limb's radius, the median distance of the
// surface vertices that the two bones carry most of within a quarter of the shorter bone of the
// joint to the two bones' segments.
void SkeletalRig::Impl::setup_fillets() {
  fillet_joints.clear();
  const int n = static_cast<int>(S.rows()), B = static_cast<int>(rest.size());
  if (B < 2 || children.size() != static_cast<size_t>(B)) return;
  for (int p = 0; p < B; ++p)
    for (int c : children[p]) {
      const double lp = bone_vec[p].norm(), lc = bone_vec[c].norm();
      if (!(lp > 1e-12 && lc > 1e-12) || (bone_vec[p] / lp + bone_vec[c] / lc).norm() < 1e-6) continue;
      const Vec3 J = bone_head[c], e = (bone_vec[p] / lp + bone_vec[c] / lc).normalized();
      FilletJoint f;
      f.p = p, f.c = c;
      std::vector<double> radius;
      for (int i = 0; i < n; ++i) {
        const double sum = W(i, p) + W(i, c);
        if (!(sum > 0.5)) continue;
        const double t = (row3(S, i) - J).dot(e), wc = W(i, c) / sum;
        if (t >= -lp && t <= lc && wc > 0.02 && wc < 0.98) f.blend_extent = std::max(f.blend_extent, std::abs(t));
        const Vec3 x = row3(control.V, i);
        if (std::abs((x - J).dot(e)) <= 0.25 * std::min(lp, lc))
          radius.push_back(
              std::sqrt(std::min(segment_sq_dist(x, J - bone_vec[p], J), segment_sq_dist(x, J, J + bone_vec[c]))));
      }
      f.radius = radius.empty() ? 0.0 : median(radius);
      if (!(f.radius > 0)) continue;
      for (int i = 0; i < n; ++i) {
        if (W(i, p) + W(i, c) > kFilletShareMin) f.surface.push_back(i);
        const int r = reps[rep_of[i]];
        if (W(r, p) + W(r, c) > kFilletShareMin) f.skeleton.push_back(i);
      }
      fillet_joints.push_back(std::move(f));
    }
}

std::vector<SkeletalRig::Impl::PosedFillet> SkeletalRig::Impl::pose_fillets(const std::vector<Mat4>& pose,
                                                                            double radius_scale, bool ring,
                                                                            double fade) const {
  std::vector<PosedFillet> out;
  JointFilletOptions o;
  o.radius_scale = radius_scale;
  o.fade = fade;
  for (const FilletJoint& j : fillet_joints) {
    const Mat4 P = pose[j.p] * rest[j.p].inverse(), M = P.inverse() * (pose[j.c] * rest[j.c].inverse());
    const auto f = joint_fillet(M, bone_head[j.c], bone_vec[j.p], bone_vec[j.c], j.blend_extent, j.radius,
                                std::min(bone_vec[j.p].norm(), bone_vec[j.c].norm()), o);
    if (f) out.push_back({&j, *f, P, ring});
  }
  return out;
}

// A vertex follows a joint's fillet by the share of its weight on the joint's two bones: fully from
// 3/4, not below 1/4 (a vertex mostly on other bones, e.g. the other leg's foot weighted a little to
// the hip, keeps its blend).
namespace {
double fillet_share(double w) { return detail::smoothstep((w - kFilletShareMin) / 0.5); }
// A vertex weighted to one of the two bones alone but lying on the other's side of the joint (e.g. a
// tip painted to the parent bone) is not a cross-section of the band: it keeps its blend.
bool against_side(double t, double wc) { return (wc <= 0 && t > 0) || (wc >= 1 && t < 0); }
}  // namespace

// The posed skeletal mesh moved to the fillets: each skeletal vertex (with its coincident group: a
// tube's collapsed ring moves as one) to the map of the cross-section of its surface vertex (the
// blend moves the pair rigidly by the surface vertex's weights; so does this, by the fillet), its
// blended rotation turned likewise (relative to the two bones' blend), both weighted by the
// fillet's onset and the vertex's share of the joint (fillet_share). Outside the band a vertex the
// two bones carry alone is where the blend puts it, and is skipped; so is one against_side.
void SkeletalRig::Impl::fillet_skeleton(MatX3d& Sd, MatX9d& lin, const std::vector<PosedFillet>& fillets) const {
  const Eigen::Quaterniond id = Eigen::Quaterniond::Identity();
  for (const PosedFillet& pf : fillets) {
    const FilletJoint& j = *pf.joint;
    const JointFillet& f = pf.fillet;
    const Eigen::Quaterniond relative(f.relative);
    const Mat3 PL = pf.parent.block<3, 3>(0, 0), PR = nearest_rotation(PL);
    const Vec3 Pt = pf.parent.block<3, 1>(0, 3);
    const int m = static_cast<int>(j.skeleton.size());
#pragma omp parallel for schedule(static) if (m >= kParallelMin)
    for (int k = 0; k < m; ++k) {
      const int i = j.skeleton[k], r = reps[rep_of[i]];
      const double sum = W(r, j.p) + W(r, j.c), g = f.weight * fillet_share(sum);
      if (!(g > 0)) continue;
      const double wc = W(r, j.c) / sum, t = f.t_of(row3(control.V, r));
      if (against_side(t, wc) || (std::abs(t) >= f.half_length && (wc <= 0 || wc >= 1))) continue;
      Mat3 R;
      const Vec3 y = PL * f.map(row3(S, i), t, fillet_twist_share(pf, r, wc), R) + Pt;
      Sd.row(i) += (g * (y - row3(Sd, i))).transpose();
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> Li(lin.row(i).data());
      const Mat3 L0 = Li, Rb = id.slerp(wc, relative).toRotationMatrix(),
                 L1 = PR * R * Rb.transpose() * PR.transpose() * L0;
      const Eigen::Quaterniond q0(L0), q1(L1);
      Li = q0.slerp(g, q1).toRotationMatrix();
    }
  }
}

// The reconstructed surface (eq. 6.11) moved to the fillets' map of the rest surface before the
// thickness steps, by the same weights: the reconstruction turns a surface vertex with its
// skeletal triangle's frame, whose cross-section lies elsewhere along the limb on a thick limb's
// medial sheet (the armadillo's knee bent 90 degrees: 235 crossing pairs rebuilt on the filleted
// skeleton, none mapped; bench/notes/skeletal.md, session 35). A vertex on an edited skeletal vertex
// (deform_skeleton) keeps its reconstruction: the map knows nothing of the edit.
void SkeletalRig::Impl::fillet_surface(MatX3d& X, const std::vector<PosedFillet>& fillets,
                                       const std::vector<char>& edited) const {
  for (const PosedFillet& pf : fillets) {
    const FilletJoint& j = *pf.joint;
    const JointFillet& f = pf.fillet;
    const Mat3 PL = pf.parent.block<3, 3>(0, 0);
    const Vec3 Pt = pf.parent.block<3, 1>(0, 3);
    const int m = static_cast<int>(j.surface.size());
#pragma omp parallel for schedule(static) if (m >= kParallelMin)
    for (int k = 0; k < m; ++k) {
      const int i = j.surface[k];
      const double sum = W(i, j.p) + W(i, j.c), g = f.weight * fillet_share(sum);
      if (!(g > 0) || (!edited.empty() && edited[i])) continue;
      const Vec3 x0 = row3(control.V, i);
      const double wc = W(i, j.c) / sum, t = f.t_of(x0);
      if (against_side(t, wc)) continue;
      Mat3 R;
      const Vec3 y = PL * f.map(x0, t, fillet_twist_share(pf, i, wc), R) + Pt;
      X.row(i) += (g * (y - row3(X, i))).transpose();
    }
  }
}

// Joint contact (SkeletalDeformOptions::contact_slide, issue 33). The thickness steps keep each
// vertex at its rest distance to the union of the posed medial balls, but in a bend's inner crease
// the flesh of one limb then lies inside the other's (capsule bent 90 degrees: a third of the
// self-intersecting triangle pairs are limb against limb, bench/tools/skeletal_crease_probe.py).
// Per joint (parent p, child c), with the bisector plane of the posed bones as the contact surface
// (normal m = (a + b) / |a + b|, a and b the unit bone directions, through the joint J): a vertex on
// the parent's side at rest slides along -a, on the child's along +b (e, away from the joint). Its
// line x + t e crosses the plane at the axial distance t_c = t + h / (a . m) from J, h = its depth on
// the wrong side; the band t in [0, kappa t_c] is compressed onto [t_c, kappa t_c] (a shift of
// (t_c - t_c0) (1 - t / (kappa t_c)), t_c0 the same crossing at rest, positive where the chain is
// bent at rest, so the map is the identity at rest and continuous in the pose), plus the plane's
// margin (growing from 0 with the crossing, so the map stays continuous). A vertex past the joint
// (t < 0) that this leaves on the other side, its line crossing the plane at t_c > 0, goes onto the
// plane (plus the margin): the flesh of a line in a tight bend's corner meets there, pressed against
// the other limb's (the trixie lane's thickness steps left one such vertex of tests/python's capsule
// at 135 degrees across), unless it would end closer to the two bones than kContactClearance of its
// rest distance (skeletal_speed's 178K capsule with ramp weights bent 135 degrees: an outer vertex
// the thickness steps had carried past the joint landed on the joint's axis, min ratio 0.017).
// Lines crossing behind the joint (t_c <= 0) are left alone: moved onto the plane there, flesh came
// close to the other bone (the untangling's slide at 135 degrees through the layer: min ratio 0.85).
// The distance to the own bone's line is unchanged (a slide along it), and the map is monotone along
// each line: no vertex overtakes another. Only the vertices within `reach` times the shorter bone's
// length of the joint at rest slide.
std::vector<SkeletalRig::Impl::ContactJoint> SkeletalRig::Impl::contact_joints(const std::vector<Mat4>& pose,
                                                                               double reach) const {
  std::vector<ContactJoint> out;
  const int B = static_cast<int>(rest.size());
  if (B < 2 || children.size() != static_cast<size_t>(B)) return out;
  std::vector<Vec3> h, v;
  posed_segments(pose, h, v);
  for (int p = 0; p < B; ++p)
    for (int c : children[p]) {
      const double lp = bone_vec[p].norm(), lc = bone_vec[c].norm();
      if (!(lp > 1e-12 && lc > 1e-12) || !(v[p].norm() > 1e-12 && v[c].norm() > 1e-12)) continue;
      ContactJoint j;
      j.p = p, j.c = c;
      j.a0 = bone_vec[p] / lp, j.b0 = bone_vec[c] / lc, j.a = v[p].normalized(), j.b = v[c].normalized();
      // Rest pose, rigid motions of the pair and twists leave the bend unchanged: nothing to do (to
      // 1e-6 in the cosine, about 0.1 degree at most: a twist posed through single-precision bone
      // matrices, e.g. Blender's, changes it by about 1e-7).
      if (std::abs(j.a.dot(j.b) - j.a0.dot(j.b0)) < 1e-6 || (j.a0 + j.b0).norm() < 1e-6 || (j.a + j.b).norm() < 1e-6)
        continue;
      j.m0 = (j.a0 + j.b0).normalized(), j.m = (j.a + j.b).normalized();
      j.co0 = j.a0.dot(j.m0), j.co = j.a.dot(j.m);  // cos of half the angle between the bones
      if (j.co < 0.05 || j.co0 < 0.05) continue;    // folded flat (over ~174 degrees): no plane between
      j.J0 = bone_head[c], j.J = h[c], j.lp = lp, j.lc = lc;
      const double L = reach * std::min(lp, lc);
      j.L2 = L * L;
      out.push_back(j);
    }
  return out;
}

template <class Out, class Weight>
bool SkeletalRig::Impl::contact_slide(Out& X, const MatX3d& V0, const std::vector<Mat4>& pose, double kappa,
                                      Weight weight, double reach) const {
  const int n = static_cast<int>(X.rows());
  if (!(kappa >= 1) || V0.rows() != n) return false;
  const double margin = contact_margin;
  const std::vector<ContactJoint> joints = contact_joints(pose, reach);
  for (const ContactJoint& j : joints) {
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (int i = 0; i < n; ++i) {
      const Vec3 x0 = row3(V0, i);
      const double s = j.side(x0, weight(i, j.p) + weight(i, j.c));
      if (s == 0) continue;
      const Vec3 e = s > 0 ? j.b : Vec3(-j.a), e0 = s > 0 ? j.b0 : Vec3(-j.a0);
      const Vec3 x = X.row(i).transpose().template cast<double>();
      const double t = (x - j.J).dot(e), tc = t - s * (x - j.J).dot(j.m) / j.co;
      double shift = 0;
      if (tc > 0) {
        const double tc0 = std::max((x0 - j.J0).dot(e0) - s * (x0 - j.J0).dot(j.m0) / j.co0, 0.0);
        const double te = std::max(t, 0.0), T = kappa * tc;
        if (te < T && tc > tc0) shift = (tc - tc0 + std::min(margin, tc - tc0)) * (1 - te / T);
      }
      // A vertex past the joint (t < 0) whose line crosses the plane on its own side goes onto it,
      // unless that takes it closer to the bones than kContactClearance of its rest distance.
      if (tc > 0 && tc > t && tc - t + margin > shift &&
          j.bone_distance(x + (tc - t + margin) * e, true) >= kContactClearance * j.bone_distance(x0, false))
        shift = tc - t + margin;
      if (shift > 0) X.row(i) = (x + shift * e).transpose().template cast<typename Out::Scalar>();
    }
  }
  return !joints.empty();
}

// Untangling (SkeletalDeformOptions::untangle_iterations, issue 33): the thesis's remedy for folds,
// a smoothing term in the flow eq. 6.15, applied only where the surface crosses itself. Each
// iteration finds the self-intersecting triangle pairs among the faces of `tree` (self_intersection.h;
// after the first, only around the faces it moved: pairs_touching, the same pairs), takes
// their vertices and `rings` rings around them (vv: the mesh's one-ring CSR), moves each by
// kUntangleSweeps Jacobi steps of the uniform umbrella operator (weight 1/2; tangential and normal,
// which in a concave crease lifts the fold out of it); after each, `push` moves it back out to the
// surface bone clearance, and a vertex still short of it (`clear`; deep in a tight bend's corner
// the push away from one bone moves it towards the other) keeps its position. An iteration that
// does not lower the count is undone and the next one takes one ring more (up to kUntangleWiden
// more: a wider region untangles a fold a narrow one cannot; capsule of bench skeletal_limb, 90
// degrees: 49 pairs left with 2 rings, 5 with 4); every iteration counts towards `iterations`.
// Rest pose and rigid motions: no pair, no move.
//
// `contact` applies the joint contact (see contact_slide) to X and returns whether it did (false
// when the joint contact is on: it has run already). It is tried first and kept when it lowers the
// count. In a tight bend the two limbs' flesh piles into the concave corner, where the smoothing
// cannot lift it out without sinking it onto the other limb's bone (the clamp refuses the move);
// slid apart along their bones, the limbs meet on the bisector plane and the smoothing only has the
// folds inside each limb left (capsule bent 135 degrees, bench/tools/skeletal_crease_probe.py's
// set-up: 1241 pairs left without, 0 with; DQS 331). Where the slide adds pairs (armadillo knee at
// 90 degrees with the option's kappa 3: 270 -> 446) it is not kept.
// The untangling's joint contact: kappa 8, over the vertices within 1.5 times the shorter bone of
// the joint. A thick, short leg's inner flesh crosses the bisector plane up to about 2.4 times its
// radius from the knee, beyond the shin's length: with contact_slide's own 3 and 1 the armadillo's
// knee bent 135 degrees has more pairs slid (8691) than not (8064), the slide is not kept and 1055
// pairs are left (DQS 308); with 8 and 1.5 the slide is kept and 246 are left, min bone ratio 0.950
// (bench/notes/skeletal.md).
constexpr double kUntangleContact = 8, kUntangleReach = 1.5;

// Whether the untangling's slide (X0 -> X) keeps the thickness of eq. 6.13: over the vertices it
// moved, the root mean square of f - target (f the distance to the union of the posed medial balls
// (Sd, radii), target the rest value) may grow by at most kSlideThickness times the median medial
// radius. A slide along the bone keeps the distance to a tube's bone; flesh far from its bone (the
// arms of bench skeletal_blender's armadillo bent 90 degrees at the waist) slides off its medial
// distance: growth 2.66 median radii there (kept on the pair count alone it ended at sum
// (f - f_rest)^2 3.51e6, volume 1.077; DQS 1.37e5), at most 0.86 on the slides that untangle the
// capsules and the armadillo's knee at 135 degrees (bench/notes/skeletal.md).
constexpr double kSlideThickness = 1.0;
bool slide_keeps_thickness(const MatX3d& X0, const MatX3d& X, const MatX3d& Sd, const VecXd& radii,
                           const VecXd& target) {
  std::vector<int> moved;
  for (int i = 0; i < X.rows(); ++i)
    if (X.row(i) != X0.row(i)) moved.push_back(i);
  if (moved.empty()) return true;
  MatX3d A(moved.size(), 3), B(moved.size(), 3);
  VecXd t(moved.size());
  for (size_t k = 0; k < moved.size(); ++k)
    A.row(k) = X0.row(moved[k]), B.row(k) = X.row(moved[k]), t[k] = target[moved[k]];
  const VecXd e0 = union_of_balls_distance(A, Sd, radii) - t, e1 = union_of_balls_distance(B, Sd, radii) - t;
  const double m = static_cast<double>(moved.size());
  return std::sqrt(e1.squaredNorm() / m) - std::sqrt(e0.squaredNorm() / m) <=
         kSlideThickness * median(std::vector<double>(radii.data(), radii.data() + radii.size()));
}

template <class Push, class Clear, class Contact>
void untangle_folds(MatX3d& X, const MatX3i& F, const std::vector<int>& vv_offset, const std::vector<int>& vv_index,
                    const SelfIntersectionTree& tree, const std::vector<std::pair<int, int>>& at_rest, int iterations,
                    int rings, Push push, Clear clear, Contact contact) {
  // Pairs that cross at rest (parts that touch, e.g. a camel's front legs) are the mesh's own, not folds.
  const auto new_only = [&](std::vector<std::pair<int, int>> p) {
    if (!at_rest.empty())
      p.erase(std::remove_if(p.begin(), p.end(),
                             [&](const auto& q) { return std::binary_search(at_rest.begin(), at_rest.end(), q); }),
              p.end());
    return p;
  };
  constexpr int kUntangleSweeps = 3;
  constexpr double kUntangleWeight = 0.5;
  constexpr int kUntangleWiden = 3;
  int widen = 0;  // extra rings after an iteration that did not lower the count
  const int n = static_cast<int>(X.rows());
  auto pairs = new_only(tree.pairs(X));
  if (pairs.empty()) return;
  if (MatX3d X0 = X; contact(X)) {
    // The slide keeps the distance to the own bone's line, not to its segment's end at the joint:
    // pushed out to the clearance like the smoothing's moves.
    for (int i = 0; i < n; ++i)
      if (X.row(i) != X0.row(i)) X.row(i) = push(i, Vec3(X.row(i).transpose())).transpose();
    auto slid = new_only(tree.pairs(X));
    if (slid.size() < pairs.size()) {
      pairs.swap(slid);
      if (pairs.empty()) return;
    } else {
      X.swap(X0);
    }
  }
  std::vector<int> stamp(n, -1), region, front, next;
  std::vector<char> touched(F.rows(), 0);
  MatX3d before, Y;
  for (int it = 0; it < iterations && !pairs.empty(); ++it) {
    front.clear();
    for (const auto& [a, b] : pairs)
      for (int f : {a, b})
        for (int c = 0; c < 3; ++c)
          if (stamp[F(f, c)] != it) stamp[F(f, c)] = it, front.push_back(F(f, c));
    region = front;
    for (int r = 0; r < rings + widen; ++r) {
      next.clear();
      for (int i : front)
        for (int k = vv_offset[i]; k < vv_offset[i + 1]; ++k) {
          const int j = vv_index[k];
          if (stamp[j] != it) stamp[j] = it, next.push_back(j);
        }
      region.insert(region.end(), next.begin(), next.end());
      front.swap(next);
    }
    const int nr = static_cast<int>(region.size());
    before.resize(nr, 3);
    Y.resize(nr, 3);
    for (int k = 0; k < nr; ++k) before.row(k) = X.row(region[k]);
    for (int sweep = 0; sweep < kUntangleSweeps; ++sweep) {
      for (int k = 0; k < nr; ++k) {
        const int i = region[k], k0 = vv_offset[i], k1 = vv_offset[i + 1];
        Y.row(k) = X.row(i);
        if (k1 == k0) continue;
        Vec3 avg = Vec3::Zero();
        for (int q = k0; q < k1; ++q) avg += row3(X, vv_index[q]);
        avg /= double(k1 - k0);
        Y.row(k) += kUntangleWeight * (avg.transpose() - X.row(i));
      }
      for (int k = 0; k < nr; ++k) {
        const Vec3 y = push(region[k], Vec3(Y.row(k).transpose()));
        if (clear(region[k], y)) X.row(region[k]) = y.transpose();
      }
    }
    // Only the pairs of the faces around the moved vertices can have changed: the others are kept
    // and the faces around the region searched against the rest (pairs_touching).
    for (int f : tree.faces()) touched[f] = stamp[F(f, 0)] == it || stamp[F(f, 1)] == it || stamp[F(f, 2)] == it;
    auto now = new_only(tree.pairs_touching(X, touched));
    for (const auto& q : pairs)
      if (!touched[q.first] && !touched[q.second]) now.push_back(q);
    if (now.size() >= pairs.size()) {
      for (int k = 0; k < nr; ++k) X.row(region[k]) = before.row(k);
      if (++widen > kUntangleWiden) break;
      continue;
    }
    std::sort(now.begin(), now.end());
    pairs.swap(now);
  }
}

void SkeletalRig::Impl::untangle(MatX3d& X, const MatX3d& Sd, const std::vector<Mat4>& pose,
                                 const SkeletalDeformOptions& opt, const std::vector<char>& edited) const {
  if (opt.untangle_iterations <= 0 || rest.size() < 2) return;  // one bone moves everything rigidly
  std::vector<Vec3> h, v;
  posed_segments(pose, h, v);
  const bool clamp = rest.size() >= 2 && untangle_clearance.rest.size() == X.rows();
  const double fraction = std::max(opt.bone_clearance, 0.9);
  untangle_folds(
      X, control.F, control.topo.vv_offset, control.topo.vv_index, control_tree, rest_pairs, opt.untangle_iterations,
      opt.untangle_rings,
      [&](int i, const Vec3& x) {
        return clamp && (edited.empty() || !edited[i]) ? untangle_clearance.push(i, x, fraction, h, v) : x;
      },
      [&](int i, const Vec3& x) {
        return !clamp || (!edited.empty() && edited[i]) || untangle_clearance.clear(i, x, fraction, h, v);
      },
      [&](MatX3d& Y) {
        if (opt.contact_slide != 0) return false;  // on: contact_slide has run already
        const MatX3d Y0 = Y;
        contact_slide(
            Y, control.V, pose, kUntangleContact, [&](int i, int j) { return W(i, j); }, kUntangleReach);
        if (slide_keeps_thickness(Y0, Y, Sd, radii, f_rest)) return true;
        Y = Y0;
        return false;
      });
}

// The same on the dense mesh through the multiresolution layer (its faces from bind, see
// SkeletalRigData::dense_F), over the faces with a vertex that does not move rigidly with one bone,
// against the dense vertices' bone clearance.
template <class Out>
void SkeletalRig::Impl::untangle_dense(Out& out, const MatX3d& Sd, const std::vector<Mat4>& pose,
                                       const SkeletalDeformOptions& opt, const std::vector<char>& edited) const {
  if (opt.untangle_iterations <= 0 || rest.size() < 2 || dense_F.rows() == 0 || dense_faces.empty()) return;
  std::vector<Vec3> h, v;
  posed_segments(pose, h, v);
  const int n = static_cast<int>(out.rows());
  const bool clamp = rest.size() >= 2 && dense_untangle_clearance.rest.size() == n;
  const double fraction = std::max(opt.bone_clearance, 0.9);
  MatX3d X = out.template cast<double>();
  const VecXi& face = multires->base_face();
  const MatX3i& Fc = control.F;
  untangle_folds(
      X, dense_F, dense_vv_offset, dense_vv_index, dense_tree, dense_rest_pairs, opt.untangle_iterations,
      opt.untangle_rings,
      [&](int i, const Vec3& x) {
        const int f = face[i];
        const bool on_edit = !edited.empty() && (edited[Fc(f, 0)] || edited[Fc(f, 1)] || edited[Fc(f, 2)]);
        return clamp && !on_edit ? dense_untangle_clearance.push(i, x, fraction, h, v) : x;
      },
      [&](int i, const Vec3& x) {
        const int f = face[i];
        const bool on_edit = !edited.empty() && (edited[Fc(f, 0)] || edited[Fc(f, 1)] || edited[Fc(f, 2)]);
        return !clamp || on_edit || dense_untangle_clearance.clear(i, x, fraction, h, v);
      },
      [&](MatX3d& Y) {
        if (opt.contact_slide != 0) return false;
        const MatX3d Y0 = Y;
        contact_slide(
            Y, dense_rest, pose, kUntangleContact, [&](int i, int j) { return dense_weight(i, j); }, kUntangleReach);
        if (slide_keeps_thickness(Y0, Y, Sd, radii, dense_f_rest)) return true;
        Y = Y0;
        return false;
      });
  out = X.template cast<typename Out::Scalar>();
}

// The twist-free pose (SkeletalDeformOptions::follow_twist): each bone's motion relative to its
// parent's, L = A_p^-1 A (A = pose rest^-1; a bone without a parent: its own motion, kept whole), has
// its rotation split into swing x twist, the twist about the bone's rest axis through its rest head
// (the quaternion's part along the axis), and the twist dropped: L'(p) = R_swing (p - h) + L(h);
// A' = A'_p L'. Returns the pose matrices A' rest; max_twist receives the largest twist angle dropped.
// Only where the twist dominates the swing: of a bone's twist angle tau, the fraction
// a = clamp(2 - 2 sigma / tau, 0, 1) is dropped, sigma the angle of its swing (whole where
// sigma <= tau / 2, kept where sigma >= tau). In a bend that carries a twist (a rotation axis not
// perpendicular to the bone), the thickness measured in the twist-free pose misplaces the child's
// crease flesh against the parent's balls by the twist: the armadillo's knee bent 135 degrees with an
// 11 degree twist, untangled, kept 1008 pairs instead of 246 when the twist was dropped
// (bench/notes/skeletal.md).
std::vector<Mat4> SkeletalRig::Impl::twist_free_pose(const std::vector<Mat4>& pose, double& max_twist) const {
  const int B = static_cast<int>(rest.size());
  max_twist = 0;
  std::vector<Mat4> A(B), Af(B);
  for (int j = 0; j < B; ++j) A[j] = pose[j] * rest[j].inverse();
  std::vector<char> done(B, 0);
  for (int left = B; left > 0;) {
    const int before = left;
    for (int j = 0; j < B; ++j) {
      const int p = parent.empty() ? -1 : parent[j];
      if (done[j] || (p >= 0 && !done[p])) continue;
      if (p < 0) {
        Af[j] = A[j];
      } else {
        const Mat4 L = A[p].inverse() * A[j];
        const Eigen::Quaterniond q(nearest_rotation(L.topLeftCorner<3, 3>()));
        const Vec3 a = bone_vec[j].normalized();
        Eigen::Quaterniond twist(q.w(), 0, 0, 0);
        twist.vec() = q.vec().dot(a) * a;
        Mat3 Rs = L.topLeftCorner<3, 3>();
        if (twist.norm() > 1e-12) {
          twist.normalize();
          // Only a twist that dominates the bone's swing is dropped (see above): the fraction a of
          // the twist angle tau, 1 where the swing sigma <= tau / 2, 0 where sigma >= tau.
          const double tau = 2 * std::acos(std::min(1.0, std::abs(twist.w())));
          const Eigen::Quaterniond swing = q * twist.conjugate();
          const double sigma = 2 * std::acos(std::min(1.0, std::abs(swing.w())));
          const double a = std::clamp(2 - 2 * sigma / std::max(tau, 1e-300), 0.0, 1.0);
          if (a > 0) {
            const Eigen::Quaterniond drop = Eigen::Quaterniond::Identity().slerp(a, twist);
            max_twist = std::max(max_twist, a * tau);
            Rs = (q * drop.conjugate()).toRotationMatrix();
          }
        }
        const Vec3 h = bone_head[j];
        Mat4 Lf = Mat4::Identity();
        Lf.topLeftCorner<3, 3>() = Rs;
        Lf.block<3, 1>(0, 3) = L.topLeftCorner<3, 3>() * h + L.block<3, 1>(0, 3) - Rs * h;
        Af[j] = Af[p] * Lf;
      }
      done[j] = 1, --left;
    }
    if (left == before) break;  // a cycle (not from setup_clearance's parents): keep the rest whole
  }
  for (int j = 0; j < B; ++j)
    if (!done[j]) Af[j] = A[j];
  std::vector<Mat4> out(B);
  for (int j = 0; j < B; ++j) out[j] = Af[j] * rest[j];
  return out;
}

// Each control vertex's twist (see Twist) for follow_twist: Sd_blend is the blend of the pose (before
// the bone clearance and any skeleton edit), lin its rotations, Sd the posed skeletal vertices.
// False (tw untouched) when the pose has no twist.
bool SkeletalRig::Impl::make_twist(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt,
                                   const MatX3d& Sd_blend, const MatX9d& lin, const MatX3d& Sd, Twist& tw) const {
  if (rest.size() < 2 || parent.size() != rest.size()) return false;
  double max_twist = 0;
  std::vector<Mat4> free_pose = twist_free_pose(pose, max_twist);
  if (!(max_twist > 1e-6)) return false;
  MatX9d lin_f;
  const MatX3d Sf = skeletal_subspace_deform(S, W, rest, free_pose, &lin_f, opt.dual_quaternion);
  // The rigid motion x -> R x + t as the unit dual quaternion (q, d = t q / 2).
  auto to_dual = [](const Mat3& R, const Vec3& t, Eigen::Quaterniond& q, Eigen::Quaterniond& d) {
    q = Eigen::Quaterniond(R).normalized();
    d = Eigen::Quaterniond(0, t.x(), t.y(), t.z()) * q;
    d.coeffs() *= 0.5;
  };
  const int n = static_cast<int>(S.rows());
  tw.R.resize(n);
  tw.t.resize(n);
  tw.qr.resize(n);
  tw.qd.resize(n);
  tw.Ss.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> T(lin.row(i).data()), U(lin_f.row(i).data());
    // M_i = T_i U_i^-1, rigid, taking the twist-free blend of s_i onto the posed blend.
    tw.R[i] = nearest_rotation(T * U.transpose());
    tw.t[i] = row3(Sd_blend, i) - tw.R[i] * row3(Sf, i);
    tw.Ss.row(i) = tw.to_free(i, row3(Sd, i)).transpose();
    to_dual(tw.R[i], tw.t[i], tw.qr[i], tw.qd[i]);
  }
  tw.free_pose = std::move(free_pose);
  return true;
}

// The twist blended with the ring weights (SkeletalDeformOptions::ring_twist): each skeletal vertex
// s_i goes to M_i U_i s_i instead of the blend's T_i s_i, U_i its blend (weights W) of the twist-free
// pose (twist_free_pose) and M_i = T~_i U~_i^-1 its twist, from the blends T~_i, U~_i of the pose and
// of the twist-free pose with W_ring; `lin` receives the rotations M_i U_i. Where W_ring's row is W's,
// T~_i U~_i^-1 U_i = T_i: the blend's result. False (Sd, lin untouched) for a pose whose twists
// twist_free_pose keeps (none dominates its bone's swing): the blend poses it.
bool SkeletalRig::Impl::ring_twist(const std::vector<Mat4>& pose, bool dual_quaternion, MatX3d& Sd, MatX9d& lin) const {
  if (rest.size() < 2 || parent.size() != rest.size() || W_ring.rows() != S.rows()) return false;
  double dropped = 0;
  const std::vector<Mat4> free_pose = twist_free_pose(pose, dropped);
  if (!(dropped > 1e-6)) return false;
  MatX9d lin_t, lin_f;
  Sd = skeletal_subspace_deform(S, W, rest, free_pose, &lin, dual_quaternion);  // U_i s_i, then M_i U_i s_i
  const MatX3d T = skeletal_subspace_deform(S, W_ring, rest, pose, &lin_t, dual_quaternion);
  const MatX3d Uf = skeletal_subspace_deform(S, W_ring, rest, free_pose, &lin_f, dual_quaternion);
  using RowMap = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>;
  for (Eigen::Index i = 0; i < S.rows(); ++i) {
    const Mat3 R = nearest_rotation(RowMap(lin_t.row(i).data()) * RowMap(lin_f.row(i).data()).transpose());
    Sd.row(i) = (R * (row3(Sd, i) - row3(Uf, i)) + row3(T, i)).transpose();
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> L(lin.row(i).data());
    L = (R * L).eval();
  }
  return true;
}

namespace {
// Whether follow_twist acts: with the variational method and the dual quaternion skeleton, whose
// blend moves each skeletal vertex rigidly (a linear blend collapses a twisted sheet onto the bone,
// and carried back by its blended rotations the collapsed sheet stays collapsed: a flattened capsule
// twisted 180 degrees tore open, its longest edge 20 times its rest length; the integration, which
// the option replaces, rebuilds it).
bool follows_twist(const SkeletalDeformOptions& opt) {
  return opt.follow_twist && opt.dual_quaternion && opt.method == SkeletalMethod::Variational;
}
}  // namespace

// The posed skeletal mesh: SSD (eq. 6.2; `lin` receives the blended rotations, `blend` the positions),
// the bone clearance, and the integration where the options ask for it. Not with a followed twist:
// make_twist carries each skeletal vertex back by its own blended twist, which the integration mixes
// across vertices (bench skeletal_blender's armadillo waist twisted 180 degrees: 3 crossing pairs
// with follow_twist, 3651 with both).
MatX3d SkeletalRig::Impl::pose_skeleton(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt, MatX9d& lin,
                                        MatX3d* blend, std::vector<PosedFillet>* fillets) const {
  MatX3d Sd;
  const bool ring = opt.ring_twist && ring_twist(pose, opt.dual_quaternion, Sd, lin);
  if (!ring) Sd = skeletal_subspace_deform(S, W, rest, pose, &lin, opt.dual_quaternion);
  if (blend) *blend = Sd;
  clear_bones(Sd, pose);
  const bool twist = follows_twist(opt);
  double dropped = 0;
  const bool followed = twist && (twist_free_pose(pose, dropped), dropped > 1e-6);
  std::vector<PosedFillet> fl;
  const bool untangling =
      opt.untangle_iterations > 0 && opt.method == SkeletalMethod::Variational && opt.fairing_steps > 0;
  // The fillet turns each cross-section by its share of the child's twist: by the ring weights
  // whether or not the pose's twist dominates (the capsule of bench skeletal_speed, bound without
  // weights, bent 60 and twisted 45 degrees: 734 crossing pairs shared by its weights, which vary
  // around the limb, none by the ring weights; bench/notes/skeletal.md, session 36). Also where
  // follow_twist acts: a bend that carries a larger twist is still a bend (skeletal_joints' capsule
  // bent 45 and twisted 90 degrees on the whole mesh: 165 pairs without the fillet there, 0 with).
  if (opt.joint_fillet > 0)
    fl = pose_fillets(pose, opt.joint_fillet, opt.ring_twist && W_ring.rows() == S.rows(),
                      untangling ? kUntangleFilletFade : 0.0);
  if (untangling) {
    // With the untangling the fillet fades out in tight bends (its radius below kUntangleFilletFade
    // limb radii) and the integrated skeleton is the base it is blended from: the untangling's joint
    // contact slide clears the colliding limbs of a 135-degree bend from there, not from a fillet
    // that cannot clear its inner side (bench skeletal_joints, untangle 10 through the layer: the
    // armadillo's knee 404 -> 49 pairs, DQS 308; bench/notes/skeletal.md, session 35).
    if (opt.integrate_skeleton && !followed) {
      integrate_skeleton(Sd, lin, pose);
      clear_bones(Sd, pose, kIntegrationClearance);
    }
    if (!fl.empty()) {
      double w = 0;
      for (const PosedFillet& pf : fl) w = std::max(w, pf.fillet.weight);
      fillet_skeleton(Sd, lin, fl);
      clear_bones(Sd, pose, kIntegrationClearance + (1 - kIntegrationClearance) * w);
      if (fillets) *fillets = std::move(fl);
    }
  } else if (!fl.empty()) {
    // The bent joints' fillets instead of the integration (which turns the axis as the weights do,
    // by the whole bend inside the blend); then every skeletal vertex back out to its rest distance
    // from its bones (the arc cuts the joint's corner).
    fillet_skeleton(Sd, lin, fl);
    clear_bones(Sd, pose);
    if (fillets) *fillets = std::move(fl);
  } else if (opt.integrate_skeleton && !followed) {
    // The integration cuts a joint's corner; where a limb's medial surface is a sheet bent in its own
    // plane it cut it across the bones (the flattened test limb's outer side: a skeletal vertex at
    // 0.043 of its rest distance to them). Not closer than half that distance, then (the full rest
    // distance, as before the integration, added crossing pairs on the legs of bench
    // skeletal_joints: the armadillo's knee bent 90 degrees, whole mesh, 4 -> 58).
    integrate_skeleton(Sd, lin, pose);
    clear_bones(Sd, pose, kIntegrationClearance);
  }
  return Sd;
}

MatX3d SkeletalRig::skeleton_pose(const std::vector<Mat4>& pose) const {
  MatX9d lin;
  return impl_->pose_skeleton(pose, SkeletalDeformOptions{}, lin);
}

MatX3d SkeletalRig::Impl::control_pose(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt,
                                       MatX3d* skeleton_out, std::vector<int>* deep, const MatX3d* skeleton,
                                       std::vector<char>* edited_out, Twist* tw_out) const {
  if (pose.size() != rest.size())
    throw MeshError("skeletal deform: expected " + std::to_string(rest.size()) + " pose matrices, got " +
                    std::to_string(pose.size()));
  for (const Mat4& m : pose)
    if (!m.allFinite()) throw MeshError("skeletal deform: pose matrices must be finite");
  if (opt.fairing_steps < 0 || opt.homotopy_steps < 1 || opt.fold_iterations < 0)
    throw MeshError("skeletal deform: fairing_steps and fold_iterations must be >= 0, homotopy_steps >= 1");
  if (!std::isfinite(opt.fairing_step) || !std::isfinite(opt.projection) || !std::isfinite(opt.bone_clearance))
    throw MeshError("skeletal deform: fairing_step, projection and bone_clearance must be finite");
  if (!(opt.joint_fillet >= 0) || !std::isfinite(opt.joint_fillet))
    throw MeshError("skeletal deform: joint_fillet must be 0 (off) or positive and finite");
  if (!(opt.contact_slide == 0 || opt.contact_slide >= 1))
    throw MeshError("skeletal deform: contact_slide must be 0 (off) or at least 1");
  if (opt.untangle_iterations < 0 || opt.untangle_rings < 0 || opt.fold_guard < 0)
    throw MeshError("skeletal deform: untangle_iterations, untangle_rings and fold_guard must be >= 0");
  const int n = static_cast<int>(S.rows());
  if (skeleton && (skeleton->rows() != n || !skeleton->allFinite()))
    throw MeshError("skeletal deform: the edited skeleton needs " + std::to_string(n) +
                    " finite rows (one per skeletal vertex), got " + std::to_string(skeleton->rows()));
  const bool twist = follows_twist(opt);
  MatX9d lin;
  MatX3d Sd_blend;
  std::vector<PosedFillet> fillets;
  MatX3d Sd = pose_skeleton(pose, opt, lin, twist ? &Sd_blend : nullptr, &fillets);
  std::vector<char> edited;
  if (skeleton) {
    // The edit's offsets turn with each skeletal vertex's blended bone frame: for rigid blends
    // (dual quaternions) this is the posed edited skeleton itself.
    edited.assign(n, 0);
    const double tol = 1e-9 * r_max;
    for (int i = 0; i < n; ++i) {
      const Vec3 d = row3(*skeleton, i) - row3(S, i);
      if (!(d.norm() > tol)) continue;
      edited[i] = 1;
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> R(lin.row(i).data());
      Sd.row(i) += (R * d).transpose();
    }
  }
  if (skeleton_out) *skeleton_out = Sd;
  if (edited_out) *edited_out = edited;
  if (opt.method != SkeletalMethod::Variational) return basic(Sd, opt);
  Twist tw;
  const bool has_twist = twist && make_twist(pose, opt, Sd_blend, lin, Sd, tw);
  const bool guard = opt.fold_guard > 0 && opt.fairing_steps > 0;
  MatX3d bare;
  MatX3d X = variational(Sd, lin, opt, deep, has_twist ? &tw : nullptr, guard ? &bare : nullptr, &fillets, &edited);
  // With the thickness steps (fairing_steps = 0 is the bare reconstruction eq. 6.11).
  if (opt.fairing_steps > 0) {
    clear_surface(X, pose, opt.bone_clearance, edited);
    const bool contact = contact_slide(X, control.V, pose, opt.contact_slide, [&](int i, int j) { return W(i, j); });
    if (guard) {
      const auto skip = [&](int i) { return !edited.empty() && edited[i]; };
      const auto constrain = [&] {
        return contact_constraint(clearance_constraint(untangle_clearance, X.rows(), pose, opt.bone_clearance, skip),
                                  control.V, X, pose, opt.contact_slide, [&](int i, int j) { return W(i, j); });
      };
      control_guard.apply(
          X, bare, {opt.fold_guard}, edited.empty() ? nullptr : &edited, constrain(), nullptr,
          reference_trust(control.F, control.V, bare, pose, [&](int f) {
            return Eigen::RowVectorXd(W.row(control.F(f, 0)) + W.row(control.F(f, 1)) + W.row(control.F(f, 2)));
          }));
      // With the joint contact acting on the whole mesh (a bend changed; not under a skeleton edit,
      // which skinning does not know), a second pass against the dual quaternion skinning of the
      // rest mesh: the faces the trust rule left alone (the bare reconstruction folds in a tight
      // bend's crease) and those the slide turned against the skinned surface. Measured on the
      // whole-mesh path only and only with the contact (bench/notes/skeletal.md, session 27):
      // without it the pass added pairs (tests/python's capsule bent 90 degrees: 63 -> 145), and
      // through the multiresolution layer (on the control mesh) it did too.
      if (contact && !multires && edited.empty())
        control_guard.apply(X, skeletal_subspace_deform(control.V, W, rest, pose, nullptr, true), {opt.fold_guard},
                            nullptr, constrain());
    }
    if (has_twist && multires && opt.untangle_iterations > 0) {
      // follow_twist through the layer: the control mesh is untangled in the twist-free pose. In the
      // pose, the crossings of the coarse control mesh that the twist alone makes (armadillo waist
      // twisted 180 degrees through a 5000-face control mesh: 94, 11 at rest; the dense mesh then has
      // none) were smoothed and the dense mesh rebuilt on the result crossed itself (76 pairs; session
      // 25). Since session 36 the dense mesh is rebuilt in the pose (see project_dense): that waist 16
      // pairs, untangled so 0.
      MatX3d Xf(X.rows(), 3);
      for (Eigen::Index i = 0; i < X.rows(); ++i)
        Xf.row(i) = tw.to_free(static_cast<int>(i), row3(X, static_cast<int>(i))).transpose();
      untangle(Xf, tw.Ss, tw.free_pose, opt, edited);
      for (Eigen::Index i = 0; i < X.rows(); ++i)
        X.row(i) = (tw.R[i] * row3(Xf, static_cast<int>(i)) + tw.t[i]).transpose();
    } else {
      untangle(X, Sd, pose, opt, edited);
    }
  }
  if (tw_out && has_twist) *tw_out = std::move(tw);
  return X;
}

MatX3d SkeletalRig::deform_control(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt,
                                   MatX3d* skeleton_out, const MatX3d* skeleton) const {
  return impl_->control_pose(pose, opt, skeleton_out, nullptr, skeleton);
}

namespace {
// Whether the dense vertices get the explicit thickness step and the surface bone clearance (see
// Impl::project_dense): with the variational method and its fairing on, as for the control mesh.
bool dense_projection(const SkeletalDeformOptions& opt) {
  return opt.method == SkeletalMethod::Variational && opt.fairing_steps > 0 &&
         (opt.projection > 0 || opt.bone_clearance > 0);
}
}  // namespace

namespace {
// Control pose, then the dense mesh through the multiresolution layer (and its thickness step), into
// `out` (float64 or float32 rows).
template <class Impl, class Out>
void deform_into(const Impl& impl, int n, const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt,
                 const MatX3d* skeleton, Out& out) {
  if (out.rows() != n)
    throw MeshError("skeletal deform: the output needs " + std::to_string(n) + " rows, got " +
                    std::to_string(out.rows()));
  MatX3d Sd;
  std::vector<int> deep;
  std::vector<char> edited;
  Twist tw;
  const MatX3d Xc = impl.control_pose(pose, opt, &Sd, impl.multires ? &deep : nullptr, skeleton, &edited, &tw);
  if (impl.multires) {
    // follow_twist: the dense thickness is measured in the twist-free pose (project_dense).
    const Twist* twist = tw.R.empty() ? nullptr : &tw;
    impl.multires->reconstruct(Xc, out);
    const auto slide = [&] {  // the joint contact, before the dense guard when there is one
      impl.contact_slide(out, impl.dense_rest, pose, opt.contact_slide,
                         [&](int i, int j) { return impl.dense_weight(i, j); });
    };
    if (dense_projection(opt)) {
      // The fold guard against the limit surface before the dense step.
      const bool guard = opt.fold_guard > 0 && !impl.dense_guard.empty();
      using Plain = Eigen::Matrix<typename Out::Scalar, Eigen::Dynamic, 3, Eigen::RowMajor>;
      Plain ref = guard ? Plain(out) : Plain();
      impl.project_dense(Sd, deep, pose, opt, edited, twist, out);
      slide();
      if (guard) {
        const VecXi& face = impl.multires->base_face();
        const MatX3i& Fc = impl.control.F;
        const auto on_edit = [&](int i) {
          return !edited.empty() && (edited[Fc(face[i], 0)] || edited[Fc(face[i], 1)] || edited[Fc(face[i], 2)]);
        };
        impl.dense_guard.apply(
            out, ref, {opt.fold_guard}, nullptr,
            impl.contact_constraint(
                impl.clearance_constraint(impl.dense_untangle_clearance, out.rows(), pose, opt.bone_clearance, on_edit),
                impl.dense_rest, out, pose, opt.contact_slide, [&](int i, int j) { return impl.dense_weight(i, j); }),
            // (an edit, and the joint contact's slide, move "rigid" faces too)
            edited.empty() && !(opt.contact_slide >= 1) ? &impl.dense_faces : nullptr,
            impl.reference_trust(impl.dense_F, impl.dense_rest, ref, pose, [&](int f) {
              const int b = face[impl.dense_F(f, 0)];
              return Eigen::RowVectorXd(impl.W.row(Fc(b, 0)) + impl.W.row(Fc(b, 1)) + impl.W.row(Fc(b, 2)));
            }));
      }
    }
    if (opt.method == SkeletalMethod::Variational && opt.fairing_steps > 0) {
      if (!dense_projection(opt)) slide();
      impl.untangle_dense(out, Sd, pose, opt, edited);
    }
  } else {
    out = Xc.template cast<typename Out::Scalar>();
  }
}
}  // namespace

MatX3d SkeletalRig::deform(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt,
                           const MatX3d* skeleton) const {
  MatX3d X(n_vertices(), 3);
  deform(pose, opt, Eigen::Ref<MatX3d>(X), skeleton);
  return X;
}

void SkeletalRig::deform(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt, Eigen::Ref<MatX3d> out,
                         const MatX3d* skeleton) const {
  deform_into(*impl_, n_vertices(), pose, opt, skeleton, out);
}

void SkeletalRig::deform(const std::vector<Mat4>& pose, const SkeletalDeformOptions& opt, Eigen::Ref<MatX3f> out,
                         const MatX3d* skeleton) const {
  deform_into(*impl_, n_vertices(), pose, opt, skeleton, out);
}

int SkeletalRig::n_vertices() const {
  return impl_->multires ? impl_->multires->n_dense() : static_cast<int>(impl_->control.V.rows());
}
int SkeletalRig::n_control() const { return static_cast<int>(impl_->control.V.rows()); }
int SkeletalRig::n_bones() const { return static_cast<int>(impl_->rest.size()); }
bool SkeletalRig::has_multires() const { return impl_->multires.has_value(); }
const MatX3d& SkeletalRig::control_vertices() const { return impl_->control.V; }
const MatX3i& SkeletalRig::control_faces() const { return impl_->control.F; }
const MatX3d& SkeletalRig::skeleton_vertices() const { return impl_->S; }
const VecXd& SkeletalRig::radii() const { return impl_->radii; }
const Eigen::MatrixXd& SkeletalRig::weights() const { return impl_->W; }
const Eigen::MatrixXd& SkeletalRig::ring_weights() const { return impl_->W_ring; }
const std::vector<Mat4>& SkeletalRig::bones_rest() const { return impl_->rest; }

}  // namespace dgmesh
