// Crest lines on surfaces with known answers (thesis chapter 4).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "dgmesh/crest_lines.h"
#include "dgmesh/errors.h"
#include "dgmesh/shapes.h"
#include "dgmesh/validate.h"

using namespace dgmesh;

// Shapes shared with test_decimate.cpp and test_segment.cpp (declared there).
namespace crest_test {

// Axis-aligned cube [-1, 1]^3 with n x n quads per side (shared vertices), triangulated.
TriMesh cube_grid(int n) {
  std::map<std::array<int, 3>, int> index;
  std::vector<Vec3> verts;
  std::vector<std::array<int, 3>> tris;
  auto vid = [&](int i, int j, int k) {
    const std::array<int, 3> key{i, j, k};
    auto it = index.find(key);
    if (it != index.end()) return it->second;
    const int id = static_cast<int>(verts.size());
    verts.emplace_back(2.0 * i / n - 1, 2.0 * j / n - 1, 2.0 * k / n - 1);
    index.emplace(key, id);
    return id;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side)
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
          auto p = [&](int da, int db) {
            std::array<int, 3> c{};
            c[axis] = side * n;
            c[(axis + 1) % 3] = a + da;
            c[(axis + 2) % 3] = b + db;
            return vid(c[0], c[1], c[2]);
          };
          const int v00 = p(0, 0), v10 = p(1, 0), v11 = p(1, 1), v01 = p(0, 1);
          // (axis+1, axis+2, axis) is right-handed: CCW seen from outside on the + side.
          if (side == 1) {
            tris.push_back({v00, v10, v11});
            tris.push_back({v00, v11, v01});
          } else {
            tris.push_back({v00, v11, v10});
            tris.push_back({v00, v01, v11});
          }
        }
  TriMesh m;
  m.V.resize(verts.size(), 3);
  for (size_t i = 0; i < verts.size(); ++i) m.V.row(i) = verts[i].transpose();
  m.F.resize(tris.size(), 3);
  for (size_t i = 0; i < tris.size(); ++i) m.F.row(i) << tris[i][0], tris[i][1], tris[i][2];
  return m;
}

// Rounded cube: flat sides, quarter-cylinder edges of radius r, sphere-octant corners.
TriMesh rounded_cube(int n, double r) {
  TriMesh m = cube_grid(n);
  const double a = 1.0 - r;
  for (int i = 0; i < m.V.rows(); ++i) {
    const Vec3 p = m.V.row(i);
    const Vec3 c = p.cwiseMax(Vec3::Constant(-a)).cwiseMin(Vec3::Constant(a));
    m.V.row(i) = (c + r * (p - c).normalized()).transpose();
  }
  return m;
}

// Share of the crest points of `lines` on a rounded_cube(n, r)'s blend middles (|x| = |y| on an arc) or in a corner.
double blend_middle_share(const CrestLines& lines, double r) {
  const double mid = (1 - r) + r / std::sqrt(2.0);
  int on = 0;
  for (int i = 0; i < lines.points.rows(); ++i) {
    Vec3 p = lines.points.row(i).cwiseAbs();
    std::sort(p.data(), p.data() + 3);
    on += (std::abs(p[1] - mid) < 0.05 && std::abs(p[2] - mid) < 0.05) || p[0] > 1 - r - 0.05;
  }
  return static_cast<double>(on) / std::max<Eigen::Index>(1, lines.points.rows());
}

