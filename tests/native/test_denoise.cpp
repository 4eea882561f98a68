// Similarity-based and bilateral denoising on surfaces with known answers (thesis ch. 2).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "dgmesh/denoise.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/parallel.h"
#include "dgmesh/shapes.h"
#include "dgmesh/validate.h"

#include "test_meshes.h"

using namespace dgmesh;
using dgmesh::test::mean_edge;

namespace {

// Gaussian noise of deviation sigma along the (clean) vertex normals, fixed seed.
MatX3d add_normal_noise(const MatX3d& V, const MatX3i& F, double sigma, unsigned seed) {
  const Mesh m = make_mesh(V, F);
  const MatX3d N = vertex_normals(m.V, m.F, m.topo);
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, sigma);
  MatX3d out = V;
  for (int i = 0; i < V.rows(); ++i) out.row(i) += g(rng) * N.row(i);
  return out;
}

// Angle (degrees) between corresponding face normals.
VecXd face_normal_error(const MatX3d& A, const MatX3d& B, const MatX3i& F) {
  const MatX3d na = face_normals(A, F), nb = face_normals(B, F);
  VecXd e(F.rows());
  for (int f = 0; f < F.rows(); ++f) e(f) = std::acos(std::clamp(na.row(f).dot(nb.row(f)), -1.0, 1.0)) * 180.0 / M_PI;
  return e;
}

// Cube [-1,1]^3 with an n x n grid on each face, welded along the edges, outward oriented.
TriMesh cube(int n) {
  std::map<std::tuple<long, long, long>, int> index;
  TriMesh t;
  std::vector<Vec3> pts;
  std::vector<Eigen::Vector3i> tris;
  auto vid = [&](const Vec3& p) {
    const auto key = std::make_tuple(std::lround(p.x() * n), std::lround(p.y() * n), std::lround(p.z() * n));
    auto it = index.find(key);
    if (it != index.end()) return it->second;
    pts.push_back(p);
    return index[key] = static_cast<int>(pts.size()) - 1;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int s = -1; s <= 1; s += 2) {
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      auto P = [&](int i, int j) {
        Vec3 p;
        p(axis) = s;
        p(a) = -1 + 2.0 * i / n;
        p(b) = -1 + 2.0 * j / n;
        return vid(p);
      };
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          int q[4] = {P(i, j), P(i + 1, j), P(i + 1, j + 1), P(i, j + 1)};
          // (a, b, axis) is right-handed, so (i, j) counter-clockwise faces +axis.
          if (s < 0) std::swap(q[1], q[3]);
          tris.emplace_back(q[0], q[1], q[2]);
          tris.emplace_back(q[0], q[2], q[3]);
        }
    }
  t.V.resize(pts.size(), 3);
  for (size_t i = 0; i < pts.size(); ++i) t.V.row(i) = pts[i].transpose();
  t.F.resize(tris.size(), 3);
  for (size_t i = 0; i < tris.size(); ++i) t.F.row(i) = tris[i].transpose();
  return t;
}

// The thesis's setting (section 2.3) by hand: these tests are about the filter, not the rule.
DenoiseOptions sim() {
  DenoiseOptions o;
  o.automatic = false;
  return o;
}

}  // namespace

