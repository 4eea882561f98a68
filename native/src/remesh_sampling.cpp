// Sampling of a chart for the remesher; see remesh_sampling.h.
#include "dgmesh/remesh_sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/parallel.h"

namespace dgmesh::detail {

namespace {

constexpr int kBand = 16;                   // raster rows per band (one band per task, no write races)
constexpr double kPixelsPerSample = 256;    // at most this many chart pixels per interior sample
constexpr double kLloydPointsPerCell = 32;  // Lloyd quadrature points wanted per Voronoi cell
constexpr int kLloydMaxResolution = 1024;   // ... up to this grid size
constexpr double kLloydTolerance = 0.003;   // Lloyd steps end when the samples' RMS move is under this (spacings)

// The point (1 - t) a + t b of the boundary edge (a, b) (a == b: the vertex a), on the input face
// holding that edge; face -1 if there is none.
Sample on_edge(const MatX3i& F, const Topology& topo, int a, int b, double t) {
  for (int q = topo.vf_offset[a]; q < topo.vf_offset[a + 1]; ++q) {
    const int f = topo.vf_index[q];
    double w[3] = {0, 0, 0};
    int hits = 0;
    for (int k = 0; k < 3; ++k) {
      if (F(f, k) == a)
        w[k] += 1 - t, ++hits;
      else if (F(f, k) == b)
        w[k] += t, ++hits;
    }
    if (a == b ? hits == 1 : hits == 2) return Sample{f, w[0], w[1], w[2]};
  }
  return Sample{-1, 0, 0, 0};
}

// Rasterizes the sampling map at Rr x Rr: covering face, control-map value and (want_x) the
// surface point of each pixel centre (floats: 12 bytes a pixel, distances only need to rank
// Lloyd generators). ratio: per face, its 3D area over its sampling-map area (0 if degenerate).
void rasterize(const SamplingChart& ch, const VecXd& area3, int Rr, std::vector<int>& pf, std::vector<double>& pv,
               std::vector<float>& px, bool want_x, VecXd& ratio) {
  const MatX3d& V = ch.V;
  const MatX3i& F = ch.F;
  const MatX2d& Us = ch.Us;
  const VecXd& rho = ch.rho;
  const int nf = ch.topo.n_faces;
  const long np = long(Rr) * Rr;
  pf.assign(np, -1);
  pv.assign(np, 0.0);
  px.assign(want_x ? 3 * np : 0, 0.0f);
  const int nbands = (Rr + kBand - 1) / kBand;
  std::vector<int> band_off(nbands + 1, 0);
  std::vector<int> row0(nf), row1(nf);
  for (int f = 0; f < nf; ++f) {
    const Vec2 a = uv_row(Us, F(f, 0)), b = uv_row(Us, F(f, 1)), c = uv_row(Us, F(f, 2));
    const double uva = 0.5 * std::abs(cross2(b - a, c - a));
    ratio[f] = uva > 0 ? area3[f] / uva : 0.0;
    const double ymin = std::min({a.y(), b.y(), c.y()}), ymax = std::max({a.y(), b.y(), c.y()});
    row0[f] = std::max(0, int(std::ceil(ymin * Rr - 0.5 - 1e-9)));
    row1[f] = std::min(Rr - 1, int(std::floor(ymax * Rr - 0.5 + 1e-9)));
    if (uva <= 0 || row0[f] > row1[f]) continue;
    for (int bnd = row0[f] / kBand; bnd <= row1[f] / kBand; ++bnd) ++band_off[bnd + 1];
  }
  for (int b = 0; b < nbands; ++b) band_off[b + 1] += band_off[b];
  std::vector<int> band_faces(band_off[nbands]);
  {
    std::vector<int> fill(band_off.begin(), band_off.end() - 1);
    for (int f = 0; f < nf; ++f) {
      if (ratio[f] <= 0 || row0[f] > row1[f]) continue;
      for (int bnd = row0[f] / kBand; bnd <= row1[f] / kBand; ++bnd) band_faces[fill[bnd]++] = f;
    }
  }
#pragma omp parallel for schedule(dynamic, 1) if (long(Rr) * Rr > kParallelMin * 4)
  for (int bnd = 0; bnd < nbands; ++bnd) {
    const int j_lo = bnd * kBand, j_hi = std::min(Rr - 1, j_lo + kBand - 1);
    for (int q = band_off[bnd]; q < band_off[bnd + 1]; ++q) {
      const int f = band_faces[q];
      const Vec2 a = uv_row(Us, F(f, 0)), b = uv_row(Us, F(f, 1)), c = uv_row(Us, F(f, 2));
      const double det = cross2(b - a, c - a);
      const double xmin = std::min({a.x(), b.x(), c.x()}), xmax = std::max({a.x(), b.x(), c.x()});
      const int i0 = std::max(0, int(std::ceil(xmin * Rr - 0.5 - 1e-9)));
      const int i1 = std::min(Rr - 1, int(std::floor(xmax * Rr - 0.5 + 1e-9)));
      const double tol = -1e-9;
      for (int j = std::max(j_lo, row0[f]); j <= std::min(j_hi, row1[f]); ++j) {
        const double y = (j + 0.5) / Rr;
        for (int i = i0; i <= i1; ++i) {
          const Vec2 p((i + 0.5) / Rr, y);
          const double w0 = cross2(b - p, c - p) / det, w1 = cross2(c - p, a - p) / det, w2 = 1 - w0 - w1;
          if (w0 < tol || w1 < tol || w2 < tol) continue;
          const long idx = long(j) * Rr + i;
          pf[idx] = f;
          pv[idx] = ratio[f] * (w0 * rho[F(f, 0)] + w1 * rho[F(f, 1)] + w2 * rho[F(f, 2)]);
          if (want_x) {
            const Vec3 x = w0 * row3(V, F(f, 0)) + w1 * row3(V, F(f, 1)) + w2 * row3(V, F(f, 2));
            for (int c = 0; c < 3; ++c) px[3 * idx + c] = float(x[c]);
          }
        }
      }
    }
  }
}

}  // namespace

BoundarySamples sample_boundary(const MatX3d& V, const MatX3i& F, const Topology& topo, const MatX2d& Us,
                                const MatX2d& Ut, const VecXd& rho, double rho_integral, const RemeshOptions& o,
                                RemeshResult& res) {
  const std::vector<int>& loop = topo.boundary_loops[0];
  const int nbl = int(loop.size());
  const int N = o.target_vertices;
  BoundarySamples out;
  std::vector<Vec3>& bnd_x = out.x;
  std::vector<Vec2>& bnd_u = out.u;
  std::vector<Vec2>& bnd_s = out.s;        // the same boundary samples in the sampling map (Lloyd generators)
  std::vector<Sample>& bnd_src = out.src;  // the same on the input: face and barycentric weights
  if (o.boundary == RemeshBoundary::Keep) {
    res.boundary_source.resize(nbl);
    for (int k = 0; k < nbl; ++k) {
      bnd_x.push_back(row3(V, loop[k]));
      bnd_u.push_back(uv_row(Ut, loop[k]));
      bnd_s.push_back(uv_row(Us, loop[k]));
      bnd_src.push_back(on_edge(F, topo, loop[k], loop[k], 0.0));
      res.boundary_source[k] = loop[k];
    }
  } else {
    // Spacing follows the density with all N vertices: count measure = int ds / h(s).
    std::vector<double> cum(nbl + 1, 0.0);
    for (int k = 0; k < nbl; ++k) {
      const int a = loop[k], b = loop[(k + 1) % nbl];
      const double len = (row3(V, b) - row3(V, a)).norm();
      const double ha = spacing(N * rho[a] / rho_integral), hb = spacing(N * rho[b] / rho_integral);
      cum[k + 1] = cum[k] + len * 0.5 * (1 / ha + 1 / hb);
    }
    // Anchors that must be samples: the square's corners (else the polygon would cut them off).
    std::vector<int> anchors;
    if (o.domain == UvBoundary::Square)
      for (int k = 0; k < nbl; ++k) {
        const Vec2 u = uv_row(Ut, loop[k]);
        const bool cx = std::abs(u.x()) < 1e-9 || std::abs(u.x() - 1) < 1e-9;
        const bool cy = std::abs(u.y()) < 1e-9 || std::abs(u.y() - 1) < 1e-9;
        if (cx && cy) anchors.push_back(k);
      }
    if (anchors.empty()) anchors.push_back(0);
    const double total = cum[nbl];
    auto place = [&](double c) {
      c = std::fmod(c, total);
      if (c < 0) c += total;
      int k = int(std::upper_bound(cum.begin(), cum.end(), c) - cum.begin()) - 1;
      k = std::clamp(k, 0, nbl - 1);
      const double t = cum[k + 1] > cum[k] ? std::clamp((c - cum[k]) / (cum[k + 1] - cum[k]), 0.0, 1.0) : 0.0;
      const int a = loop[k], b = loop[(k + 1) % nbl];
      bnd_x.push_back((1 - t) * row3(V, a) + t * row3(V, b));
      bnd_u.push_back((1 - t) * uv_row(Ut, a) + t * uv_row(Ut, b));
      bnd_s.push_back((1 - t) * uv_row(Us, a) + t * uv_row(Us, b));
      bnd_src.push_back(on_edge(F, topo, a, b, t));
    };
    const int na = int(anchors.size());
    const int min_per_piece = na == 1 ? 3 : 1;
    for (int m = 0; m < na; ++m) {
      const double c0 = cum[anchors[m]];
      const double c1 = m + 1 < na ? cum[anchors[m + 1]] : total + cum[anchors[0]];
      const int n_piece = std::max(min_per_piece, int(std::lround(c1 - c0)));
      for (int q = 0; q < n_piece; ++q) {
        if (q == 0) {  // the anchor itself, exactly
          bnd_x.push_back(row3(V, loop[anchors[m]]));
          bnd_u.push_back(uv_row(Ut, loop[anchors[m]]));
          bnd_src.push_back(on_edge(F, topo, loop[anchors[m]], loop[anchors[m]], 0.0));
          bnd_s.push_back(uv_row(Us, loop[anchors[m]]));
        } else {
          place(c0 + (c1 - c0) * q / n_piece);
        }
      }
    }
  }
  return out;
}

ChartPieces chart_pieces(const Topology& topo, const std::vector<Vec2>& bnd_u, const RemeshOptions& o) {
  const std::vector<int>& loop = topo.boundary_loops[0];
  const int nf = topo.n_faces, nb = int(bnd_u.size());
  // Ears of the kept boundary: a boundary vertex with a single input face, (prev, tip, next) (a
  // grid's corner; a region cut out of a finer mesh has many). The unwrap takes the tip off the
  // convex domain and lays the ear out in its 3D shape beyond the chord (prev, next), so in the
  // triangulation map the chart is a convex core (the other boundary vertices, on the domain's
  // boundary) with one triangle glued onto each chord. One Delaunay triangulation of all the points
  // need not have the ears' sides: a needle ear leaning along the boundary holds the tip of the ear
  // on the other side of its base vertex in its circumcircle (the left half of a subdivided
  // lion-head has 20 such ears out of 85), and ears that lean far even overlap each other in the map,
  // where no planar triangulation has the boundary's edges. So the core and each ear are
  // triangulated on their own (step 5) and joined along the chords. Every interior sample goes with
  // its input face: an ear's face to the ear, any other face to the core. (Two ears are never loop
  // neighbours; with fewer than 3 core vertices there are no ears.)
  std::vector<Ear> ears;
  std::vector<int> ear_of_face(nf, -1);
  std::vector<char> is_tip(nb, 0);
  if (o.boundary == RemeshBoundary::Keep && nb > 3) {
    for (int k = 0; k < nb; ++k) {
      const int v = loop[k];
      if (topo.vf_offset[v + 1] - topo.vf_offset[v] != 1) continue;
      if (is_tip[(k + nb - 1) % nb] || (k + 1 == nb && is_tip[0])) continue;
      is_tip[k] = 1;
      ears.push_back({k, (k + nb - 1) % nb, (k + 1) % nb, topo.vf_index[topo.vf_offset[v]]});
    }
    if (nb - int(ears.size()) < 3) {
      ears.clear();
      std::fill(is_tip.begin(), is_tip.end(), 0);
    }
    for (int e = 0; e < int(ears.size()); ++e) ear_of_face[ears[e].face] = e;
  }
  std::vector<int> core;  // boundary samples of the core, in loop order
  for (int k = 0; k < nb; ++k)
    if (!is_tip[k]) core.push_back(k);
  // The core polygon, counter-clockwise, for the inside test.
  std::vector<Vec2> poly;
  for (int k : core) poly.push_back(bnd_u[k]);
  {
    double a2 = 0;
    for (size_t k = 0; k < poly.size(); ++k) a2 += cross2(poly[k], poly[(k + 1) % poly.size()]);
    if (a2 < 0) std::reverse(poly.begin(), poly.end());
  }
  return ChartPieces{std::move(ears), std::move(ear_of_face), std::move(core), ConvexPolygon(std::move(poly)), &bnd_u};
}

bool ChartPieces::inside(int f, const Vec2& u, double margin) const {
  const int e = ear_of_face[f];
  if (e < 0) return polygon.inside(u, margin);
  Vec2 c[3] = {(*bnd_u)[ears[e].prev], (*bnd_u)[ears[e].tip], (*bnd_u)[ears[e].next]};
  const double s = cross2(c[1] - c[0], c[2] - c[0]);
  if (s == 0) return false;
  if (s < 0) std::swap(c[1], c[2]);
  for (int k = 0; k < 3; ++k) {
    const Vec2 d = c[(k + 1) % 3] - c[k];
    if (!(cross2(d, u - c[k]) > margin * d.norm())) return false;
  }
  return true;
}

ControlRaster control_raster(const SamplingChart& c, const VecXd& area3, const RemeshOptions& o, RemeshResult& res) {
  const MatX3i& F = c.F;
  const MatX2d& Us = c.Us;
  const int nf = c.topo.n_faces, n_int = c.n_int;
  ControlRaster r;
  // 3. Rasterize the control map over the sampling map: pixel value = (3D area / UV area) of the
  // covering face times the interpolated density, i.e. the density per unit of UV area [AMD02].
  // Error diffusion needs some samples per hundred pixels: with fewer, a row's carried error only
  // fires where the row leaves the chart, the samples line the chart's border and the boundary
  // clearance drops them all (a 150-vertex target on a grid at 512^2 kept no interior sample). So
  // the raster is made coarser until there are at most kPixelsPerSample chart pixels per interior
  // sample; larger targets keep the resolution asked for.
  double chart_uv_area = 0;
  for (int f = 0; f < nf; ++f)
    chart_uv_area +=
        0.5 * std::abs(cross2(uv_row(Us, F(f, 1)) - uv_row(Us, F(f, 0)), uv_row(Us, F(f, 2)) - uv_row(Us, F(f, 0))));
  const double r_fit = std::ceil(std::sqrt(kPixelsPerSample * n_int / std::max(chart_uv_area, 1e-12)));
  const int R = std::max(16, int(std::min(r_fit, double(o.resolution))));
  res.resolution = R;
  r.R = R;
  const long npix = long(R) * R;
  // At most one sample per pixel: a target beyond the chart's pixels cannot be met, and error
  // diffusion at several samples a pixel fell apart (5M asked at 512^2 gave 94 vertices).
  const double chart_pixels = chart_uv_area * double(npix);
  if (n_int > chart_pixels) {
    const int needed = int(std::ceil(std::sqrt(n_int / std::max(chart_uv_area, 1e-12))));
    throw MeshError("remesh: " + std::to_string(n_int) + " interior vertices do not fit the chart's " +
                    std::to_string(long(chart_pixels)) + " pixels at resolution " + std::to_string(R) +
                    " (at most one per pixel): raise the resolution to at least " + std::to_string(needed) +
                    " or lower the target");
  }
  if (n_int > npix / 4)
    res.warnings.push_back("resolution " + std::to_string(R) + " is low for " + std::to_string(n_int) +
                           " interior samples (at most one per pixel): raise the resolution");
  const bool relax = o.lloyd_iterations > 0;
  const bool relax_surface = relax && o.relax_metric == RemeshRelaxMetric::Surface;
  VecXd ratio(nf);
  std::vector<int>& pix_face = r.pix_face;
  std::vector<double>& pix_val = r.pix_val;
  std::vector<float>& pix_x = r.pix_x;
  // The Lloyd step's quadrature grid, apart from the diffusion raster: a Voronoi cell of the
  // relaxation should hold some kLloydPointsPerCell grid points, else its pixel-quantized boundary
  // stalls the relaxation (at 256^2 and 5000 samples a cell holds ~10 pixels, and after ~6 steps no
  // pixel changes its cell: the samples stop short of a centroidal tessellation, and more so on the
  // map whose pixels are the more anisotropic on the surface). So the sampling map is rasterized
  // once more at an integer multiple of R, capped at kLloydMaxResolution (the cost bound: 1024^2
  // holds the 100K-vertex target at its own pixels).
  int RL = R;
  if (relax) {
    int ss = int(std::ceil(std::sqrt(kLloydPointsPerCell * n_int / std::max(chart_pixels, 1.0))));
    ss = std::max(1, std::min(ss, kLloydMaxResolution / R));
    RL = R * ss;
  }
  r.RL = RL;
  rasterize(c, area3, R, pix_face, pix_val, pix_x, relax_surface && RL == R, ratio);
  if (RL != R) rasterize(c, area3, RL, r.lpix_face_own, r.lpix_val_own, r.lpix_x_own, relax_surface, ratio);
  double pix_sum = 0;
  for (long i = 0; i < npix; ++i) pix_sum += pix_val[i];
  if (!(pix_sum > 0)) throw MeshError("remesh: the chart covers no pixel of the control map; raise the resolution");
  r.pix_sum = pix_sum;
  return r;
}

namespace {

// The point of the sampling map (map_point) or of the surface (surface_point) at input location q.
Vec2 map_point(const MatX2d& Us, const MatX3i& F, const Sample& q) {
  return Vec2(q.w0 * uv_row(Us, F(q.face, 0)) + q.w1 * uv_row(Us, F(q.face, 1)) + q.w2 * uv_row(Us, F(q.face, 2)));
}

Vec3 surface_point(const MatX3d& V, const MatX3i& F, const Sample& q) {
  return Vec3(q.w0 * row3(V, F(q.face, 0)) + q.w1 * row3(V, F(q.face, 1)) + q.w2 * row3(V, F(q.face, 2)));
}

// 4b. Density-weighted Lloyd relaxation of the interior samples (Lloyd 1982; the centroidal
// Voronoi sampling of a parameter map in Alliez, de Verdiere, Devillers, Isenburg 2003,
// "Isotropic surface remeshing"; beyond the thesis's list of steps). Error diffusion quantizes samples to pixel centres
// and puts neighbours anywhere from 1 to several pixels apart; each Lloyd step moves every interior sample to the mass
// centroid (mass = control map value, i.e. density times 3D area) of its Voronoi cell over the points of the Lloyd grid
// (the sampling map rasterized at RL, a multiple of the control map's resolution). The cells are measured in the
// surface metric (nearest generator in 3D; the centroid is then taken in 3D and pulled onto the surface) or in the
// sampling map's own metric; boundary samples are fixed generators. The same step for all three modes. Error diffusion
// leaves a pattern that is isotropic in the sampling map, so stretched on the surface as the map is, and Lloyd steps
// undo that only slowly (a stretched lattice is itself a fixed point): with 4 steps sampling on U0 stayed more uniform
// than on Uopt where U0 is the less anisotropic map (nefertiti: 1.24 vs 1.33); steps until the samples settle make the
// map's signature small against the tie margins.
// The interior samples with keep set move (samples); sets res.lloyd_iterations, adds to
// res.seconds_relax. Relaxing requires o.lloyd_iterations > 0.
void lloyd_relax(const SamplingChart& c, const ControlRaster& raster, const RemeshOptions& o, Progress& report,
                 std::vector<Sample>& samples, const std::vector<char>& keep, RemeshResult& res) {
  const MatX3d& V = c.V;
  const MatX3i& F = c.F;
  const Topology& topo = c.topo;
  const MatX2d& Us = c.Us;
  const MatX2d& Ut = c.Ut;
  const VecXd& rho = c.rho;
  const double rho_integral = c.rho_integral;
  const int n_int = c.n_int, nb = int(c.bnd.x.size());
  const std::vector<Vec3>& bnd_x = c.bnd.x;
  const std::vector<Vec2>& bnd_s = c.bnd.s;
  const ChartPieces& pieces = c.pieces;
  const int R = raster.R, RL = raster.RL;
  const std::vector<int>& lpix_face = RL != R ? raster.lpix_face_own : raster.pix_face;
  const std::vector<double>& lpix_val = RL != R ? raster.lpix_val_own : raster.pix_val;
  const std::vector<float>& lpix_x = RL != R ? raster.lpix_x_own : raster.pix_x;
  const long nlpix = long(RL) * RL;
  const bool relax_surface = o.relax_metric == RemeshRelaxMetric::Surface;
  const double margin = 1e-9;
  const auto t_relax = Clock::now();
  std::vector<int> ids;  // interior samples taking part
  for (size_t q = 0; q < samples.size(); ++q)
    if (keep[q]) ids.push_back(int(q));
  const int ni = int(ids.size());
  const int ng = nb + ni;
  MatX3d G(ng, 3);  // generator coordinates for the nearest-neighbour search
  auto set_gen = [&](int g, const Vec2& su, const Vec3& x) {
    if (relax_surface)
      G.row(g) = x.transpose();
    else
      G.row(g) << su.x(), su.y(), 0.0;
  };
  for (int k = 0; k < nb; ++k) set_gen(k, bnd_s[k], bnd_x[k]);
  const int nthreads = nlpix > kParallelMin * 4 ? std::max(1, num_threads()) : 1;
  constexpr int kAcc = 9;  // per generator: mass, mass x (map position, 3D position, face normal)
  const MatX3d Nf = relax_surface ? face_normals(V, F) : MatX3d();
  std::vector<double> acc(size_t(kAcc) * ng);
  auto locate = [&](const Vec2& p, int f, Sample& out) { return locate_in_map(Us, F, topo, p, f, out); };
  // Nearest generator of every pixel: a kd-tree the first time; afterwards a greedy walk from the
  // pixel's previous generator over the Voronoi-neighbour graph read off the previous labels
  // (pixels side by side with different labels). Greedy descent on the Delaunay graph finds the
  // nearest site (this graph is its pixel approximation), and samples move less than a cell per step, so the walk is a
  // few distance evaluations instead of a tree search (the relaxation's cost at 1024^2 pixels).
  std::vector<int> label(nlpix, -1);
  std::vector<double> move2(ni);
  constexpr int kMaxNbr = 24;  // Voronoi neighbours kept per generator (a cell has ~6)
  std::vector<int> nbr(size_t(ng) * kMaxNbr), nbr_n(ng);
  auto pix_point = [&](long idx) {
    if (relax_surface) return Vec3(lpix_x[3 * idx], lpix_x[3 * idx + 1], lpix_x[3 * idx + 2]);
    return Vec3((idx % RL + 0.5) / RL, (idx / RL + 0.5) / RL, 0.0);
  };
  // Row bands list their neighbour pairs apart (the build was the step's largest serial part at
  // 1024^2), then each generator's lists are merged and sorted: the walk's visiting order, and so
  // the labels, must not depend on the number of bands.
  const int nadj = std::clamp(nthreads, 1, 4);
  std::vector<int> band_nbr(size_t(nadj) * ng * kMaxNbr), band_n(size_t(nadj) * ng);
  auto build_adjacency = [&]() {
    std::fill(band_n.begin(), band_n.end(), 0);
#pragma omp parallel for schedule(static, 1) num_threads(nadj) if (nadj > 1)
    for (int t = 0; t < nadj; ++t) {
      int* tl = band_nbr.data() + size_t(t) * ng * kMaxNbr;
      int* tn = band_n.data() + size_t(t) * ng;
      auto add1 = [&](int a, int b) {
        int* l = tl + size_t(a) * kMaxNbr;
        for (int k = 0; k < tn[a]; ++k)
          if (l[k] == b) return;
        if (tn[a] < kMaxNbr) l[tn[a]++] = b;
      };
      auto add = [&](int a, int b) {
        if (a == b || a < 0 || b < 0) return;
        add1(a, b);
        add1(b, a);
      };
      for (int j = RL * t / nadj; j < RL * (t + 1) / nadj; ++j)
        for (int i = 0; i < RL; ++i) {
          const long idx = long(j) * RL + i;
          const int l = label[idx];
          if (l < 0) continue;
          if (i + 1 < RL) add(l, label[idx + 1]);
          if (j + 1 < RL) add(l, label[idx + RL]);
          if (i + 1 < RL && j + 1 < RL) add(l, label[idx + RL + 1]);
          if (i > 0 && j + 1 < RL) add(l, label[idx + RL - 1]);
        }
    }
#pragma omp parallel for schedule(static) if (ng > kParallelMin)
    for (int g = 0; g < ng; ++g) {
      int* l = nbr.data() + size_t(g) * kMaxNbr;
      int n = 0;
      for (int t = 0; t < nadj; ++t) {
        const int* tl = band_nbr.data() + (size_t(t) * ng + g) * kMaxNbr;
        for (int k = 0, m = band_n[size_t(t) * ng + g]; k < m; ++k)
          if (n < kMaxNbr && std::find(l, l + n, tl[k]) == l + n) l[n++] = tl[k];
      }
      std::sort(l, l + n);
      nbr_n[g] = n;
    }
  };
  for (int it = 0; it < o.lloyd_iterations; ++it) {
    for (int q = 0; q < ni; ++q) {
      const Sample& sm = samples[ids[q]];
      set_gen(nb + q, map_point(Us, F, sm), surface_point(V, F, sm));
    }
    std::unique_ptr<KdTree> tree;
    if (it == 0)
      tree = std::make_unique<KdTree>(G);
    else
      build_adjacency();
      // Labels in parallel; the mass sums then in raster order, so that the centroids do not
      // depend on the thread count or schedule (bit-identical results run to run).
#pragma omp parallel for schedule(dynamic, 4) num_threads(nthreads) if (nthreads > 1)
    for (int j = 0; j < RL; ++j) {
      for (int i = 0; i < RL; ++i) {
        const long idx = long(j) * RL + i;
        if (lpix_face[idx] < 0) continue;
        const Vec3 qp = pix_point(idx);
        int g;
        if (tree) {
          g = tree->nearest(qp);
        } else {
          g = label[idx];
          double best = (row3(G, g) - qp).squaredNorm();
          for (bool improved = true; improved;) {
            improved = false;
            const int* l = nbr.data() + size_t(g) * kMaxNbr;
            const int n = nbr_n[g];
            for (int k = 0; k < n; ++k) {
              const double d = (row3(G, l[k]) - qp).squaredNorm();
              if (d < best) {
                best = d;
                g = l[k];
                improved = true;
                break;  // walk on from the closer generator
              }
            }
          }
        }
        label[idx] = g;
      }
    }
    std::fill(acc.begin(), acc.end(), 0.0);
    for (int j = 0; j < RL; ++j) {
      const double y = (j + 0.5) / RL;
      for (int i = 0; i < RL; ++i) {
        const long idx = long(j) * RL + i;
        if (lpix_face[idx] < 0) continue;
        const double x = (i + 0.5) / RL;
        const double m = lpix_val[idx];
        double* ag = acc.data() + kAcc * label[idx];
        ag[0] += m;
        ag[1] += m * x;
        ag[2] += m * y;
        if (relax_surface) {
          ag[3] += m * lpix_x[3 * idx];
          ag[4] += m * lpix_x[3 * idx + 1];
          ag[5] += m * lpix_x[3 * idx + 2];
          const int f = lpix_face[idx];
          ag[6] += m * Nf(f, 0);
          ag[7] += m * Nf(f, 1);
          ag[8] += m * Nf(f, 2);
        }
      }
    }
    // Each sample moves to its cell's mass centroid. In the surface metric that is the centroid
    // in 3D pulled onto the surface (the constrained centroidal Voronoi tessellation of Du,
    // Gunzburger and Ju 2003), here the 3D centroid's offset from the sample within the cell's
    // mean tangent plane: Gauss-Newton steps from the sample towards the surface point nearest to
    // it, through each face's Jacobian. The map's own centroid is not it wherever the map's
    // Jacobian varies across the cell (a cell spans several input faces), and that bias depends
    // on the map: on lion-head's Uopt (anisotropy 4.8) it made more steps raise the area CV
    // instead of lowering it. The steps end at o.lloyd_iterations or when the samples' RMS move
    // falls under kLloydTolerance local spacings (12 steps at 100K vertices, 18-30 at 3000-5000).
    int moved = 0;
#pragma omp parallel for schedule(static) reduction(+ : moved) if (ni > kParallelMin)
    for (int q = 0; q < ni; ++q) {
      const int g = nb + q;
      move2[q] = 0;
      const double* ag = acc.data() + kAcc * g;
      if (!(ag[0] > 0)) continue;  // no pixel: the sample stays (and is dropped below)
      Sample& sm = samples[ids[q]];
      Sample next;
      Vec2 c;
      if (relax_surface) {
        // Gauss-Newton from the sample itself: a cell can wrap a thin feature, its pixels then lie
        // in two far-apart parts of the map, and their map centroid in neither (from there ~60 of
        // 100K samples on mannequin-devil jumped by half a spacing or more at every step).
        next = sm;
        c = map_point(Us, F, sm);
      } else {
        c = Vec2(ag[1] / ag[0], ag[2] / ag[0]);  // the map's own centroid
        const int pi = std::clamp(int(c.x() * RL), 0, RL - 1), pj = std::clamp(int(c.y() * RL), 0, RL - 1);
        const int start = lpix_face[long(pj) * RL + pi] >= 0 ? lpix_face[long(pj) * RL + pi] : sm.face;
        if (!locate(c, start, next)) continue;
      }
      if (relax_surface) {
        // The 3D centroid's offset from the sample, within the cell's mean tangent plane: at a
        // peak or a ridge the 3D centroid lies inside the solid, and the surface point nearest to
        // it is on a flank, so the plain constrained centroid drives samples off sharp tips and
        // crests (three_peaks, targets 4800-5200: mean Hausdorff 0.0080 of the diagonal, 0.0056
        // with this). A cell whose normals cancel (it wraps a thin feature) uses the sample's own.
        const Vec3 x0 = surface_point(V, F, sm);
        Vec3 x3(ag[3] / ag[0], ag[4] / ag[0], ag[5] / ag[0]);
        const Vec3 nm(ag[6], ag[7], ag[8]);
        const Vec3 n = nm.norm() > 0.5 * ag[0] ? Vec3(nm.normalized()) : Vec3(row3(Nf, sm.face));
        x3 -= n * n.dot(x3 - x0);
        for (int step = 0; step < 5; ++step) {
          const int f = next.face;
          const Vec2 ua = uv_row(Us, F(f, 0)), ub = uv_row(Us, F(f, 1)), uc = uv_row(Us, F(f, 2));
          const Vec3 xa = row3(V, F(f, 0)), xb = row3(V, F(f, 1)), xc = row3(V, F(f, 2));
          Eigen::Matrix2d M;
          M << ub.x() - ua.x(), uc.x() - ua.x(), ub.y() - ua.y(), uc.y() - ua.y();
          if (!(std::abs(M.determinant()) > 0)) break;
          Eigen::Matrix<double, 3, 2> E;
          E.col(0) = xb - xa;
          E.col(1) = xc - xa;
          const Eigen::Matrix<double, 3, 2> J = E * M.inverse();  // d(3D) / d(map)
          const Eigen::Matrix2d JtJ = J.transpose() * J;
          if (!(std::abs(JtJ.determinant()) > 0)) break;
          const Vec3 x = next.w0 * xa + next.w1 * xb + next.w2 * xc;
          const Vec2 du = JtJ.ldlt().solve(J.transpose() * (x3 - x));
          const Vec2 c1 = c + du;
          Sample at;
          if (!locate(c1, next.face, at)) break;  // off the chart: keep the last point
          c = c1;
          next = at;
          if (du.norm() < 1e-3 / RL) break;
        }
      }
      const Vec2 u = next.w0 * uv_row(Ut, F(next.face, 0)) + next.w1 * uv_row(Ut, F(next.face, 1)) +
                     next.w2 * uv_row(Ut, F(next.face, 2));
      if (!pieces.inside(next.face, u, margin)) continue;  // must stay strictly inside for the Delaunay step
      {
        const double r =
            next.w0 * rho[F(next.face, 0)] + next.w1 * rho[F(next.face, 1)] + next.w2 * rho[F(next.face, 2)];
        const double h = spacing(n_int * r / rho_integral);
        move2[q] = (surface_point(V, F, next) - surface_point(V, F, sm)).squaredNorm() / (h * h);
      }
      sm = next;
      ++moved;
    }
    res.lloyd_iterations = it + 1;
    report(std::min(0.79, 0.7 + 0.09 * (it + 1) / o.lloyd_iterations));
    if (moved == 0) break;
    // Converged: the samples' RMS move, in local target spacings, under kLloydTolerance.
    const double rms = std::sqrt(
        ordered_sums<1>(ni, ni > kParallelMin, [&](int q, std::array<double, 1>& a) { a[0] += move2[q]; })[0] / ni);
    if (rms < kLloydTolerance) break;
  }
  res.seconds_relax += seconds_since(t_relax);
}

// 4c. Minimum separation: an interior sample closer in 3D than min_separation x the local target
// spacing to a boundary sample or to an earlier kept interior sample is dropped. Pixel-quantized
// or stuck samples (a Lloyd cell with no pixel) otherwise make the near-degenerate triangles.
// Clears keep of the dropped samples, counts them in res.n_separated and adds to res.seconds_relax.
void separate(const SamplingChart& c, const RemeshOptions& o, const std::vector<Sample>& samples,
              std::vector<char>& keep, RemeshResult& res) {
  const MatX3d& V = c.V;
  const MatX3i& F = c.F;
  const VecXd& rho = c.rho;
  const double rho_integral = c.rho_integral;
  const int n_int = c.n_int, nb = int(c.bnd.x.size());
  const std::vector<Vec3>& bnd_x = c.bnd.x;
  const auto t_sep = Clock::now();
  MatX3d G(nb + int(samples.size()), 3);
  for (int k = 0; k < nb; ++k) G.row(k) = bnd_x[k].transpose();
  for (size_t q = 0; q < samples.size(); ++q) {
    const Sample& sm = samples[q];
    G.row(nb + int(q)) = sm.w0 * V.row(F(sm.face, 0)) + sm.w1 * V.row(F(sm.face, 1)) + sm.w2 * V.row(F(sm.face, 2));
  }
  const KdTree tree(G);
  const int ns = int(samples.size());
  // Only a sample with some kept neighbour inside its radius can be dropped: find those in
  // parallel, then decide them in order (the verdict depends on earlier drops).
  std::vector<char> crowded(ns, 0);
  std::vector<double> radius(ns, 0.0);
#pragma omp parallel if (ns > kParallelMin)
  {
    std::vector<std::pair<int, double>> near;
#pragma omp for schedule(static)
    for (int q = 0; q < ns; ++q) {
      if (!keep[q]) continue;
      const Sample& sm = samples[q];
      const double r = sm.w0 * rho[F(sm.face, 0)] + sm.w1 * rho[F(sm.face, 1)] + sm.w2 * rho[F(sm.face, 2)];
      radius[q] = o.min_separation * spacing(n_int * r / rho_integral);
      tree.radius(row3(G, nb + q), radius[q], near);
      for (const auto& gd : near)
        if (gd.first != nb + q && (gd.first < nb || keep[gd.first - nb])) {
          crowded[q] = 1;
          break;
        }
    }
  }
  std::vector<std::pair<int, double>> near;
  for (int q = 0; q < ns; ++q) {
    if (!crowded[q]) continue;
    tree.radius(row3(G, nb + q), radius[q], near);
    for (const auto& gd : near) {
      const int g = gd.first, other = g - nb;
      if (other == q) continue;
      if (g < nb || (other < q && keep[other])) {
        keep[q] = 0;
        ++res.n_separated;
        break;
      }
    }
  }
  res.seconds_relax += seconds_since(t_sep);
}

}  // namespace

void sample_interior(const SamplingChart& c, const ControlRaster& raster, const RemeshOptions& o, Progress& report,
                     Clock::time_point t_sample, std::vector<Sample>& samples, std::vector<char>& keep,
                     RemeshResult& res) {
  const MatX3d& V = c.V;
  const MatX3i& F = c.F;
  const Topology& topo = c.topo;
  const std::vector<int>& loop = topo.boundary_loops[0];
  const MatX2d& Us = c.Us;
  const MatX2d& Ut = c.Ut;
  const VecXd& rho = c.rho;
  const double rho_integral = c.rho_integral;
  const int n_int = c.n_int, nf = topo.n_faces;
  const ChartPieces& pieces = c.pieces;
  const int R = raster.R;
  const long npix = long(R) * R;
  const std::vector<int>& pix_face = raster.pix_face;
  const std::vector<double>& pix_val = raster.pix_val;
  const double pix_sum = raster.pix_sum;
  const bool relax = o.lloyd_iterations > 0;
  // 4. Error diffusion (serpentine Floyd-Steinberg), then the samples: the same face and barycentric
  // coordinates give the point in the triangulation map and in 3D. Interior samples too close to
  // the boundary are dropped, and the density is rescaled until the count hits the target.
  const bool clearance = o.boundary_clearance > 0;
  std::unique_ptr<BoundaryDistance> bdist;
  // Faces certainly farther from the boundary than the clearance at any of their points: their
  // samples need no query (a lower bound: centroid distance minus the centroid-vertex radius).
  std::vector<char> face_far(nf, 1);
  if (clearance) {
    bdist = std::make_unique<BoundaryDistance>(
        V, loop, 0.5 * o.boundary_clearance * spacing(n_int * rho.maxCoeff() / rho_integral));
#pragma omp parallel for schedule(static) if (nf > kParallelMin)
    for (int f = 0; f < nf; ++f) {
      const Vec3 a = row3(V, F(f, 0)), b = row3(V, F(f, 1)), c = row3(V, F(f, 2));
      const Vec3 g = (a + b + c) / 3.0;
      const double rad = std::max({(a - g).norm(), (b - g).norm(), (c - g).norm()});
      const double rmin = std::min({rho[F(f, 0)], rho[F(f, 1)], rho[F(f, 2)]});
      face_far[f] = (*bdist)(g)-rad > o.boundary_clearance * spacing(n_int * rmin / rho_integral);
    }
  }
  const double margin = 1e-9;
  double scale = n_int / pix_sum;
  std::vector<long> picked;
  // A pixel's sample is always the same point, so its verdict is reused by later passes.
  std::vector<signed char> pix_keep(npix, -1);
  std::vector<double> err0(R + 2), err1(R + 2);
  // Rounds of diffusion + relaxation + minimum separation: where the sampling map is too coarse for
  // the target (pixels larger than the spacing on the surface), relaxed samples crowd and the
  // separation drops them, so the diffusion goal is raised by the shortfall and the rounds repeat
  // until the kept count is within 0.5% of the target (every mode hits the count).
  int n_goal = n_int;
  res.passes = 0;
  int kept = 0;  // interior samples kept by the last round
  for (int round = 0;; ++round) {
    res.n_separated = 0;
    for (int pass = 0; pass < 6; ++pass) {
      picked.clear();
      std::fill(err0.begin(), err0.end(), 0.0);
      for (int j = 0; j < R; ++j) {
        std::fill(err1.begin(), err1.end(), 0.0);
        const bool fwd = (j % 2) == 0;
        const int dir = fwd ? 1 : -1;
        for (int s = 0; s < R; ++s) {
          const int i = fwd ? s : R - 1 - s;
          const long idx = long(j) * R + i;
          if (pix_face[idx] < 0) continue;
          const double v = scale * pix_val[idx] + err0[i + 1];
          double e = v;
          if (v >= 0.5) {
            picked.push_back(idx);
            e = v - 1.0;
          }
          // Floyd-Steinberg weights 7, 3, 5, 1 (/16), over the neighbours inside the chart only so
          // that no density leaks out at the chart's border.
          const int in = i + dir, ib = i - dir;
          const bool ok_n = in >= 0 && in < R && pix_face[idx + dir] >= 0;
          const bool last = j + 1 >= R;
          const long below = idx + R;
          const bool ok_b = !last && pix_face[below] >= 0;
          const bool ok_bb = !last && ib >= 0 && ib < R && pix_face[below - dir] >= 0;
          const bool ok_bn = !last && in >= 0 && in < R && pix_face[below + dir] >= 0;
          const double wsum = 7.0 * ok_n + 3.0 * ok_bb + 5.0 * ok_b + 1.0 * ok_bn;
          if (wsum <= 0) continue;
          const double q = e / wsum;
          if (ok_n) err0[in + 1] += 7 * q;
          if (ok_bb) err1[ib + 1] += 3 * q;
          if (ok_b) err1[i + 1] += 5 * q;
          if (ok_bn) err1[in + 1] += 1 * q;
        }
        std::swap(err0, err1);
      }
      const int ns = int(picked.size());
      samples.assign(ns, Sample{});
      keep.assign(ns, 0);
#pragma omp parallel for schedule(static) if (ns > kParallelMin)
      for (int s = 0; s < ns; ++s) {
        const long idx = picked[s];
        const int i = int(idx % R), j = int(idx / R);
        const uint32_t h = uint32_t(idx) * 2654435761U;
        const Vec2 p((i + 0.5 + 0.1 * jitter(h)) / R, (j + 0.5 + 0.1 * jitter(h ^ 0x9e3779b9U)) / R);
        const int f = pix_face[idx];
        const Vec2 a = uv_row(Us, F(f, 0)), b = uv_row(Us, F(f, 1)), c = uv_row(Us, F(f, 2));
        const double det = cross2(b - a, c - a);
        double w0 = std::max(0.0, cross2(b - p, c - p) / det), w1 = std::max(0.0, cross2(c - p, a - p) / det);
        double w2 = std::max(0.0, 1 - w0 - w1);
        const double ws = w0 + w1 + w2;
        w0 /= ws, w1 /= ws, w2 /= ws;
        samples[s] = Sample{f, w0, w1, w2};
        if (pix_keep[idx] >= 0) {
          keep[s] = pix_keep[idx];
          continue;
        }
        const Vec2 u = w0 * uv_row(Ut, F(f, 0)) + w1 * uv_row(Ut, F(f, 1)) + w2 * uv_row(Ut, F(f, 2));
        if (!pieces.inside(f, u, margin)) {
          pix_keep[idx] = 0;
          continue;
        }
        if (face_far[f]) {
          keep[s] = pix_keep[idx] = 1;
          continue;
        }
        const Vec3 x = w0 * row3(V, F(f, 0)) + w1 * row3(V, F(f, 1)) + w2 * row3(V, F(f, 2));
        const double r = w0 * rho[F(f, 0)] + w1 * rho[F(f, 1)] + w2 * rho[F(f, 2)];
        const double hloc = spacing(n_int * r / rho_integral);
        keep[s] = (*bdist)(x) >= o.boundary_clearance * hloc;
        pix_keep[idx] = keep[s];
      }
      int accepted = 0;
      for (int s = 0; s < ns; ++s) accepted += keep[s];
      ++res.passes;
      res.n_rejected = ns - accepted;
      report(std::min(0.55 + 0.04 * (pass + 1), 0.79));
      const int tol = std::max(1, int(0.002 * n_goal));
      if (std::abs(accepted - n_goal) <= tol) break;
      scale *= accepted > 0 ? double(n_goal) / accepted : 2.0;  // none kept: every sample hit the clearance
    }
    res.seconds_sample = seconds_since(t_sample) - res.seconds_relax;

    // 4b. Density-weighted Lloyd relaxation of the interior samples.
    if (relax) lloyd_relax(c, raster, o, report, samples, keep, res);

    // 4c. Minimum separation.
    if (o.min_separation > 0) separate(c, o, samples, keep, res);
    kept = 0;
    for (char k : keep) kept += k;
    res.sampling_rounds = round + 1;
    if (kept == 0 || std::abs(kept - n_int) <= std::max(1, int(0.005 * n_int)) || round == 3) break;
    const double shortfall = double(n_int) / kept;
    n_goal = std::max(1, int(std::lround(n_goal * shortfall)));
    scale *= shortfall;
  }  // rounds
  if (kept == 0 && n_int > 0)
    throw MeshError(
        "remesh: no inner vertex could be placed (every sample fell within the boundary clearance); "
        "raise the target or lower the resolution");
  if (res.n_separated > std::max(1, n_int / 100))
    res.warnings.push_back(std::to_string(res.n_separated) + " of " + std::to_string(n_goal) +
                           " interior samples were closer than " + std::to_string(o.min_separation) +
                           " x the target spacing and were dropped (the diffusion oversampled to keep the count): "
                           "the sampling map is too coarse for this target somewhere; raise the resolution or "
                           "sample on the low-stretch map (mode double)");
}

}  // namespace dgmesh::detail