// Graph z = cos(|xy|) over a disc of radius R, triangulated by an equilateral lattice of spacing h:
// the thesis's waving surface r(u, v) = (u cos v, u sin v, cos u).
TriMesh waving_disc(double R, double h, bool square = false) {
  const int n = static_cast<int>(std::ceil(R / h)) + 2;
  const double dy = square ? h : h * std::sqrt(3.0) / 2;
  std::map<std::pair<int, int>, int> id;
  std::vector<Vec3> verts;
  auto pos = [&](int i, int j) { return Vec3(i * h + ((j & 1) && !square ? 0.5 * h : 0.0), j * dy, 0.0); };
  auto vid = [&](int i, int j) {
    auto it = id.find({i, j});
    if (it != id.end()) return it->second;
    Vec3 p = pos(i, j);
    p.z() = std::cos(std::hypot(p.x(), p.y()));
    verts.push_back(p);
    return id[{i, j}] = static_cast<int>(verts.size()) - 1;
  };
  auto inside = [&](int i, int j) { return pos(i, j).head<2>().norm() <= R; };
  std::vector<std::array<int, 3>> tris;
  for (int j = -n; j < n; ++j)
    for (int i = -n; i < n; ++i) {
      // Row j to row j+1; odd rows are shifted right by h/2 (square: the diagonals alternate instead).
      const bool odd = square ? (i + j) & 1 : j & 1;
      std::array<std::pair<int, int>, 3> t1, t2;
      if (!odd) {
        t1 = {{{i, j}, {i + 1, j}, {i, j + 1}}};
        t2 = {{{i + 1, j}, {i + 1, j + 1}, {i, j + 1}}};
      } else {
        t1 = {{{i, j}, {i + 1, j}, {i + 1, j + 1}}};
        t2 = {{{i, j}, {i + 1, j + 1}, {i, j + 1}}};
      }
      for (const auto& t : {t1, t2}) {
        bool ok = true;
        for (const auto& [a, b] : t) ok = ok && inside(a, b);
        if (ok)
          tris.push_back({vid(t[0].first, t[0].second), vid(t[1].first, t[1].second), vid(t[2].first, t[2].second)});
      }
    }
  TriMesh m;
  m.V.resize(verts.size(), 3);
  for (size_t i = 0; i < verts.size(); ++i) m.V.row(i) = verts[i].transpose();
  m.F.resize(tris.size(), 3);
  for (size_t i = 0; i < tris.size(); ++i) m.F.row(i) << tris[i][0], tris[i][1], tris[i][2];
  return m;
}

// Open cylinder of radius r and height h, nu around and nv along.
TriMesh cylinder(double r, double h, int nu, int nv) {
  TriMesh m;
  m.V.resize(nu * (nv + 1), 3);
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double a = 2 * M_PI * i / nu;
      m.V.row(j * nu + i) << r * std::cos(a), r * std::sin(a), h * j / nv;
    }
  m.F.resize(2 * nu * nv, 3);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int a = j * nu + i, b = j * nu + (i + 1) % nu, c = a + nu, d = b + nu;
      m.F.row(2 * (j * nu + i)) << a, b, d;
      m.F.row(2 * (j * nu + i) + 1) << a, d, c;
    }
  return m;
}

}  // namespace crest_test

namespace {

using namespace crest_test;

double max_strength(const CrestLines& cl) {
  double t = 0;
  for (double s : cl.line_strength) t = std::max(t, s);
  return t;
}

// Separates the features of the test shapes (T >= 12) from fitting noise on spheres and Dupin
// cyclides (T <= 4.4 on a 5K-triangle icosphere).
constexpr double kThreshold = 8.0;

// Crest lines of `fit` with T >= kThreshold.
CrestLines strong_lines(const Mesh& m, const DerivativeOptions& fit = {}) {
  CrestOptions opt;
  opt.threshold = kThreshold;
  return crest_lines(m, fit, opt);
}

CrestOptions every_line() {
  CrestOptions o;
  o.threshold = 0.0;
  return o;
}

}  // namespace

