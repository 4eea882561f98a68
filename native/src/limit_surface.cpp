// The Loop limit surface of a control mesh; see detail/limit_surface.h.
#include "dgmesh/detail/limit_surface.h"

#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/ptexIndices.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <string>

#include "dgmesh/errors.h"

namespace dgmesh::detail {

namespace Sdc = OpenSubdiv::Sdc;

void LimitSurface::init(const MatX3i& F_, int n_vertices, int level) {
  F = F_;
  n_control = n_vertices;
  topo = build_topology(F, n_vertices);
  const int m = static_cast<int>(F.rows());
  std::vector<int> counts(m, 3);
  Far::TopologyDescriptor desc;
  desc.numVertices = n_vertices;
  desc.numFaces = m;
  desc.numVertsPerFace = counts.data();
  desc.vertIndicesPerFace = F.data();
  Sdc::Options sdc;
  sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);  // as loop_subdivide
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  refiner.reset(Factory::Create(desc, Factory::Options(Sdc::SCHEME_LOOP, sdc)));
  if (!refiner) throw MeshError("OpenSubdiv could not build the Loop topology of the control mesh");

  Far::PatchTableFactory::Options po(level);
  po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
  po.SetPatchPrecision<double>();
  po.useInfSharpPatch = true;
  po.generateVaryingTables = false;
  po.generateVaryingLocalPoints = false;
  refiner->RefineAdaptive(po.GetRefineAdaptiveOptions());
  patches.reset(Far::PatchTableFactory::Create(*refiner, po));
  if (!patches) throw Error("OpenSubdiv could not build the limit patches of the control mesh");

  // Refined vertices of every level as combinations of control vertices, then the end-cap points.
  using StencilFactory = Far::StencilTableFactoryReal<double>;
  using Table = Far::StencilTableReal<double>;
  StencilFactory::Options so;
  so.generateOffsets = true;
  so.generateIntermediateLevels = true;
  std::unique_ptr<const Table> base;
  if (refiner->GetMaxLevel() > 0) base.reset(StencilFactory::Create(*refiner, so));
  std::unique_ptr<const Table> combined;
  const Table* local = patches->GetLocalPointStencilTable<double>();
  if (local && local->GetNumStencils() > 0) {
    if (base) {
      combined.reset(StencilFactory::AppendLocalPointStencilTable(*refiner, base.get(), local, true));
    } else {
      combined.reset(new Table(*local));  // nothing refined: local points refer to control vertices
    }
  }
  const Table* table = combined ? combined.get() : base.get();
  const int rows = table ? table->GetNumStencils() : 0;
  const int n_all = n_control + rows;  // OpenSubdiv's numbering: control vertices, then the table's
  const auto& pv = patches->GetPatchControlVerticesTable();
  std::vector<int> renum(n_all, -1), old_of;
  old_of.reserve(n_all);
  patch_cvs.resize(pv.size());
  for (size_t q = 0; q < pv.size(); ++q) {
    const int c = pv[q];
    if (c < 0 || c >= n_all) throw Error("OpenSubdiv patch refers to a missing patch point");
    if (renum[c] < 0) renum[c] = static_cast<int>(old_of.size()), old_of.push_back(c);
    patch_cvs[q] = renum[c];
  }
  n_points = static_cast<int>(old_of.size());
  st_off.assign(n_points + 1, 0);
  st_idx.clear();
  st_w.clear();
  for (int r = 0; r < n_points; ++r) {
    const int c = old_of[r];
    if (c < n_control) {
      st_idx.push_back(c);
      st_w.push_back(1.0);
    } else {
      const int q = c - n_control;
      const int size = table->GetSizes()[q], off = table->GetOffsets()[q];
      for (int k = 0; k < size; ++k) {
        const int v = table->GetControlIndices()[off + k];
        if (v < 0 || v >= n_control) throw Error("OpenSubdiv stencil refers to a missing control vertex");
        st_idx.push_back(v);
        st_w.push_back(table->GetWeights()[off + k]);
      }
    }
    st_off[r + 1] = static_cast<int>(st_idx.size());
  }
  for (int a = 0; a < patches->GetNumPatchArrays(); ++a)
    if (patches->GetPatchArrayDescriptor(a).GetNumControlVertices() > kMaxCvs)
      throw Error("unexpected OpenSubdiv patch type");

  map = std::make_unique<Far::PatchMap>(*patches);
  Far::PtexIndices pi(*refiner);
  ptex.resize(m);
  for (int f = 0; f < m; ++f) ptex[f] = pi.GetFaceId(f);