TEST(Denoise, NoisyPlaneReturnsToThePlane) {
  const TriMesh g = grid(40, 40);
  const double e = mean_edge(g.V, g.F);
  MatX3d Vn = g.V;
  std::mt19937 rng(3);
  std::normal_distribution<double> nd(0.0, 0.2 * e);
  for (int i = 0; i < Vn.rows(); ++i) Vn(i, 2) += nd(rng);
  const double before = std::sqrt(Vn.col(2).squaredNorm() / Vn.rows());
  for (const DenoiseOptions& o : {sim(), bilateral_defaults()}) {
    const DenoiseResult r = denoise(Vn, g.F, o);
    double inner = 0;
    int cnt = 0;
    for (int i = 0; i < Vn.rows(); ++i)
      if (g.V(i, 0) > 0.1 && g.V(i, 0) < 0.9 && g.V(i, 1) > 0.1 && g.V(i, 1) < 0.9) {
        inner += r.vertices(i, 2) * r.vertices(i, 2);
        ++cnt;
      }
    inner = std::sqrt(inner / cnt);
    // Measured: 0.2 e of noise drops to about 0.033 e inside.
    EXPECT_LT(inner, 0.06 * e) << static_cast<int>(o.method);
    EXPECT_LT(inner, before / 3);
    EXPECT_TRUE(r.vertices.allFinite());
    EXPECT_NEAR(r.edge_length, e, 0.05 * e);  // e of the last (nearly flat) iteration
  }
}

TEST(Denoise, ExactPlaneDoesNotMove) {
  TriMesh g = grid(20, 20);
  // Tilted plane: no coordinate is special.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  g.V = (g.V * R.transpose()).eval();
  const DenoiseResult r = denoise(g.V, g.F, sim());
  EXPECT_LT((r.vertices - g.V).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(r.residual.maxCoeff(), 1e-9);
  EXPECT_EQ(r.rbf_fallbacks, 0);
}

TEST(Denoise, NoisySphereReturnsToTheSphereAndKeepsItsRadius) {
  const TriMesh s = icosphere(4, 1.0);
  const double e = mean_edge(s.V, s.F);
  const MatX3d Vn = add_normal_noise(s.V, s.F, 0.2 * e, 5);
  const VecXd r0 = Vn.rowwise().norm();
  const double dev0 = std::sqrt((r0.array() - r0.mean()).square().mean());
  const DenoiseResult r = denoise(Vn, s.F, sim());
  const VecXd rad = r.vertices.rowwise().norm();
  const double dev = std::sqrt((rad.array() - rad.mean()).square().mean());
  // Measured: deviation from round 0.0150 -> 0.0031, mean radius 0.987 (NL-means shrinks a
  // little, like every averaging of heights over a curved patch).
  EXPECT_LT(dev, dev0 / 3);
  EXPECT_LT(dev, 0.005);
  EXPECT_NEAR(rad.mean(), 1.0, 0.02);
  EXPECT_LT((rad.array() - 1.0).abs().maxCoeff(), 0.035);
}

TEST(Denoise, CubeKeepsSharpEdgesFarBetterThanBilateral) {
  const TriMesh c = cube(16);
  const double e = mean_edge(c.V, c.F);
  const MatX3d Vn = add_normal_noise(c.V, c.F, 0.2 * e, 7);
  const DenoiseResult rs = denoise(Vn, c.F, sim());
  const DenoiseResult rb = denoise(Vn, c.F, bilateral_defaults());
  const VecXd es = face_normal_error(rs.vertices, c.V, c.F), eb = face_normal_error(rb.vertices, c.V, c.F);
  double s_edge = 0, b_edge = 0, s_flat = 0;
  int n_edge = 0, n_flat = 0;
  for (int f = 0; f < c.F.rows(); ++f) {
    bool at_edge = false;
    for (int k = 0; k < 3; ++k) {
      const auto p = c.V.row(c.F(f, k));
      at_edge |= (p.array().abs() > 1 - 1e-9).count() >= 2;
    }
    if (at_edge) {
      s_edge += es(f), b_edge += eb(f), ++n_edge;
    } else {
      s_flat += es(f), ++n_flat;
    }
  }
  s_edge /= n_edge, b_edge /= n_edge, s_flat /= n_flat;
  // Measured: similarity about 5 degrees at edge faces, bilateral about 18.
  EXPECT_LT(s_edge, 8.0);
  EXPECT_LT(s_edge, 0.5 * b_edge);
  EXPECT_LT(s_flat, 3.0);
}

TEST(Denoise, SoupStaysCrackFreeAndMatchesTheWeldedMesh) {
  const TriMesh s = icosphere(3, 1.0);
  const MatX3d Vn = add_normal_noise(s.V, s.F, 0.2 * mean_edge(s.V, s.F), 11);
  // Every face gets its own three vertices, listed in reverse face order.
  const int m = static_cast<int>(s.F.rows());
  MatX3d Vs(3 * m, 3);
  MatX3i Fs(m, 3);
  std::vector<int> orig(3 * m);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = 3 * (m - 1 - f) + k;
      Vs.row(i) = Vn.row(s.F(f, k));
      Fs(f, k) = i;
      orig[i] = s.F(f, k);
    }
  const DenoiseResult soup = denoise(Vs, Fs, sim());
  const DenoiseResult mesh = denoise(Vn, s.F, sim());
  EXPECT_EQ(soup.welded, 3 * m - static_cast<int>(s.V.rows()));
  double crack = 0, diff = 0;
  for (int i = 0; i < 3 * m; ++i) {
    for (int j = i + 1; j < 3 * m; ++j)
      if (orig[j] == orig[i]) crack = std::max(crack, (soup.vertices.row(i) - soup.vertices.row(j)).norm());
    diff = std::max(diff, (soup.vertices.row(i) - mesh.vertices.row(orig[i])).norm());
  }
  EXPECT_EQ(crack, 0.0);  // copies receive the very same displacement
  EXPECT_LT(diff, 1e-9);
  EXPECT_GT(soup.residual.maxCoeff(), 0.0);
}