TEST(CrestLines, SphereFitsExactCurvatureAndHasNoStrongLines) {
  const TriMesh s = icosphere(4, 2.0);
  const Mesh m = make_mesh(s.V, s.F);
  for (int rings = 1; rings <= 3; ++rings) {
    DerivativeOptions fit;
    fit.rings = rings;
    const CurvatureDerivatives d = curvature_derivatives(m, fit);
    // p -> p' shrinks the sphere slightly and unevenly; curvature stays within 10% of 1/r.
    EXPECT_LT((d.k_max.array() - 0.5).abs().maxCoeff(), 0.05) << rings;
    EXPECT_LT((d.k_min.array() - 0.5).abs().maxCoeff(), 0.05) << rings;
    EXPECT_LT(d.e_max.cwiseAbs().maxCoeff(), 0.1) << rings;
    // Without the smoothing the vertices are on the sphere and the fit is nearly exact.
    fit.smooth = false;
    const CurvatureDerivatives d0 = curvature_derivatives(m, fit);
    EXPECT_LT((d0.k_max.array() - 0.5).abs().maxCoeff(), 0.015) << rings;
    EXPECT_LT(d0.e_max.cwiseAbs().maxCoeff(), 0.005) << rings;
    const CrestLines cl = trace_crest_lines(m, d, every_line());
    EXPECT_LT(max_strength(cl), kThreshold) << rings;
  }
}

TEST(CrestLines, PlaneHasNoLines) {
  const TriMesh g = grid(30, 30);
  const Mesh m = make_mesh(g.V, g.F);
  const CurvatureDerivatives d = curvature_derivatives(m, DerivativeOptions{});
  EXPECT_LT(d.k_max.cwiseAbs().maxCoeff(), 1e-9);
  CrestOptions opt;
  opt.threshold = kThreshold;
  EXPECT_EQ(trace_crest_lines(m, d, opt).n_lines(), 0);
}

TEST(CrestLines, CylinderAndTorusHaveNoStrongLines) {
  for (const TriMesh& t : {cylinder(1.0, 3.0, 64, 40), torus(2.0, 0.7, 96, 48)}) {
    const Mesh m = make_mesh(t.V, t.F);
    const CrestLines cl = crest_lines(m, DerivativeOptions{}, every_line());
    EXPECT_LT(max_strength(cl), kThreshold);
  }
}

TEST(CrestLines, RoundedCubeHasRidgesAlongAllTwelveEdges) {
  const TriMesh rc = rounded_cube(40, 0.25);
  const Mesh m = make_mesh(rc.V, rc.F);
  const CrestLines cl = strong_lines(m);
  ASSERT_GT(cl.n_lines(), 0);
  for (int k : cl.line_kind) EXPECT_EQ(k, kRidge);
  // Every kept point lies on the middle of a rounded edge or in a corner region.
  const double mid = (1 - 0.25) + 0.25 / std::sqrt(2.0);  // |x| = |y| on the arc's middle
  // Coverage: for each of the 12 edges, how much of its straight part holds crest points.
  int covered_edges = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int sa = -1; sa <= 1; sa += 2)
      for (int sb = -1; sb <= 1; sb += 2) {
        std::vector<char> bins(20, 0);
        for (int i = 0; i < cl.points.rows(); ++i) {
          const Vec3 p = cl.points.row(i);
          const double a = p[(axis + 1) % 3] * sa, b = p[(axis + 2) % 3] * sb;
          if (std::abs(a - mid) < 0.05 && std::abs(b - mid) < 0.05 && std::abs(p[axis]) < 0.75) {
            bins[std::min(19, static_cast<int>((p[axis] + 0.75) / 1.5 * 20))] = 1;
          }
        }
        int filled = 0;
        for (char c : bins) filled += c;
        covered_edges += filled >= 18;
      }
  EXPECT_EQ(covered_edges, 12);
  for (int i = 0; i < cl.points.rows(); ++i) {
    const Vec3 p = cl.points.row(i).cwiseAbs();
    // At least two coordinates are in the rounded band (an edge or a corner), none on a flat side.
    int band = (p.array() > 0.75 - 0.05).count();
    EXPECT_GE(band, 2) << p.transpose();
  }
  // On a blend's middle line (or in a corner region), with the jet fit (the default) and with the thesis fit. The jet
  // resolves the blends' constant k_max, so there this rests on DerivativeOptions::plateaus: without it the jet traces
  // strong ridges beside the middle, where its polynomial overshoots the jump of k at the blend's rims.
  EXPECT_GT(blend_middle_share(cl, 0.25), 0.95);
  DerivativeOptions thesis, no_plateaus;
  thesis.jet = false;
  const CrestLines tl = strong_lines(m, thesis);
  EXPECT_GT(blend_middle_share(tl, 0.25), 0.95);
  EXPECT_GT(tl.n_lines(), 0);
  no_plateaus.plateaus = false;
  const CrestLines raw = strong_lines(m, no_plateaus);
  EXPECT_LT(blend_middle_share(raw, 0.25), 0.8);
}