  // The centre child of a refined triangle is rotated and contains (1/3, 1/3).
  for (int f = 0; f < m; ++f) {
    const double u = 1.0 / 3, v = 1.0 / 3, h = 1e-5;
    const Far::PatchTable::PatchHandle* hd = map->FindPatch(ptex[f], u, v);
    if (!hd || !patches->GetPatchParam(*hd).IsTriangleRotated()) continue;
    double wP[kMaxCvs], wS[kMaxCvs], wT[kMaxCvs], wSS[kMaxCvs], wST[kMaxCvs], wTT[kMaxCvs], wS1[kMaxCvs];
    patches->EvaluateBasis(*hd, u, v, wP, wS, wT, wSS, wST, wTT);
    patches->EvaluateBasis(*hd, u + h, v, wP, wS1, wT);
    double dot = 0;
    for (int j = 0; j < patches->GetPatchArrayDescriptor(hd->arrayIndex).GetNumControlVertices(); ++j)
      dot += wSS[j] * (wS1[j] - wS[j]) / h;
    flip_rotated_second = dot < 0;
    break;
  }
}

int LimitSurface::basis(int f, double s, double t, const int*& cvs, double* wP, double* wS, double* wT, double* wSS,
                        double* wST, double* wTT, bool* second) const {
  clamp_st(s, t);
  const Far::PatchTable::PatchHandle* h = map->FindPatch(ptex[f], s, t);
  if (!h) return 0;
  const Far::PatchDescriptor desc = patches->GetPatchArrayDescriptor(h->arrayIndex);
  const int k = desc.GetNumControlVertices();
  const Far::PatchDescriptor::Type type = desc.GetType();
  const bool gregory = type == Far::PatchDescriptor::GREGORY_TRIANGLE || type == Far::PatchDescriptor::GREGORY_BASIS ||
                       type == Far::PatchDescriptor::GREGORY || type == Far::PatchDescriptor::GREGORY_BOUNDARY;
  const Far::ConstIndexArray idx = patches->GetPatchVertices(*h);
  cvs = patch_cvs.data() + (&idx[0] - &patches->GetPatchControlVerticesTable()[0]);  // our numbering
  if (second) *second = wSS && !gregory;
  if (!gregory) {
    if (wSS) {
      patches->EvaluateBasis(*h, s, t, wP, wS, wT, wSS, wST, wTT);
      if (flip_rotated_second && patches->GetPatchParam(*h).IsTriangleRotated())
        for (int j = 0; j < k; ++j) wSS[j] = -wSS[j], wST[j] = -wST[j], wTT[j] = -wTT[j];
    } else {
      patches->EvaluateBasis(*h, s, t, wP, wS, wT);
    }
    return k;
  }
  patches->EvaluateBasis(*h, s, t, wP, wS, wT);  // pseudo derivatives: the last resort below
  const double size = 1.0 / (1 << patches->GetPatchParam(*h).GetDepth());
  double w1[kMaxCvs], w2[kMaxCvs];
  auto at = [&](double u, double v, double* w) {
    if (u < 0 || v < 0 || u + v > 1 || map->FindPatch(ptex[f], u, v) != h) return false;
    patches->EvaluateBasis(*h, u, v, w);
    return true;
  };
  // First differences along (du, dv) * step: central, else second-order one-sided.
  auto first = [&](double du, double dv, double step, double* out) {
    if (at(s + du * step, t + dv * step, w1) && at(s - du * step, t - dv * step, w2)) {
      for (int j = 0; j < k; ++j) out[j] = (w1[j] - w2[j]) / (2 * step);
    } else if (at(s + du * step, t + dv * step, w1) && at(s + 2 * du * step, t + 2 * dv * step, w2)) {
      for (int j = 0; j < k; ++j) out[j] = (-3 * wP[j] + 4 * w1[j] - w2[j]) / (2 * step);
    } else if (at(s - du * step, t - dv * step, w1) && at(s - 2 * du * step, t - 2 * dv * step, w2)) {
      for (int j = 0; j < k; ++j) out[j] = (3 * wP[j] - 4 * w1[j] + w2[j]) / (2 * step);
    } else {
      return false;
    }
    return true;
  };
  // Second differences along (du, dv) * step: central, else one-sided.
  auto second_diff = [&](double du, double dv, double step, double* out) {
    const double h2 = step * step;
    if (at(s + du * step, t + dv * step, w1) && at(s - du * step, t - dv * step, w2)) {
      for (int j = 0; j < k; ++j) out[j] = (w1[j] - 2 * wP[j] + w2[j]) / h2;
    } else if (at(s + du * step, t + dv * step, w1) && at(s + 2 * du * step, t + 2 * dv * step, w2)) {
      for (int j = 0; j < k; ++j) out[j] = (wP[j] - 2 * w1[j] + w2[j]) / h2;
    } else if (at(s - du * step, t - dv * step, w1) && at(s - 2 * du * step, t - 2 * dv * step, w2)) {
      for (int j = 0; j < k; ++j) out[j] = (wP[j] - 2 * w1[j] + w2[j]) / h2;
    } else {
      return false;
    }
    return true;
  };
  first(1, 0, 1e-5 * size, wS);
  first(0, 1, 1e-5 * size, wT);
  if (wSS) {
    // Larger steps for second differences (rounding grows as 1/step^2); the mixed term from the
    // second difference along the diagonal: D_dd = Sss + 2 Sst + Stt.
    const double step = 1e-3 * size;
    double wD[kMaxCvs];
    const bool ok = second_diff(1, 0, step, wSS) && second_diff(0, 1, step, wTT) && second_diff(1, 1, step, wD);
    if (ok)
      for (int j = 0; j < k; ++j) wST[j] = 0.5 * (wD[j] - wSS[j] - wTT[j]);
    if (second) *second = ok;
  }
  return k;
}