TEST(Denoise, MaskedVerticesDoNotMoveButOthersDo) {
  const TriMesh s = icosphere(3, 1.0);
  const MatX3d Vn = add_normal_noise(s.V, s.F, 0.2 * mean_edge(s.V, s.F), 13);
  for (DenoiseOptions o : {sim(), bilateral_defaults()}) {
    o.movable.assign(Vn.rows(), 1);
    for (int i = 0; i < Vn.rows(); ++i)
      if (Vn(i, 2) > 0) o.movable[i] = 0;
    const DenoiseResult r = denoise(Vn, s.F, o);
    int moved = 0;
    for (int i = 0; i < Vn.rows(); ++i) {
      if (!o.movable[i]) {
        EXPECT_EQ((r.vertices.row(i) - Vn.row(i)).norm(), 0.0) << i;
        EXPECT_EQ(r.residual(i), 0.0);
      } else if (r.residual(i) > 1e-6) {
        ++moved;
      }
    }
    EXPECT_GT(moved, Vn.rows() / 3);
  }
}

TEST(Denoise, PointCloudWithNormalsIsDenoised) {
  const TriMesh s = icosphere(4, 2.0);
  const double e = mean_edge(s.V, s.F);
  const MatX3d Vn = add_normal_noise(s.V, s.F, 0.2 * e, 17);
  const MatX3d N = s.V / 2.0;  // exact normals
  const VecXd r0 = Vn.rowwise().norm();
  const double dev0 = std::sqrt((r0.array() - r0.mean()).square().mean());
  for (bool reestimate : {true, false}) {
    DenoiseOptions o;
    o.reestimate_normals = reestimate;
    const DenoiseResult r = denoise_points(Vn, N, o);
    const VecXd rad = r.vertices.rowwise().norm();
    EXPECT_LT(std::sqrt((rad.array() - rad.mean()).square().mean()), dev0 / 3);
    EXPECT_NEAR(rad.mean(), 2.0, 0.04);
    // e from the sampling density is close to the mesh's edge length.
    EXPECT_NEAR(r.edge_length, e, 0.1 * e);
  }
}