TEST(CrestLines, CoarseBlendsKeepTheirLinesOnTheMiddleWithTheJetFit) {
  // A blend about five vertices wide: beside its middle the jet's |e| is 2.5-3.8 of its standard error, so no one-ring
  // on it was a plateau at three standard errors and the jet's lines ran beside the middles (T >= 8: 67% of the points
  // on a middle or in a corner); at five (kPlateauErrors) 100%, as the thesis fit.
  const TriMesh rc = rounded_cube(24, 0.3);
  const Mesh m = make_mesh(rc.V, rc.F);
  const CrestLines cl = strong_lines(m);
  ASSERT_GT(cl.n_lines(), 0);
  EXPECT_TRUE(crest_fields(m, DerivativeOptions{}).jet_used);
  EXPECT_GT(blend_middle_share(cl, 0.3), 0.95);
}

TEST(CrestLines, WavingSurfaceMatchesExactCircles) {
  // Exact crest lines of z = cos(rho): ridges on rho = 2 pi, valleys on rho = pi, 3 pi.
  const TriMesh w = waving_disc(3.5 * M_PI, 0.45);
  ASSERT_LT(w.F.rows(), 5000);
  const Mesh m = make_mesh(w.V, w.F);
  // The exact circles have C = 0, but C interpolated from the edge ends as in 4.6 is not: they are
  // strong (T > 80) while the spurious lines around the umbilic at the centre are weak.
  CrestOptions opt;
  opt.threshold = 20.0;
  const CrestLines cl = crest_lines(m, DerivativeOptions{}, opt);
  ASSERT_GT(cl.n_lines(), 0);
  const double h = 0.45;
  double len_near[4] = {0, 0, 0, 0};
  for (int s = 0; s < cl.segments.rows(); ++s) {
    const Vec3 a = cl.points.row(cl.segments(s, 0)), b = cl.points.row(cl.segments(s, 1));
    const Vec3 c = 0.5 * (a + b);
    const double rho = std::hypot(c.x(), c.y());
    const int ring = static_cast<int>(std::lround(rho / M_PI));
    ASSERT_GE(ring, 1) << "line at rho " << rho;
    ASSERT_LE(ring, 3);
    EXPECT_LT(std::abs(rho - ring * M_PI), 0.5 * h) << rho;
    const int kind = cl.line_kind[cl.segment_line[s]];
    EXPECT_EQ(kind, ring % 2 == 0 ? kRidge : kValley) << rho;
    len_near[ring] += (a - b).norm();
  }
  // The two interior circles are found whole (the third is close to the boundary).
  EXPECT_GT(len_near[1], 0.95 * 2 * M_PI * M_PI);
  EXPECT_GT(len_near[2], 0.95 * 2 * M_PI * 2 * M_PI);
}