bool LimitSurface::eval(const MatX4d& P, const Loc& l, Vec3& S, Vec3& Ss, Vec3& St, Vec3* H, bool* second) const {
  double wP[kMaxCvs], wS[kMaxCvs], wT[kMaxCvs], wSS[kMaxCvs], wST[kMaxCvs], wTT[kMaxCvs];
  const int* cvs = nullptr;
  bool has2 = false;
  const int k = basis(l.f, l.s, l.t, cvs, wP, wS, wT, H ? wSS : nullptr, wST, wTT, &has2);
  if (second) *second = has2;
  if (k == 0) return false;
  S.setZero(), Ss.setZero(), St.setZero();
  for (int j = 0; j < k; ++j) {
    const Eigen::Map<const Vec3> p(P.data() + 4 * static_cast<size_t>(cvs[j]));
    S += wP[j] * p, Ss += wS[j] * p, St += wT[j] * p;
  }
  if (H) {
    H[0].setZero(), H[1].setZero(), H[2].setZero();
    if (has2)
      for (int j = 0; j < k; ++j) {
        const Eigen::Map<const Vec3> p(P.data() + 4 * static_cast<size_t>(cvs[j]));
        H[0] += wSS[j] * p, H[1] += wST[j] * p, H[2] += wTT[j] * p;
      }
  }
  return true;
}

Loc LimitSurface::advance(Loc l, double ds, double dt) const {
  double b[3] = {1 - l.s - l.t, l.s, l.t};
  double d[3] = {-ds - dt, ds, dt};
  for (int crossing = 0; crossing < 8; ++crossing) {
    double alpha = 1;
    int hit = -1;
    for (int k = 0; k < 3; ++k)
      if (d[k] < 0 && b[k] + alpha * d[k] < 0) alpha = std::max(0.0, b[k] / -d[k]), hit = k;
    for (int k = 0; k < 3; ++k) b[k] += alpha * d[k], d[k] *= 1 - alpha;
    if (hit < 0) break;
    b[hit] = 0;
    const int ka = (hit + 1) % 3, kb = (hit + 2) % 3;  // the edge F(f,ka) -> F(f,kb)
    const int e = topo.face_edges(l.f, ka);
    const int g = topo.edge_faces(e, 0) == l.f ? topo.edge_faces(e, 1) : topo.edge_faces(e, 0);
    if (g < 0) {  // boundary: keep the along-edge part of the rest of the step
      d[ka] += 0.5 * d[hit], d[kb] += 0.5 * d[hit], d[hit] = 0;
      continue;
    }
    const int va = F(l.f, ka), vb = F(l.f, kb);
    int ga = 0, gb = 0, gc = 0;
    for (int j = 0; j < 3; ++j) {
      if (F(g, j) == va)
        ga = j;
      else if (F(g, j) == vb)
        gb = j;
      else
        gc = j;
    }
    // Corner hit of f sits at va + vb - (g's third corner) in the unfolded parallelogram.
    double nb[3], nd[3];
    nb[ga] = b[ka], nb[gb] = b[kb], nb[gc] = 0;
    nd[ga] = d[ka] + d[hit], nd[gb] = d[kb] + d[hit], nd[gc] = -d[hit];
    std::copy(nb, nb + 3, b);
    std::copy(nd, nd + 3, d);
    l.f = g;
  }
  l.s = std::max(0.0, b[1]);
  l.t = std::max(0.0, b[2]);
  clamp_st(l.s, l.t);
  return l;
}