TEST(Denoise, RepeatedPointsFallBackToAPlaneAndNeverGiveNaN) {
  // Without welding, coincident vertices make the RBF system singular.
  TriMesh g = grid(6, 6);
  const int n = static_cast<int>(g.V.rows());
  MatX3d V(2 * n, 3);
  V << g.V, g.V;
  MatX3i F(2 * g.F.rows(), 3);
  F << g.F, (g.F.array() + n).matrix();
  V(24, 2) = 0.01;  // the centre vertex
  V(n + 24, 2) = 0.01;
  DenoiseOptions o = sim();
  o.weld_tolerance = 0;
  const DenoiseResult r = denoise(V, F, o);
  EXPECT_TRUE(r.vertices.allFinite());
  EXPECT_GT(r.rbf_fallbacks, 0);
  // Welded, the same input is a plain grid with one bump and no fallback is needed.
  const DenoiseResult w = denoise(V, F, sim());
  EXPECT_EQ(w.welded, n);
  EXPECT_EQ(w.rbf_fallbacks, 0);
  EXPECT_LT(std::abs(w.vertices(24, 2)), 0.002);
}

TEST(Denoise, SameResultWithAnyThreadCount) {
  const TriMesh s = icosphere(3, 1.0);
  const MatX3d Vn = add_normal_noise(s.V, s.F, 0.2 * mean_edge(s.V, s.F), 19);
  const int before = num_threads();
  set_num_threads(1);
  const DenoiseResult a = denoise(Vn, s.F, sim());
  set_num_threads(2);
  const DenoiseResult b = denoise(Vn, s.F, sim());
  set_num_threads(before);
  EXPECT_EQ((a.vertices - b.vertices).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Denoise, ResidualAndEntropy) {
  const TriMesh s = icosphere(3, 1.0);
  const MatX3d Vn = add_normal_noise(s.V, s.F, 0.2 * mean_edge(s.V, s.F), 23);
  const DenoiseResult r = denoise(Vn, s.F, sim());
  for (int i = 0; i < Vn.rows(); ++i) EXPECT_NEAR(r.residual(i), (r.vertices.row(i) - Vn.row(i)).norm(), 1e-15);
  EXPECT_NEAR(r.residual_entropy, residual_entropy(r.residual), 1e-12);
  EXPECT_GT(r.residual_entropy, 1.0);
  EXPECT_LT(r.residual_entropy, std::log2(65.0));
  // Known answers: constant -> 0 bits; two equally frequent, well separated values -> 1 bit.
  EXPECT_EQ(residual_entropy(VecXd::Constant(10, 0.3)), 0.0);
  VecXd two(4);
  two << 0.1, 0.1, 1.0, 1.0;
  EXPECT_NEAR(residual_entropy(two), 1.0, 1e-12);
  EXPECT_EQ(residual_entropy(VecXd::Zero(5)), 0.0);
  // Zero iterations change nothing.
  DenoiseOptions o = sim();
  o.iterations = 0;
  const DenoiseResult z = denoise(Vn, s.F, o);
  EXPECT_EQ((z.vertices - Vn).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Denoise, AutomaticReportsItsEstimateAndLeavesCleanInputAlone) {
  const TriMesh s = icosphere(3, 1.0);
  const DenoiseResult clean = denoise(s.V, s.F, DenoiseOptions{});
  EXPECT_TRUE(clean.options.automatic);
  EXPECT_LT(clean.noise.sigma, 0.01);
  EXPECT_LT((clean.vertices - s.V).cwiseAbs().maxCoeff(), 1e-3 * mean_edge(s.V, s.F));
  const MatX3d Vn = add_normal_noise(s.V, s.F, 0.2 * mean_edge(s.V, s.F), 29);
  const DenoiseResult r = denoise(Vn, s.F, DenoiseOptions{});
  const NoiseEstimate est = estimate_noise(Vn, s.F);
  EXPECT_EQ(r.noise.sigma, est.sigma);
  EXPECT_EQ(r.options.eta1, auto_options(est, DenoiseOptions{}).eta1);
  EXPECT_EQ(r.iterations, r.options.iterations);
  EXPECT_GT(r.residual.maxCoeff(), 0.0);
}

namespace {

// Gaussian noise of deviation sigma in each coordinate, fixed seed.
MatX3d add_isotropic_noise(const MatX3d& V, double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, sigma);
  MatX3d out = V;
  for (int i = 0; i < V.rows(); ++i)
    for (int k = 0; k < 3; ++k) out(i, k) += g(rng);
  return out;
}

double mean_error(const MatX3d& A, const MatX3d& B, const MatX3i& F) { return face_normal_error(A, B, F).mean(); }

}  // namespace

TEST(Denoise, TaubinSmoothingStepsLowerTheNoiseAndKeepFixedVertices) {
  const TriMesh s = icosphere(3, 1.0);
  const MatX3d Vn = add_isotropic_noise(s.V, 0.2 * mean_edge(s.V, s.F), 41);
  DenoiseOptions o = sim();
  o.iterations = 0;
  o.smoothing_steps = 10;
  const DenoiseResult r = denoise(Vn, s.F, o);
  EXPECT_LT(mean_error(r.vertices, s.V, s.F), 0.5 * mean_error(Vn, s.V, s.F));
  // Taubin's mu step undoes the lambda step's shrinkage: the radius stays within 1% of the sphere's.
  EXPECT_NEAR(r.vertices.rowwise().norm().mean(), 1.0, 0.01);
  o.movable.assign(s.V.rows(), 1);
  o.movable[5] = 0;
  const DenoiseResult m = denoise(Vn, s.F, o);
  EXPECT_EQ((m.vertices.row(5) - Vn.row(5)).norm(), 0.0);
  EXPECT_GT((m.vertices.row(6) - Vn.row(6)).norm(), 0.0);
  o.smoothing_steps = -1;
  EXPECT_THROW(denoise(Vn, s.F, o), MeshError);
}

TEST(Denoise, TaubinSmoothingSurvivesDegenerateFaces) {
  // The operator's cotangent half: a face with a vertex on its opposite edge (zero area, infinite
  // cotangents) and a sliver must not make a weight NaN or unbounded; the result stays finite and
  // within the input's bounding box (the weights are convex).
  TriMesh s = icosphere(2, 1.0);
  const int a = s.F(0, 0), b = s.F(0, 1), c = s.F(0, 2);
  s.V.row(c) = 0.5 * (s.V.row(a) + s.V.row(b));
  const int d = s.F(10, 0), e = s.F(10, 1), f = s.F(10, 2);
  s.V.row(f) = 0.5 * (s.V.row(d) + s.V.row(e)) + 1e-12 * (s.V.row(f) - s.V.row(d));
  DenoiseOptions o = sim();
  o.iterations = 0;
  o.smoothing_steps = 5;
  const DenoiseResult r = denoise(s.V, s.F, o);
  EXPECT_TRUE(r.vertices.allFinite());
  EXPECT_LE(r.vertices.cwiseAbs().maxCoeff(), s.V.cwiseAbs().maxCoeff() * 1.05);
}

TEST(Denoise, AutomaticSmoothingRule) {
  NoiseEstimate e;
  EXPECT_EQ(auto_smoothing_steps(e), 0);  // noise-free: no smoothing
  e.detail = 0.1;
  e.sigma = 0.1;
  const int low = auto_smoothing_steps(e);
  e.sigma = 0.3;
  const int high = auto_smoothing_steps(e);
  EXPECT_GT(low, 0);
  EXPECT_GT(high, low);  // more noise, more steps
  e.detail = 0.3;
  EXPECT_LT(auto_smoothing_steps(e), high);  // more shape detail at the sampling scale, fewer steps
  // Below the shape's own reading min(0.9 detail, 0.1 e) sigma is not noise: a noise-free coarse
  // scan (elephant: sigma 0.090, detail 0.213; cow 0.091 / 0.136) gets no step, the same with 0.1 e
  // of noise (elephant: 0.164 / 0.233) does.
  e.sigma = 0.090;
  e.detail = 0.213;
  EXPECT_EQ(auto_smoothing_steps(e), 0);
  e.sigma = 0.091;
  e.detail = 0.136;
  EXPECT_EQ(auto_smoothing_steps(e), 0);
  e.sigma = 0.164;
  e.detail = 0.233;
  EXPECT_GT(auto_smoothing_steps(e), 0);
  // Refitted for the half-cotangent operator (session 25): elephant with 0.3 e of isotropic noise
  // (seed 11: sigma 0.324, detail 0.272) is best with 15 steps of it; the rule fitted for the
  // uniform umbrella gave 6 (11.73 degrees against the best 10.40), the refit 8 (11.01).
  e.sigma = 0.324;
  e.detail = 0.272;
  EXPECT_GE(auto_smoothing_steps(e), 8);
  e.detail = 0;
  e.sigma = 1.0;
  EXPECT_EQ(auto_smoothing_steps(e), 60);  // capped
  e.outliers = 0.3;
  e.curvature = 0.1;
  EXPECT_TRUE(shows_features(e));
  e.curvature = 0.5;
  EXPECT_FALSE(shows_features(e));
}

TEST(Denoise, AutomaticSmoothsCoarseSmoothSurfaces) {
  // A coarse sphere (e kappa about 0.3) with isotropic noise: no sharp feature, so the default
  // smooths (Taubin) instead of filtering, and does better than the filter with the rule's eta1.
  const TriMesh s = icosphere(2, 1.0);
  const MatX3d Vn = add_isotropic_noise(s.V, 0.2 * mean_edge(s.V, s.F), 43);
  const DenoiseResult r = denoise(Vn, s.F, DenoiseOptions{});
  EXPECT_GT(r.options.smoothing_steps, 0);
  EXPECT_EQ(r.options.smoothing_steps, auto_smoothing_steps(r.noise));
  EXPECT_EQ(r.iterations, 0);
  DenoiseOptions filter = auto_options(estimate_noise(Vn, s.F), DenoiseOptions{});
  filter.automatic = false;
  const DenoiseResult f = denoise(Vn, s.F, filter);
  EXPECT_LT(mean_error(r.vertices, s.V, s.F), 0.8 * mean_error(f.vertices, s.V, s.F));
}

TEST(Denoise, AutomaticKeepsTheFilterOnSharpFeatures) {
  // A noisy cube: the rule asks for smoothing, but the filtered mesh shows its creases, so the
  // filter's result is kept; Taubin smoothing with the rule's step count would round them. (On a
  // 10 x 10 cube the creases' fits read as curvature instead and the test fails: a known limit,
  // bench/notes/denoise.md.)
  const TriMesh c = cube(16);
  const MatX3d Vn = add_normal_noise(c.V, c.F, 0.1 * mean_edge(c.V, c.F), 47);
  const DenoiseResult r = denoise(Vn, c.F, DenoiseOptions{});
  const int steps = auto_smoothing_steps(r.noise);
  EXPECT_GT(steps, 0);
  EXPECT_EQ(r.options.smoothing_steps, 0);
  EXPECT_EQ(r.iterations, 3);
  DenoiseOptions smooth = sim();
  smooth.iterations = 0;
  smooth.smoothing_steps = steps;
  const DenoiseResult t = denoise(Vn, c.F, smooth);
  EXPECT_LT(mean_error(r.vertices, c.V, c.F), 0.8 * mean_error(t.vertices, c.V, c.F));
}

TEST(Denoise, BadInputGivesClearErrors) {
  const TriMesh s = icosphere(1, 1.0);
  MatX3d bad = s.V;
  bad(3, 1) = std::nan("");
  EXPECT_THROW(denoise(bad, s.F, sim()), MeshError);
  MatX3i badF = s.F;
  badF(2, 1) = 999;
  EXPECT_THROW(denoise(s.V, badF, sim()), MeshError);
  EXPECT_THROW(denoise(s.V, MatX3i(0, 3), sim()), MeshError);
  EXPECT_THROW(denoise(MatX3d(0, 3), s.F, sim()), MeshError);
  DenoiseOptions o;
  o.movable.assign(3, 1);
  EXPECT_THROW(denoise(s.V, s.F, o), MeshError);
  o = sim();
  o.eta1 = -1;
  EXPECT_THROW(denoise(s.V, s.F, o), MeshError);
  o = sim();
  o.eta3 = std::nan("");
  EXPECT_THROW(denoise(s.V, s.F, o), MeshError);
  // All faces degenerate: nothing to measure.
  MatX3d flat = MatX3d::Zero(s.V.rows(), 3);
  EXPECT_THROW(denoise(flat, s.F, sim()), MeshError);
  // Point clouds.
  EXPECT_THROW(denoise_points(s.V, MatX3d(2, 3), sim()), MeshError);
  MatX3d badN = s.V;
  badN(0, 0) = INFINITY;
  EXPECT_THROW(denoise_points(s.V, badN, sim()), MeshError);
  EXPECT_THROW(denoise_points(s.V.topRows(3), s.V.topRows(3), sim()), MeshError);
  EXPECT_THROW(similarity(s.V, s.F, 1000), MeshError);
  EXPECT_THROW(similarity(s.V, s.F, -1), MeshError);
  try {
    denoise(bad, s.F, sim());
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("row 3"), std::string::npos) << e.what();
  }
}