TEST(CrestLines, ReversingOrientationSwapsRidgesAndValleys) {
  // Duality (thesis 4.1): flipping the normals turns ridges into valleys at the same places. The
  // waving surface's strong lines avoid its umbilic, where principal directions are arbitrary.
  const TriMesh w = waving_disc(3.5 * M_PI, 0.45);
  MatX3i Fr = w.F;
  Fr.col(1).swap(Fr.col(2));
  const Mesh a = make_mesh(w.V, w.F), b = make_mesh(w.V, Fr);
  CrestOptions opt;
  opt.threshold = 20.0;
  const CrestLines ca = crest_lines(a, DerivativeOptions{}, opt);
  const CrestLines cb = crest_lines(b, DerivativeOptions{}, opt);
  ASSERT_EQ(ca.n_lines(), 3);
  ASSERT_EQ(cb.n_lines(), 3);
  for (int l = 0; l < 3; ++l) {
    // Same lines (traced in the same order), kinds swapped, same strength.
    EXPECT_EQ(ca.line_kind[l], 1 - cb.line_kind[l]);
    EXPECT_NEAR(ca.line_strength[l], cb.line_strength[l], 1e-6 * ca.line_strength[l]);
    EXPECT_NEAR(ca.line_length[l], cb.line_length[l], 1e-9 * ca.line_length[l]);
  }
  // The same points (numbered differently: ridges are numbered before valleys).
  ASSERT_EQ(ca.points.rows(), cb.points.rows());
  double worst = 0;
  for (int i = 0; i < ca.points.rows(); ++i)
    worst = std::max(worst, (cb.points.rowwise() - ca.points.row(i)).rowwise().norm().minCoeff());
  EXPECT_LT(worst, 1e-9);
}

TEST(CrestLines, PrincipalFrameIsOrthonormal) {
  const TriMesh t = torus(2.0, 0.7, 48, 24);
  const Mesh m = make_mesh(t.V, t.F);
  const CurvatureDerivatives d = curvature_derivatives(m, DerivativeOptions{});
  for (int v = 0; v < m.V.rows(); ++v) {
    EXPECT_NEAR(d.t_max.row(v).norm(), 1.0, 1e-9);
    EXPECT_NEAR(d.t_max.row(v).dot(d.t_min.row(v)), 0.0, 1e-9);
    EXPECT_NEAR(d.t_max.row(v).dot(d.normals.row(v)), 0.0, 1e-9);
    EXPECT_GE(d.k_max[v], d.k_min[v]);
  }
  // Torus: k_max = 1/r on the tube circles (outward normals); p -> p' thins the tube a little.
  EXPECT_NEAR(d.k_max.maxCoeff(), 1 / 0.7, 0.08 / 0.7);
  EXPECT_GT(d.k_min.minCoeff(), -1.0 / (2.0 - 0.7) - 0.1);
}

TEST(CrestLines, FaceDistanceAndFeatureFunction) {
  const TriMesh rc = rounded_cube(16, 0.3);
  const Mesh m = make_mesh(rc.V, rc.F);
  CrestOptions opt;
  opt.threshold = kThreshold;
  const CrestLines cl = crest_lines(m, DerivativeOptions{}, opt);
  ASSERT_GT(cl.n_lines(), 0);
  const VecXd d = crest_face_distance(m, cl);
  EXPECT_EQ(d.minCoeff(), 0.0);
  // The farthest faces are the face centres, about 1 from the edge midlines.
  EXPECT_GT(d.maxCoeff(), 0.8);
  EXPECT_LT(d.maxCoeff(), 1.4);
  const VecXd F = feature_function(d, 2.0);
  EXPECT_NEAR(F.minCoeff(), 0.01, 1e-12);
  EXPECT_NEAR(F.maxCoeff(), 1.21, 1e-12);
  EXPECT_TRUE((feature_function(d, 0.0).array() == 1.0).all());
}

TEST(CrestLines, FilterKeepsStrongLinesOnly) {
  const TriMesh rc = rounded_cube(20, 0.3);
  const Mesh m = make_mesh(rc.V, rc.F);
  const CrestLines all = crest_lines(m, DerivativeOptions{}, every_line());
  const CrestLines kept = filter_crest_lines(all, kThreshold);
  int expect = 0;
  for (double t : all.line_strength) expect += t >= kThreshold;
  EXPECT_EQ(kept.n_lines(), expect);
  EXPECT_EQ(static_cast<int>(kept.line_offset.size()), expect + 1);
  for (int s = 0; s < kept.segments.rows(); ++s) {
    EXPECT_LT(kept.segments(s, 0), kept.points.rows());
    EXPECT_GE(kept.line_strength[kept.segment_line[s]], kThreshold);
  }
  EXPECT_EQ(filter_crest_lines(all, 0.0, false, false).n_lines(), 0);
}