Loc LimitSurface::newton(const MatX4d& P, const Vec3& p, Loc loc, int iterations, double& d2) const {
  Vec3 S, Ss, St, H[3];
  bool second = false;
  d2 = std::numeric_limits<double>::infinity();
  if (!eval(P, loc, S, Ss, St, H, &second)) return loc;
  d2 = (p - S).squaredNorm();
  for (int it = 0; it < iterations; ++it) {
    const Vec3 r = p - S;
    const double ra = Ss.dot(r), rb = St.dot(r);  // -gradient
    double a = Ss.dot(Ss), b = Ss.dot(St), c = St.dot(St);
    const double jdet = a * c - b * b;
    if (!(jdet > 1e-14 * a * c)) break;
    const double na = a - r.dot(H[0]), nb = b - r.dot(H[1]), nc = c - r.dot(H[2]);
    if (second && na > 0 && na * nc - nb * nb > 1e-3 * jdet) a = na, b = nb, c = nc;  // Newton
    const double det = a * c - b * b;
    double ds = (c * ra - b * rb) / det, dt = (a * rb - b * ra) / det;
    double len = std::abs(ds) + std::abs(dt);
    if (!(len > 1e-13)) break;
    if (len > 0.5) ds *= 0.5 / len, dt *= 0.5 / len, len = 0.5;  // a local model: one face at most
    bool accepted = false;
    for (int tries = 0; tries < 8 && !accepted; ++tries, ds *= 0.5, dt *= 0.5) {
      const Loc n = advance(loc, ds, dt);
      Vec3 S2, Ss2, St2, H2[3];
      bool second2 = false;
      if (!eval(P, n, S2, Ss2, St2, H2, &second2)) continue;
      const double d2n = (p - S2).squaredNorm();
      if (d2n < d2) {
        loc = n, S = S2, Ss = Ss2, St = St2, d2 = d2n, accepted = true, second = second2;
        std::copy(H2, H2 + 3, H);
      }
    }
    if (!accepted || len < 1e-11) break;
  }
  return loc;
}

Loc LimitSurface::project(const MatX4d& P, const Vec3& p, Loc loc, int iterations) const {
  double d2;
  loc = newton(P, p, loc, iterations, d2);
  for (int round = 0; round < 3; ++round) {
    const double b[3] = {1 - loc.s - loc.t, loc.s, loc.t};
    constexpr double eps = 1e-7;
    const int zeros = (b[0] < eps) + (b[1] < eps) + (b[2] < eps);
    if (zeros == 0) break;
    Loc best = loc;
    double best_d2 = d2;
    auto restart = [&](int g, const double* bg) {
      // Nudged into the face so that its own parameter directions are used.
      const double q0 = 0.96 * bg[0] + 0.04 / 3, q1 = 0.96 * bg[1] + 0.04 / 3, q2 = 0.96 * bg[2] + 0.04 / 3;
      (void)q0;
      double dn;
      const Loc r = newton(P, p, Loc{g, q1, q2}, iterations, dn);
      if (dn < best_d2) best = r, best_d2 = dn;
    };
    if (zeros >= 2) {  // at a corner: every face around its vertex
      const int k = b[0] >= b[1] && b[0] >= b[2] ? 0 : (b[1] >= b[2] ? 1 : 2);
      const int v = F(loc.f, k);
      for (int q = topo.vf_offset[v]; q < topo.vf_offset[v + 1]; ++q) {
        const int g = topo.vf_index[q];
        double bg[3] = {0, 0, 0};
        for (int j = 0; j < 3; ++j)
          if (F(g, j) == v) bg[j] = 1;
        restart(g, bg);
      }
    } else {  // on an edge: the face across it
      const int z = b[0] < eps ? 0 : (b[1] < eps ? 1 : 2);
      const int ka = (z + 1) % 3, kb = (z + 2) % 3;
      const int e = topo.face_edges(loc.f, ka);
      const int g = topo.edge_faces(e, 0) == loc.f ? topo.edge_faces(e, 1) : topo.edge_faces(e, 0);
      if (g >= 0) {
        double bg[3] = {0, 0, 0};
        for (int j = 0; j < 3; ++j) {
          if (F(g, j) == F(loc.f, ka)) bg[j] = b[ka];
          if (F(g, j) == F(loc.f, kb)) bg[j] = b[kb];
        }
        restart(g, bg);
      }
    }
    if (!(best_d2 < d2)) break;
    loc = best, d2 = best_d2;
  }
  return loc;
}

}  // namespace dgmesh::detail