TEST(Denoise, CancelFromProgress) {
  const TriMesh s = icosphere(5, 1.0);
  EXPECT_THROW(denoise(s.V, s.F, sim(), [](double) { return false; }), CancelledError);
  // Cancelled at the first report after the start (reports are throttled to one per 50 ms).
  int calls = 0;
  EXPECT_THROW(denoise(s.V, s.F, sim(), [&](double f) { return ++calls < 2 || f >= 1.0; }), CancelledError);
  EXPECT_EQ(calls, 2);
  std::vector<double> seen;
  denoise(s.V, s.F, sim(), [&](double f) {
    seen.push_back(f);
    return true;
  });
  ASSERT_GE(seen.size(), 2u);
  EXPECT_EQ(seen.front(), 0.0);
  EXPECT_EQ(seen.back(), 1.0);
  for (size_t i = 1; i < seen.size(); ++i) EXPECT_GE(seen[i], seen[i - 1]);
}

TEST(Similarity, SelfIsOneAndSimilarShapesScoreHigh) {
  const TriMesh c = cube(12);
  // Centre of the +z face, a point on the edge x = y = 1, and the centre of the -x face.
  auto find = [&](const Vec3& p) {
    int best = 0;
    for (int i = 0; i < c.V.rows(); ++i)
      if ((c.V.row(i).transpose() - p).norm() < (c.V.row(best).transpose() - p).norm()) best = i;
    return best;
  };
  const int centre = find(Vec3(0, 0, 1)), face_point = find(Vec3(0.5, -0.5, 1)), edge = find(Vec3(1, 0, 1));
  const VecXd w = similarity(c.V, c.F, centre);
  EXPECT_NEAR(w(centre), 1.0, 1e-6);
  EXPECT_GT(w(face_point), 0.99);  // same flat shape, same orientation
  EXPECT_LT(w(edge), 0.2);         // an edge is a different shape
  EXPECT_TRUE(((w.array() >= 0) && (w.array() <= 1)).all());
  // The filter's own weights vanish away from x (heights measured from x's tangent plane).
  SimilarityOptions o;
  o.shape_only = false;
  const VecXd wf = similarity(c.V, c.F, centre, o);
  EXPECT_NEAR(wf(centre), 1.0, 1e-6);
  EXPECT_GT(wf(face_point), 0.99);            // still in the same plane
  EXPECT_LT(wf(find(Vec3(0, 0, -1))), 1e-6);  // the opposite face
}