TEST(CrestLines, RejectsBadRings) {
  const TriMesh s = icosphere(1);
  const Mesh m = make_mesh(s.V, s.F);
  DerivativeOptions fit;
  fit.rings = 0;
  EXPECT_THROW(curvature_derivatives(m, fit), MeshError);
  fit.rings = 9;
  EXPECT_THROW(curvature_derivatives(m, fit), MeshError);
}

namespace {

// L2 and Linf errors of e_max, e_min against the exact values on the waving surface z = cos(rho)
// (thesis table 4.1), over the vertices outside the boundary's one-ring: {L2 max, Linf max, L2 min,
// Linf min}. Along the meridian e = -s (1 + s^2 + 3 c^2) / (1 + s^2)^3 (s, c = sin, cos rho) in the
// outward direction, along the parallels e = 0.
std::array<double, 4> waving_errors(const Mesh& m, const CurvatureDerivatives& d) {
  std::vector<char> skip(m.topo.on_boundary.begin(), m.topo.on_boundary.end());
  for (int e = 0; e < m.topo.n_edges(); ++e) {
    const int a = m.topo.edges(e, 0), b = m.topo.edges(e, 1);
    if (m.topo.on_boundary[a] || m.topo.on_boundary[b]) skip[a] = skip[b] = 1;
  }
  std::array<double, 4> out{0, 0, 0, 0};
  int n = 0;
  for (int v = 0; v < m.V.rows(); ++v) {
    if (skip[v]) continue;
    const Vec3 p = m.V.row(v);
    const double rho = std::hypot(p.x(), p.y());
    if (rho < 1e-9) continue;  // the umbilic at the centre: directions undefined
    const double s = std::sin(rho), c = std::cos(rho);
    const double km = c / std::pow(1 + s * s, 1.5), kp = s / (rho * std::sqrt(1 + s * s));
    const double em = -s * ((1 + s * s) + 3 * c * c) / std::pow(1 + s * s, 3);
    const Vec3 ur = Vec3(p.x() / rho, p.y() / rho, -s).normalized();
    for (int k = 0; k < 2; ++k) {
      const double e = k == 0 ? d.e_max[v] : d.e_min[v];
      const Vec3 t = k == 0 ? Vec3(d.t_max.row(v)) : Vec3(d.t_min.row(v));
      const bool meridian = k == 0 ? km >= kp : km < kp;
      const double err = meridian ? std::abs((t.dot(ur) < 0 ? -e : e) - em) : std::abs(e);
      out[2 * k] += err * err;
      out[2 * k + 1] = std::max(out[2 * k + 1], err);
    }
    ++n;
  }
  out[0] = std::sqrt(out[0] / n);
  out[2] = std::sqrt(out[2] / n);
  return out;
}

// V with Gaussian noise of standard deviation sigma on every coordinate (fixed seed).
MatX3d with_noise(MatX3d V, double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  for (int i = 0; i < V.rows(); ++i)
    for (int c = 0; c < 3; ++c) V(i, c) += noise(rng);
  return V;
}

// The waving disc with every vertex moved sideways by up to `jitter` h (fixed seed), back on z = cos rho.
TriMesh jittered(TriMesh w, double h, double jitter) {
  unsigned state = 12345u;
  auto uniform = [&] {  // LCG: deterministic on every platform
    state = state * 1664525u + 1013904223u;
    return (state >> 8) / 16777216.0 * 2.0 - 1.0;
  };
  for (int v = 0; v < w.V.rows(); ++v) {
    const double dx = uniform() * jitter * h, dy = uniform() * jitter * h;
    w.V(v, 0) += dx;
    w.V(v, 1) += dy;
    w.V(v, 2) = std::cos(std::hypot(w.V(v, 0), w.V(v, 1)));
  }
  return w;
}

}  // namespace

TEST(CrestLines, WavingSurfaceDerivativesBeatTheThesisTable) {
  // Thesis table 4.1, one-ring fit with p -> p' and normals: L2 0.145 (e_max), 0.126 (e_min).
  const double h = 0.42;
  const TriMesh regular = waving_disc(3.5 * M_PI, h);
  const TriMesh irregular = jittered(regular, h, 0.2);
  ASSERT_LT(regular.F.rows(), 5000);
  for (const TriMesh* w : {&regular, &irregular}) {
    const Mesh m = make_mesh(w->V, w->F);
    DerivativeOptions enhanced, thesis;
    enhanced.jet = thesis.jet = false;
    thesis.fit_tangent_plane = false;
    thesis.transport_to_vertex = false;
    const auto ours = waving_errors(m, curvature_derivatives(m, enhanced));
    const auto printed = waving_errors(m, curvature_derivatives(m, thesis));
    std::printf("%s: e_max L2 %.4f Linf %.4f, e_min L2 %.4f Linf %.4f (eq. 4.7 as printed: %.4f %.4f %.4f %.4f)\n",
                w == &regular ? "regular" : "jittered", ours[0], ours[1], ours[2], ours[3], printed[0], printed[1],
                printed[2], printed[3]);
    EXPECT_LT(ours[0], 0.145);
    EXPECT_LT(ours[2], 0.126);
    // Fitting the tangent plane and evaluating at the original vertex lower both L2 errors.
    EXPECT_LT(ours[0], 0.95 * printed[0]);
    EXPECT_LT(ours[2], 0.95 * printed[2]);
  }
}

TEST(CrestLines, JetFitIsMoreAccurateAndImprovesWithTwoRings) {
  // Issue #31: the two-pass jet fit (the default) against the thesis fit on the waving surface, and its
  // 2-ring fit not less accurate than its 1-ring fit there (the thesis fit's 2-ring is worse).
  const double h = 0.30;
  const TriMesh w = waving_disc(2.5 * M_PI, h);
  const Mesh m = make_mesh(w.V, w.F);
  DerivativeOptions jet1, jet2, old1, old2;
  jet1.jet = jet2.jet = true;
  old1.jet = old2.jet = false;
  jet2.rings = old2.rings = 2;
  const auto old = waving_errors(m, curvature_derivatives(m, old1));
  const auto one = waving_errors(m, curvature_derivatives(m, jet1));
  const auto two = waving_errors(m, curvature_derivatives(m, jet2));
  const auto old_two = waving_errors(m, curvature_derivatives(m, old2));
  std::printf("L2 e_max / e_min: thesis %.4f %.4f (2-ring %.4f %.4f), jet 1-ring %.4f %.4f, 2-ring %.4f %.4f\n", old[0],
              old[2], old_two[0], old_two[2], one[0], one[2], two[0], two[2]);
  EXPECT_LT(one[0], 0.5 * old[0]);
  EXPECT_LT(one[2], 0.5 * old[2]);
  EXPECT_LE(two[0], one[0]);
  EXPECT_LE(two[2], one[2]);
}

TEST(CrestLines, JetNoiseTestFallsBackToTheThesisFitUnderNoise) {
  // DerivativeOptions::noise_adaptive: the jet fit on an exact mesh, the thesis fit (same fields as jet = false) under
  // Gaussian noise of 0.05 mean edge length, where it is the more accurate of the two.
  const double h = 0.30;
  const TriMesh w = waving_disc(2.5 * M_PI, h);
  const Mesh exact = make_mesh(w.V, w.F);
  DerivativeOptions jet, plain, thesis;
  jet.jet = plain.jet = true;
  plain.noise_adaptive = false;
  const CurvatureDerivatives clean = curvature_derivatives(exact, jet);
  EXPECT_TRUE(clean.jet_used);
  EXPECT_GT(clean.noise_ratio, 0.0);
  EXPECT_LT(clean.noise_ratio, kJetNoiseRatio);

  const Mesh noisy = make_mesh(with_noise(w.V, 0.05 * h, 5), w.F);
  const CurvatureDerivatives adaptive = curvature_derivatives(noisy, jet);
  EXPECT_FALSE(adaptive.jet_used);
  EXPECT_GT(adaptive.noise_ratio, kJetNoiseRatio);
  const CurvatureDerivatives reference = curvature_derivatives(noisy, thesis);
  EXPECT_TRUE(adaptive.e_max == reference.e_max);
  EXPECT_TRUE(adaptive.e_min == reference.e_min);
  const CurvatureDerivatives alone = curvature_derivatives(noisy, plain);
  EXPECT_TRUE(alone.jet_used);
  // Errors against the exact fields of the unperturbed surface (noise 0.05 h moves vertices by far less than the
  // scale of the fields).
  const auto a = waving_errors(exact, adaptive), b = waving_errors(exact, alone);
  EXPECT_LT(a[0], 0.6 * b[0]);
  EXPECT_LT(a[2], 0.6 * b[2]);
}

TEST(CrestLines, JetOneRingFitHoldsOnSquareAndJitteredLattices) {
  // Issue #31: the one-ring jet fit on the lattices where it lost to CGAL's 2-ring jet fitting (bench
  // crest_derivatives (5), (6)). Square grid with alternating diagonals: valence-4 vertices widen to the 2-ring (their
  // four neighbours do not determine the cubic's mixed terms). Jittered lattice: a quartic pass 1 (fourth-order terms
  // leak into the normals of a lopsided 2-ring). The fit without the two, in this measure: square 0.0556 / 0.0474,
  // jittered 0.0607 / 0.0726 (with them 0.0463 / 0.0407, 0.0450 / 0.0574).
  const TriMesh square = waving_disc(2.8 * M_PI, 0.34, true);
  const TriMesh jitter = jittered(waving_disc(3.5 * M_PI, 0.42), 0.42, 0.2);
  for (const TriMesh* w : {&square, &jitter}) {
    const Mesh m = make_mesh(w->V, w->F);
    DerivativeOptions jet, two;
    jet.jet = two.jet = true;
    two.rings = 2;
    const auto one = waving_errors(m, curvature_derivatives(m, jet));
    const auto wide = waving_errors(m, curvature_derivatives(m, two));
    std::printf("%s: jet 1-ring %.4f %.4f, 2-ring %.4f %.4f\n", w == &square ? "square" : "jittered", one[0], one[2],
                wide[0], wide[2]);
    EXPECT_LT(one[0], w == &square ? 0.051 : 0.053);
    EXPECT_LT(one[2], w == &square ? 0.044 : 0.065);
    EXPECT_LE(wide[0], one[0]);
    EXPECT_LE(wide[2], one[2]);
  }
}

TEST(CrestLines, JetStandardErrorsAreSmallOnExactAndLargeOnNoisyMeshes) {
  const double h = 0.30;
  const TriMesh w = waving_disc(2.5 * M_PI, h);
  const Mesh exact = make_mesh(w.V, w.F);
  DerivativeOptions plain;
  plain.jet = true;
  plain.noise_adaptive = false;
  const CurvatureDerivatives a = curvature_derivatives(exact, plain);
  ASSERT_EQ(a.e_max_error.size(), exact.V.rows());
  const CurvatureDerivatives b = curvature_derivatives(make_mesh(with_noise(w.V, 0.02 * h, 3), w.F), plain);
  auto median = [](VecXd x) {
    std::nth_element(x.data(), x.data() + x.size() / 2, x.data() + x.size());
    return x[x.size() / 2];
  };
  const double ea = median(a.e_max_error), eb = median(b.e_max_error);
  std::printf("median standard error of e_max: exact %.4g, noise 0.02 h %.4g\n", ea, eb);
  EXPECT_GT(ea, 0.0);
  EXPECT_LT(ea, 0.03);  // 0.018 measured; the jet's RMS error here is 0.007 (bench crest_derivatives (4))
  EXPECT_GT(eb, 5.0 * ea);
  EXPECT_EQ(a.plateau_vertices, 0);  // only crest_fields() sets it
  DerivativeOptions thesis;
  thesis.jet = false;
  EXPECT_EQ(curvature_derivatives(exact, thesis).e_max_error.size(), 0);  // the thesis fit has none
}
