// Displaced subdivision multiresolution layer (thesis 6.4, end of 6.5; [LMH00]). See multires.h.
//
// Evaluation goes through OpenSubdiv only (no hand-written Loop rules): the control topology is
// refined adaptively with Sdc::SCHEME_LOOP, Far::PatchTableFactory builds box-spline patches for
// regular regions and Gregory-triangle end caps at the isolation level, and a StencilTable with
// intermediate levels plus the patch table's local-point stencils expresses every patch point as a
// combination of control vertices. A location (control face, s, t) is a ptex location (for Loop,
// ptex face = control face, corners (0,0), (1,0), (0,1)), found in the patch table by Far::PatchMap.
#include "dgmesh/multires.h"

#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/ptexIndices.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "dgmesh/decimate.h"
#include "dgmesh/detail/limit_surface.h"
#include "dgmesh/detail/timer.h"
#include "dgmesh/errors.h"
#include "dgmesh/parallel.h"
#include "dgmesh/self_intersection.h"
#include "dgmesh/sparse_solver.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/validate.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace dgmesh {

namespace {

using detail::clamp_st;
using detail::kMaxCvs;
using detail::LimitSurface;
using detail::Loc;
using detail::MatX4d;
namespace Far = OpenSubdiv::Far;

using Vec4 = Eigen::Vector4d;
using CMap4 =
    Eigen::Map<const Vec4, Eigen::Aligned16>;  // largest patch (Gregory basis); Loop patches have 12 or 18 points
constexpr int kMaxLevel = 5;

// Runs fn(i) for i in [0, n) in parallel, in blocks so that the (single-threaded) progress callback
// is called between blocks and can cancel. fn must not throw.
template <class Fn>
void parallel_blocks(int n, Progress& progress, double f0, double f1, Fn&& fn) {
  const int block = std::max(8192, n / 40);
  for (int start = 0; start < n; start += block) {
    const int end = std::min(n, start + block);
#pragma omp parallel for schedule(dynamic, 256)
    for (int i = start; i < end; ++i) fn(i);
    progress(f0 + (f1 - f0) * double(end) / std::max(1, n));
  }
}

// The frame (t1, t2, n) of the limit surface from its first derivatives. Falls back to the control
// face's plane where the derivatives are degenerate (only on degenerate control geometry).
inline void make_frame(const Vec3& Ds, const Vec3& Dt, const Vec3& face_normal, const Vec3& face_edge, Vec3& t1,
                       Vec3& t2, Vec3& n) {
  n = Ds.cross(Dt);
  const double ls = Ds.norm(), lt = Dt.norm(), ln = n.norm();
  if (ln > 1e-10 * ls * lt && ln > 0) {
    n /= ln;
    t1 = Ds / ls;
  } else {
    const double fn = face_normal.norm();
    n = fn > 0 ? Vec3(face_normal / fn) : Vec3(0, 0, 1);
    Vec3 e = face_edge - face_edge.dot(n) * n;
    if (!(e.norm() > 0)) e = n.unitOrthogonal();
    t1 = e.normalized();
  }
  t2 = n.cross(t1);
}

// The dense stencils (see Multires::Impl) and what one evaluation reads and writes.
struct DenseArgs {
  const int* vsup;     // per dense vertex: its support list
  const int* sup_off;  // support list s: control vertices sup_idx[sup_off[s] .. sup_off[s + 1])
  const int* sup_idx;
  const int64_t* w_off;  // per dense vertex: its weights w[w_off[i] ..], 3 per support entry after the first
  const float* w;
  const double* X4;    // control vertices, 4 doubles per row (the 4th unused)
  const double* disp;  // (a, b, c) per dense vertex, or null: frames
  double* out;         // positions (3 per vertex), or frames (12 per vertex: S, t1, t2, n) if disp is null
  float* out_f;        // single-precision positions instead of out (disp given)
};

// Dense vertices [i0, i1): limit point S and derivatives Ds, Dt as one sparse product over the
// control vertices (float weights for every support entry but the first, which takes 1 minus their
// sum for the position and minus their sum for the derivatives, so that translations are
// reproduced whatever the rounding of the stored weights), the frame (t1, t2, n) = (Ds/|Ds|,
// n x t1, Ds x Dt/|Ds x Dt|), and x = S + a t1 + b t2 + c n (multires.h). Returns the first vertex
// whose derivatives are degenerate (the caller redoes the rest of the range with a fallback
// frame), or i1.
using v4d = double __attribute__((vector_size(32)));
// Four floats at any 4-byte boundary (the weights of one support entry and the next entry's first).
using v4f_u = float __attribute__((vector_size(16), aligned(4), may_alias));

inline __attribute__((always_inline)) int dense_body(const DenseArgs& g, int i0, int i1) {
  for (int i = i0; i < i1; ++i) {
    const int s = g.vsup[i];
    const int* cv = g.sup_idx + g.sup_off[s];
    const int k = g.sup_off[s + 1] - g.sup_off[s];
    const float* wi = g.w + g.w_off[i];
    const double* x0 = g.X4 + 4 * static_cast<size_t>(cv[0]);
    // Per coordinate, lanes (position, d/ds, d/dt): sum_q w_q x_q over the entries after the
    // first, in two interleaved chains (latency), and the weight sums W for the first entry's
    // share: S = x0 + sum_q wP_q (x_q - x0) = sum_q wP_q x_q + (1 - W_P) x0, exact for translations
    // whatever the rounding of the stored weights (their sum W is taken as stored).
    v4d ax = {0, 0, 0, 0}, ay = ax, az = ax, aw = ax, bx = ax, by = ax, bz = ax, bw = ax;
    int q = 1;
    for (; q + 1 < k; q += 2, wi += 6) {
      const double* x = g.X4 + 4 * static_cast<size_t>(cv[q]);
      const double* y = g.X4 + 4 * static_cast<size_t>(cv[q + 1]);
      const v4d wa = __builtin_convertvector(*reinterpret_cast<const v4f_u*>(wi), v4d);
      const v4d wb = __builtin_convertvector(*reinterpret_cast<const v4f_u*>(wi + 3), v4d);
      ax += x[0] * wa, ay += x[1] * wa, az += x[2] * wa, aw += wa;
      bx += y[0] * wb, by += y[1] * wb, bz += y[2] * wb, bw += wb;
    }
    if (q < k) {
      const double* x = g.X4 + 4 * static_cast<size_t>(cv[q]);
      const v4d wa = __builtin_convertvector(*reinterpret_cast<const v4f_u*>(wi), v4d);
      ax += x[0] * wa, ay += x[1] * wa, az += x[2] * wa, aw += wa;
    }
    ax += bx, ay += by, az += bz, aw += bw;
    const v4d c0 = {1 - aw[0], -aw[1], -aw[2], 0};  // the first entry's weights
    ax += x0[0] * c0, ay += x0[1] * c0, az += x0[2] * c0;
    double S[3] = {ax[0], ay[0], az[0]}, A[3] = {ax[1], ay[1], az[1]};
    const double B[3] = {ax[2], ay[2], az[2]};
    double n[3] = {A[1] * B[2] - A[2] * B[1], A[2] * B[0] - A[0] * B[2], A[0] * B[1] - A[1] * B[0]};
    const double ln2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    const double la2 = A[0] * A[0] + A[1] * A[1] + A[2] * A[2], lb2 = B[0] * B[0] + B[1] * B[1] + B[2] * B[2];
    if (!(ln2 > 1e-20 * la2 * lb2 && ln2 > 0)) return i;
    const double in = 1 / std::sqrt(ln2), ia = 1 / std::sqrt(la2);
    for (int d = 0; d < 3; ++d) n[d] *= in, A[d] *= ia;  // A becomes t1
    const double t2[3] = {n[1] * A[2] - n[2] * A[1], n[2] * A[0] - n[0] * A[2], n[0] * A[1] - n[1] * A[0]};
    if (g.disp) {
      const double a = g.disp[3 * static_cast<size_t>(i)], b = g.disp[3 * static_cast<size_t>(i) + 1],
                   c = g.disp[3 * static_cast<size_t>(i) + 2];
      if (g.out_f) {
        float* o = g.out_f + 3 * static_cast<size_t>(i);
        for (int d = 0; d < 3; ++d) o[d] = static_cast<float>(S[d] + a * A[d] + b * t2[d] + c * n[d]);
      } else {
        double* o = g.out + 3 * static_cast<size_t>(i);
        for (int d = 0; d < 3; ++d) o[d] = S[d] + a * A[d] + b * t2[d] + c * n[d];
      }
    } else {
      double* o = g.out + 12 * static_cast<size_t>(i);
      for (int d = 0; d < 3; ++d) o[d] = S[d], o[3 + d] = A[d], o[6 + d] = t2[d], o[9 + d] = n[d];
    }
  }
  return i1;
}

// The kernel compiled for the baseline x86-64 and for AVX2 + FMA (4 doubles per instruction),
// picked once by CPU features. (GCC's target_clones("arch=haswell") dispatches on the CPU model,
// not its features, and falls back to the scalar baseline on newer CPUs.)
#if defined(__GNUC__) && defined(__x86_64__)
__attribute__((target("avx2,fma"))) int dense_kernel_avx2(const DenseArgs& g, int i0, int i1) {
  return dense_body(g, i0, i1);
}
#endif
int dense_kernel_base(const DenseArgs& g, int i0, int i1) { return dense_body(g, i0, i1); }
using DenseKernel = int (*)(const DenseArgs&, int, int);
DenseKernel pick_dense_kernel() {
#if defined(__GNUC__) && defined(__x86_64__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return dense_kernel_avx2;
#endif
  return dense_kernel_base;
}
int dense_kernel(const DenseArgs& g, int i0, int i1) {
  static const DenseKernel k = pick_dense_kernel();
  return k(g, i0, i1);
}

}  // namespace

struct Multires::Impl {
  int n() const { return static_cast<int>(face.size()); }
  void compute_weights();

  LimitSurface surf;
  MultiresTimings timings;
  MatX3d control_V;
  int level = 2;
  VecXi face;
  MatX2d st;
  MatX3d disp;
  // Dense stencils: reconstruction is ONE sparse product over the control vertices. The patch
  // basis of each base point (position and first derivatives) is composed at bind time with the
  // stencils of the patch points, so that no patch point is evaluated per pose (at level 2 a 5K-face
  // control mesh has more patch points than a 170K-vertex dense mesh has vertices) and every gather
  // hits the control vertices, which stay in cache. The dense vertices of one patch share the
  // patch's support list (control vertices, ascending); the weights of every entry after the first,
  // (wP, wS, wT) as floats, are per vertex in dense order, read as one stream.
  std::vector<int> sup_off, sup_idx;
  std::vector<int> vsup;       // per dense vertex: support list
  std::vector<int64_t> w_off;  // per dense vertex (+1): offset into w
  std::vector<float> w;

  DenseArgs args(const double* X4, const double* disp_ptr, double* out, float* out_f) const {
    return DenseArgs{vsup.data(), sup_off.data(), sup_idx.data(), w_off.data(), w.data(), X4, disp_ptr, out, out_f};
  }
  // Limit point and derivatives of dense vertex i in double precision from the float weights
  // (the kernel's arithmetic).
  void eval_f(const double* X4, int i, Vec3& S, Vec3& Ds, Vec3& Dt) const {
    const int s = vsup[i];
    const int* cv = sup_idx.data() + sup_off[s];
    const int k = sup_off[s + 1] - sup_off[s];
    const float* wi = w.data() + w_off[i];
    Vec3 sum = Vec3::Zero();  // weight sums (position, d/ds, d/dt) of the entries after the first
    S.setZero(), Ds.setZero(), Dt.setZero();
    for (int q = 1; q < k; ++q, wi += 3) {
      const CMap4 x(X4 + 4 * static_cast<size_t>(cv[q]));
      S += double(wi[0]) * x.head<3>();
      Ds += double(wi[1]) * x.head<3>();
      Dt += double(wi[2]) * x.head<3>();
      sum += Vec3(wi[0], wi[1], wi[2]);
    }
    const CMap4 x0(X4 + 4 * static_cast<size_t>(cv[0]));
    S += (1 - sum[0]) * x0.head<3>();
    Ds -= sum[1] * x0.head<3>();
    Dt -= sum[2] * x0.head<3>();
  }
  // Limit point and frame (t1, t2, n) of dense vertex i, with the control face's plane as the
  // fallback where the derivatives are degenerate (only on degenerate control geometry).
  void frame_at(const double* X4, int i, Vec3& S, Vec3& t1, Vec3& t2, Vec3& n) const {
    Vec3 Ds, Dt;
    eval_f(X4, i, S, Ds, Dt);
    n = Ds.cross(Dt);
    const double ln2 = n.squaredNorm(), ls2 = Ds.squaredNorm(), lt2 = Dt.squaredNorm();
    if (ln2 > 1e-20 * ls2 * lt2 && ln2 > 0) {
      n *= 1 / std::sqrt(ln2);
      t1 = Ds * (1 / std::sqrt(ls2));
      t2 = n.cross(t1);
    } else {
      const int f = face[i];
      const CMap4 a(X4 + 4 * static_cast<size_t>(surf.F(f, 0))), b(X4 + 4 * static_cast<size_t>(surf.F(f, 1))),
          c(X4 + 4 * static_cast<size_t>(surf.F(f, 2)));
      const Vec3 edge = (b - a).head<3>();
      const Vec3 fnrm = edge.cross((c - a).head<3>());
      make_frame(Ds, Dt, fnrm, edge, t1, t2, n);
    }
  }
  // Evaluates every dense vertex: positions into out (double) or out_f (float) when disp_ptr is
  // given, else frames (12 doubles per vertex) into out. One static block of vertices per thread
  // (the work per vertex is uniform); a block that meets a degenerate frame finishes on frame_at.
  void run_dense(const double* X4, const double* disp_ptr, double* out, float* out_f = nullptr) const {
    const int nd = n();
    const DenseArgs g = args(X4, disp_ptr, out, out_f);
    auto block = [&](int i0, int i1) {
      for (int i = dense_kernel(g, i0, i1); i < i1; i = dense_kernel(g, i + 1, i1)) {
        Vec3 S, t1, t2, nn;
        frame_at(X4, i, S, t1, t2, nn);
        if (!disp_ptr) {
          double* o = out + 12 * static_cast<size_t>(i);
          for (int d = 0; d < 3; ++d) o[d] = S[d], o[3 + d] = t1[d], o[6 + d] = t2[d], o[9 + d] = nn[d];
          continue;
        }
        const Vec3 x = S + disp_ptr[3 * static_cast<size_t>(i)] * t1 + disp_ptr[3 * static_cast<size_t>(i) + 1] * t2 +
                       disp_ptr[3 * static_cast<size_t>(i) + 2] * nn;
        for (int d = 0; d < 3; ++d) {
          if (out_f)
            out_f[3 * static_cast<size_t>(i) + d] = static_cast<float>(x[d]);
          else
            out[3 * static_cast<size_t>(i) + d] = x[d];
        }
      }
    };
    if (nd < kParallelMin) {
      block(0, nd);
      return;
    }
#pragma omp parallel
    {
      int nt = 1, t = 0;
#ifdef _OPENMP
      nt = omp_get_num_threads(), t = omp_get_thread_num();
#endif
      block(static_cast<int>(static_cast<int64_t>(nd) * t / nt),
            static_cast<int>(static_cast<int64_t>(nd) * (t + 1) / nt));
    }
  }

  // The control vertices as 4 doubles per row (one aligned packet per gather), validated.
  void load_control(const Eigen::Ref<const MatX3d>& X, std::vector<double>& X4) const {
    if (X.rows() != surf.n_control)
      throw MeshError("control vertices: expected " + std::to_string(surf.n_control) + " rows, got " +
                      std::to_string(X.rows()));
    X4.resize(4 * static_cast<size_t>(X.rows()));
    for (Eigen::Index r = 0; r < X.rows(); ++r) {
      const double x = X(r, 0), y = X(r, 1), z = X(r, 2);
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        throw MeshError("control vertices contain NaN or infinite coordinates");
      double* o = X4.data() + 4 * r;
      o[0] = x, o[1] = y, o[2] = z, o[3] = 0;
    }
  }
};

void Multires::Impl::compute_weights() {
  const int nd = n();
  const int nc = surf.n_control;
  // 1. The patch of every base point (its first entry in the patch-point table names it).
  std::vector<int> begin(nd, 0);
  std::atomic<bool> missing{false};
#pragma omp parallel for schedule(static)
  for (int i = 0; i < nd; ++i) {
    const auto* h = surf.handle(face[i], st(i, 0), st(i, 1));
    if (!h) {
      missing = true;
      continue;
    }
    const Far::ConstIndexArray cvs = surf.patches->GetPatchVertices(*h);
    begin[i] = static_cast<int>(&cvs[0] - &surf.patches->GetPatchControlVerticesTable()[0]);
  }
  if (missing) throw Error("a base point lies on no limit patch (hole face?)");
  // 2. One support list per patch in use: the control vertices its patch points depend on.
  std::vector<int> list_of(surf.patch_cvs.size() + 1, -1);
  std::vector<int> first_vertex;  // a dense vertex of each list (to get the patch's size)
  vsup.resize(nd);
  for (int i = 0; i < nd; ++i) {
    int& l = list_of[begin[i]];
    if (l < 0) l = static_cast<int>(first_vertex.size()), first_vertex.push_back(i);
    vsup[i] = l;
  }
  const int nl = static_cast<int>(first_vertex.size());
  sup_off.assign(nl + 1, 0);
  sup_idx.clear();
  {
    std::vector<char> mark(nc, 0);
    std::vector<int> list;
    const int* table = surf.patch_cvs.data();
    for (int l = 0; l < nl; ++l) {
      const int i = first_vertex[l];
      const auto* h = surf.handle(face[i], st(i, 0), st(i, 1));
      const int* cvs = table + begin[i];
      const int k = surf.patches->GetPatchVertices(*h).size();
      list.clear();
      for (int q = 0; q < k; ++q)
        for (int e = surf.st_off[cvs[q]]; e < surf.st_off[cvs[q] + 1]; ++e)
          if (!mark[surf.st_idx[e]]) mark[surf.st_idx[e]] = 1, list.push_back(surf.st_idx[e]);
      std::sort(list.begin(), list.end());
      for (int v : list) mark[v] = 0, sup_idx.push_back(v);
      sup_off[l + 1] = static_cast<int>(sup_idx.size());
    }
  }
  w_off.assign(nd + 1, 0);
  for (int i = 0; i < nd; ++i)
    w_off[i + 1] = w_off[i] + 3 * static_cast<int64_t>(sup_off[vsup[i] + 1] - sup_off[vsup[i]] - 1);
  w.assign(w_off[nd] + 4, 0.0f);  // padded: the kernel loads 4 floats per entry of 3
  // 3. Per vertex: the patch basis (double) composed with the patch-point stencils, then stored
  // in single precision for every entry after the list's first (see dense_kernel).
#pragma omp parallel
  {
    std::vector<int> local(nc, -1);
    std::vector<double> acc;
#pragma omp for schedule(static)
    for (int i = 0; i < nd; ++i) {
      double wP[kMaxCvs], wS[kMaxCvs], wT[kMaxCvs];
      const int* cvs = nullptr;
      const int k = surf.basis(face[i], st(i, 0), st(i, 1), cvs, wP, wS, wT);
      const int l = vsup[i], b = sup_off[l], m = sup_off[l + 1] - b;
      for (int q = 0; q < m; ++q) local[sup_idx[b + q]] = q;
      acc.assign(3 * static_cast<size_t>(m), 0.0);
      for (int q = 0; q < k; ++q)
        for (int e = surf.st_off[cvs[q]]; e < surf.st_off[cvs[q] + 1]; ++e) {
          double* a = acc.data() + 3 * local[surf.st_idx[e]];
          const double sw = surf.st_w[e];
          a[0] += wP[q] * sw, a[1] += wS[q] * sw, a[2] += wT[q] * sw;
        }
      float* out = w.data() + w_off[i];
      for (int q = 1; q < m; ++q)
        for (int d = 0; d < 3; ++d) *out++ = static_cast<float>(acc[3 * q + d]);
      for (int q = 0; q < m; ++q) local[sup_idx[b + q]] = -1;
    }
  }
}

namespace {

// Bind the points V to the limit surface for control positions X: closest points seeded by the
// nearest limit sample (a (2^level+1)-per-edge grid on every face), then Gauss-Newton.
// `home` (optional, per point): the control vertex the point was merged into by the decimation.
void bind_points(Multires::Impl& m, const MatX3d& X, const MatX3d& V, int iterations, bool warm_start,
                 Progress& progress, double f0, double f1, const std::vector<int>* home = nullptr) {
  const LimitSurface& L = m.surf;
  MatX4d P;
  L.points_exact(X, P);
  const int nd = static_cast<int>(V.rows());
  if (!warm_start) {
    const int N = 1 << std::min(m.level, 3);
    const int per_face = (N + 1) * (N + 2) / 2;
    const int nf = static_cast<int>(L.F.rows());
    MatX3d samples(static_cast<Eigen::Index>(nf) * per_face, 3);
    std::vector<Loc> sample_loc(samples.rows());
#pragma omp parallel for schedule(static)
    for (int f = 0; f < nf; ++f) {
      int k = f * per_face;
      for (int i = 0; i <= N; ++i)
        for (int j = 0; i + j <= N; ++j, ++k) {
          const Loc l{f, double(i) / N, double(j) / N};
          Vec3 S, Ss, St;
          if (!L.eval(P, l, S, Ss, St)) S = X.row(L.F(f, 0)).transpose();
          samples.row(k) = S.transpose();
          sample_loc[k] = l;
        }
    }
    progress(f0 + 0.15 * (f1 - f0));
    const KdTree tree(samples);
    m.face.resize(nd);
    m.st.resize(nd, 2);
    const Topology& topo = L.topo;
    parallel_blocks(nd, progress, f0 + 0.2 * (f1 - f0), f0 + 0.4 * (f1 - f0), [&](int i) {
      const Vec3 x = V.row(i).transpose();
      int s = tree.nearest(x);
      // The nearest sample can lie on another part of the surface that touches this one (the
      // camel's front legs, which the closest-point walk then never leaves): a seed whose face has
      // no corner within two rings of the point's own control vertex is replaced by the nearest
      // sample on the faces around that vertex and its ring.
      const int h = home && s >= 0 ? (*home)[i] : -1;
      if (h >= 0) {
        const int f = sample_loc[s].f;
        auto near2 = [&](int c) {
          if (c == h) return true;
          for (int k = topo.vv_offset[h]; k < topo.vv_offset[h + 1]; ++k) {
            const int a = topo.vv_index[k];
            if (a == c) return true;
            for (int q = topo.vv_offset[a]; q < topo.vv_offset[a + 1]; ++q)
              if (topo.vv_index[q] == c) return true;
          }
          return false;
        };
        if (!near2(L.F(f, 0)) && !near2(L.F(f, 1)) && !near2(L.F(f, 2))) {
          double best = std::numeric_limits<double>::infinity();
          auto faces_of = [&](int c) {
            for (int q = topo.vf_offset[c]; q < topo.vf_offset[c + 1]; ++q) {
              const int g = topo.vf_index[q];
              for (int k = g * per_face; k < (g + 1) * per_face; ++k) {
                const double d2 = (samples.row(k).transpose() - x).squaredNorm();
                if (d2 < best) best = d2, s = k;
              }
            }
          };
          faces_of(h);
          for (int k = topo.vv_offset[h]; k < topo.vv_offset[h + 1]; ++k) faces_of(topo.vv_index[k]);
        }
      }
      const Loc l = sample_loc[std::max(0, s)];
      m.face[i] = l.f;
      m.st(i, 0) = l.s;
      m.st(i, 1) = l.t;
    });
  }
  parallel_blocks(nd, progress, f0 + 0.4 * (f1 - f0), f1, [&](int i) {
    const Loc l = L.project(P, V.row(i).transpose(), Loc{m.face[i], m.st(i, 0), m.st(i, 1)}, iterations);
    m.face[i] = l.f;
    m.st(i, 0) = l.s;
    m.st(i, 1) = l.t;
  });
}

// Rows of the limit matrix (positions over control vertices) for the dense vertices `rows`.
SpMatR limit_rows(const LimitSurface& L, const VecXi& face, const MatX2d& st, const std::vector<int>& rows) {
  const int nr = static_cast<int>(rows.size());
  const int nt = std::max(1, num_threads());
  std::vector<std::vector<int>> cols(nt);
  std::vector<std::vector<double>> vals(nt);
  std::vector<int> row_nnz(nr, 0);
  std::vector<int> chunk_begin(nt + 1);
  for (int t = 0; t <= nt; ++t) chunk_begin[t] = static_cast<int>(static_cast<int64_t>(nr) * t / nt);
    // One contiguous chunk of rows per task, each with its own output lists (concatenated in order).
#pragma omp parallel for schedule(static, 1)
  for (int t = 0; t < nt; ++t) {
    std::vector<double> acc(L.n_control, 0.0);
    std::vector<int> touched;
    double wP[kMaxCvs], wS[kMaxCvs], wT[kMaxCvs];
    for (int r = chunk_begin[t]; r < chunk_begin[t + 1]; ++r) {
      const int i = rows[r];
      const int* cvs = nullptr;
      const int k = L.basis(face[i], st(i, 0), st(i, 1), cvs, wP, wS, wT);
      touched.clear();
      auto add = [&](int c, double w) {
        if (acc[c] == 0.0) touched.push_back(c);
        acc[c] += w;
        if (acc[c] == 0.0) acc[c] = 1e-300;  // keep it marked as touched
      };
      for (int j = 0; j < k; ++j) {
        const int c = cvs[j];
        for (int q = L.st_off[c]; q < L.st_off[c + 1]; ++q) add(L.st_idx[q], wP[j] * L.st_w[q]);
      }
      std::sort(touched.begin(), touched.end());
      for (int c : touched) {
        cols[t].push_back(c);
        vals[t].push_back(acc[c]);
        acc[c] = 0.0;
      }
      row_nnz[r] = static_cast<int>(touched.size());
    }
  }
  SpMatR W(nr, L.n_control);
  std::vector<int64_t> start(nr + 1, 0);
  for (int r = 0; r < nr; ++r) start[r + 1] = start[r] + row_nnz[r];
  W.resizeNonZeros(start[nr]);
  int64_t pos = 0;
  for (int t = 0; t < nt; ++t)
    for (size_t q = 0; q < cols[t].size(); ++q, ++pos) {
      W.innerIndexPtr()[pos] = cols[t][q];
      W.valuePtr()[pos] = vals[t][q];
    }
  for (int r = 0; r <= nr; ++r) W.outerIndexPtr()[r] = static_cast<int>(start[r]);
  return W;
}

// [LMH00]'s fit: control positions whose limit surface passes closest (least squares) to the dense
// vertices at their base points, with a weak pull towards the current positions X0.
MatX3d fit_control(const Multires::Impl& m, const MatX3d& X0, const MatX3d& V, double reg) {
  const int nd = static_cast<int>(V.rows());
  // At most ~40 samples per control vertex: plenty for the fit and keeps the normal equations cheap.
  const int stride = std::max(1, nd / std::max(1, 40 * m.surf.n_control));
  std::vector<int> rows;
  rows.reserve(nd / stride + 1);
  for (int i = 0; i < nd; i += stride) rows.push_back(i);
  const SpMatR Wr = limit_rows(m.surf, m.face, m.st, rows);
  const SpMat W = Wr;  // column major for the normal equations
  SpMat A = SpMat(W.transpose()) * W;
  MatX3d Vr(rows.size(), 3);
  for (size_t r = 0; r < rows.size(); ++r) Vr.row(r) = V.row(rows[r]);
  Eigen::MatrixXd B = W.transpose() * Vr;
  const double mu = reg * A.diagonal().sum() / std::max<Eigen::Index>(1, A.rows());
  for (int c = 0; c < A.rows(); ++c) A.coeffRef(c, c) += mu;
  B += mu * X0;
  SparseSolver solver;
  solver.factor(A, SparseSolver::Kind::Cholesky);
  const Eigen::MatrixXd X = solver.solve(B);
  if (!X.allFinite()) throw SolverError("the control-mesh fit produced non-finite positions");
  return X;
}

// The fit may not make the control mesh cross itself where the positions before it (X0) did not: on a
// thin tube decimated to few faces the least-squares fit lets neighbouring control vertices swing
// through each other (skeletal_speed's 45K capsule on 1000 control faces: 5280 crossing pairs after the
// fit, none before; a pose then folds the dense mesh there). Around each crossing pair (its faces'
// vertices and one ring more) the fit's step is halved, until no pair is left that X0 did not have
// (at most kUncrossRounds rounds; then those vertices keep X0). Elsewhere the fit is kept whole.
MatX3d uncross_fit(const MatX3i& F, const MatX3d& X0, const MatX3d& X) {
  constexpr int kUncrossRounds = 8;
  const SelfIntersectionTree tree(X0, F);
  const auto before = tree.pairs(X0);
  const auto fresh = [&](const MatX3d& Y) {
    auto p = tree.pairs(Y);
    p.erase(std::remove_if(p.begin(), p.end(),
                           [&](const auto& q) { return std::binary_search(before.begin(), before.end(), q); }),
            p.end());
    return p;
  };
  VecXd step = VecXd::Ones(X.rows());
  MatX3d Y = X;
  std::vector<char> near(X.rows());
  for (int round = 0; round <= kUncrossRounds; ++round) {
    const auto pairs = fresh(Y);
    if (pairs.empty()) return Y;
    std::fill(near.begin(), near.end(), 0);
    for (const auto& [a, b] : pairs)
      for (int f : {a, b})
        for (int c = 0; c < 3; ++c) near[F(f, c)] = 1;
    std::vector<char> ring = near;
    for (int f = 0; f < F.rows(); ++f)
      if (near[F(f, 0)] || near[F(f, 1)] || near[F(f, 2)])
        for (int c = 0; c < 3; ++c) ring[F(f, c)] = 1;
    for (int i = 0; i < X.rows(); ++i)
      if (ring[i]) {
        step[i] = round == kUncrossRounds ? 0.0 : 0.5 * step[i];
        Y.row(i) = X0.row(i) + step[i] * (X.row(i) - X0.row(i));
      }
  }
  return Y;
}

// Displacement coefficients (a, b, c) of V in the frames of the base points (the frames of the
// reconstruction kernel itself, so that the rest pose reconstructs to rounding).
void compute_displacements(Multires::Impl& m, const MatX3d& V) {
  std::vector<double> X4;
  m.load_control(m.control_V, X4);
  const int nd = m.n();
  std::vector<double> frames(12 * static_cast<size_t>(nd));
  m.run_dense(X4.data(), nullptr, frames.data());
  m.disp.resize(nd, 3);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < nd; ++i) {
    const double* f = &frames[12 * static_cast<size_t>(i)];
    const Eigen::Map<const Vec3> S(f), t1(f + 3), t2(f + 6), n(f + 9);
    const Vec3 d = V.row(i).transpose() - S;
    m.disp.row(i) << d.dot(t1), d.dot(t2), d.dot(n);
  }
}

void check_level(int level) {
  if (level < 1 || level > kMaxLevel)
    throw MeshError("level must be between 1 and " + std::to_string(kMaxLevel) + ", got " + std::to_string(level));
}

}  // namespace

Multires Multires::build(const Mesh& dense, const MultiresOptions& opt, const ProgressFn& progress_fn) {
  check_level(opt.level);
  if (opt.control_faces < 4) throw MeshError("control_faces must be at least 4");
  if (opt.fit_iterations < 0) throw MeshError("fit_iterations must be >= 0");
  if (!(opt.fit_regularization > 0)) throw MeshError("fit_regularization must be > 0");
  if (opt.projection_iterations < 0) throw MeshError("projection_iterations must be >= 0");
  Progress progress(progress_fn);
  progress(0.0);
  detail::Stopwatch stopwatch;

  // 1. Control mesh: quadric decimation, manifold and topology preserving, sliver guard.
  DecimateOptions dopt;
  dopt.target_faces = opt.control_faces;
  dopt.min_quality = opt.min_quality;
  dopt.preserve_boundary = false;  // the boundary may coarsen too (held by constraint planes)
  const ProgressFn sub = progress_fn ? ProgressFn([&](double x) { return progress_fn(0.35 * x); }) : ProgressFn();
  DecimateResult dec = decimate(dense, dopt, sub);
  try {
    validate(dec.V, dec.F, kSurface | kNoLooseVertices);
  } catch (const MeshError& e) {
    throw MeshError(std::string("the decimated control mesh is not usable: ") + e.what());
  }
  progress(0.35);

  auto impl = std::make_shared<Impl>();
  Impl& m = *impl;
  m.timings.decimate = stopwatch.lap();
  m.level = opt.level;
  m.control_V = std::move(dec.V);
  m.surf.init(dec.F, static_cast<int>(m.control_V.rows()), opt.level);
  m.timings.surface = stopwatch.lap();
  progress(0.4);

  // 2. Bind, fit, re-bind (warm started from the previous base points).
  const int rounds = opt.fit_iterations;
  const double span = 0.55 / (1 + rounds);
  bind_points(m, m.control_V, dense.V, opt.projection_iterations, false, progress, 0.4, 0.4 + span, &dec.vertex_map);
  m.timings.bind = stopwatch.lap();
  for (int r = 0; r < rounds; ++r) {
    m.control_V = uncross_fit(m.surf.F, m.control_V, fit_control(m, m.control_V, dense.V, opt.fit_regularization));
    m.timings.fit += stopwatch.lap();
    const double f0 = 0.4 + span * (r + 1);
    bind_points(m, m.control_V, dense.V, opt.projection_iterations, true, progress, f0, f0 + span);
    m.timings.bind += stopwatch.lap();
  }
  // 3. Stencils and displacements.
  m.compute_weights();
  compute_displacements(m, dense.V);
  m.timings.stencils = stopwatch.lap();
  progress(1.0);
  return Multires(std::move(impl));
}

Multires Multires::build(const MatX3d& V, const MatX3i& F, const MultiresOptions& opt, const ProgressFn& progress) {
  const Mesh mesh = make_mesh(V, F, kSurface);
  return build(mesh, opt, progress);
}

Multires Multires::bind(const MatX3d& control_V, const MatX3i& control_F, const MatX3d& V, int level,
                        const ProgressFn& progress_fn, int projection_iterations) {
  check_level(level);
  if (projection_iterations < 0) throw MeshError("projection_iterations must be >= 0");
  try {
    validate(control_V, control_F, kSurface | kNoLooseVertices);
  } catch (const MeshError& e) {
    throw MeshError(std::string("control mesh: ") + e.what());
  }
  validate_points(V);
  Progress progress(progress_fn);
  progress(0.0);
  auto impl = std::make_shared<Impl>();
  Impl& m = *impl;
  m.level = level;
  m.control_V = control_V;
  m.surf.init(control_F, static_cast<int>(control_V.rows()), level);
  bind_points(m, m.control_V, V, projection_iterations, false, progress, 0.1, 0.95);
  m.compute_weights();
  compute_displacements(m, V);
  progress(1.0);
  return Multires(std::move(impl));
}

Multires Multires::from_data(const MultiresData& d) {
  check_level(d.level);
  try {
    validate(d.control_V, d.control_F, kSurface | kNoLooseVertices);
  } catch (const MeshError& e) {
    throw MeshError(std::string("multires data: control mesh: ") + e.what());
  }
  const Eigen::Index nd = d.face.size();
  if (d.st.rows() != nd || d.disp.rows() != nd)
    throw MeshError("multires data: face, st and disp must have one row per dense vertex (" + std::to_string(nd) +
                    ", " + std::to_string(d.st.rows()) + ", " + std::to_string(d.disp.rows()) + ")");
  const int nf = static_cast<int>(d.control_F.rows());
  for (Eigen::Index i = 0; i < nd; ++i) {
    if (d.face[i] < 0 || d.face[i] >= nf)
      throw MeshError("multires data: base face " + std::to_string(d.face[i]) + " of vertex " + std::to_string(i) +
                      " is out of range");
    const double s = d.st(i, 0), t = d.st(i, 1);
    if (!(s >= -1e-9 && t >= -1e-9 && s + t <= 1 + 1e-9))
      throw MeshError("multires data: (s, t) of vertex " + std::to_string(i) + " lies outside its triangle");
  }
  if (!d.disp.allFinite()) throw MeshError("multires data: displacements contain NaN or infinite values");
  auto impl = std::make_shared<Impl>();
  Impl& m = *impl;
  m.level = d.level;
  m.control_V = d.control_V;
  m.surf.init(d.control_F, static_cast<int>(d.control_V.rows()), d.level);
  m.face = d.face;
  m.st = d.st;
  m.disp = d.disp;
  m.compute_weights();
  return Multires(std::move(impl));
}

MultiresData Multires::data() const {
  MultiresData d;
  d.control_V = impl_->control_V;
  d.control_F = impl_->surf.F;
  d.level = impl_->level;
  d.face = impl_->face;
  d.st = impl_->st;
  d.disp = impl_->disp;
  return d;
}

int Multires::n_dense() const { return impl_->n(); }
int Multires::n_control() const { return impl_->surf.n_control; }
int Multires::level() const { return impl_->level; }
const MatX3d& Multires::control_vertices() const { return impl_->control_V; }
const MatX3i& Multires::control_faces() const { return impl_->surf.F; }
const VecXi& Multires::base_face() const { return impl_->face; }
const MatX2d& Multires::base_st() const { return impl_->st; }
const MatX3d& Multires::displacement() const { return impl_->disp; }
int Multires::n_patch_points() const { return impl_->surf.n_points; }
const MultiresTimings& Multires::timings() const { return impl_->timings; }

size_t Multires::memory_bytes() const {
  const Impl& m = *impl_;
  return m.surf.memory_bytes() + (m.sup_off.size() + m.sup_idx.size() + m.vsup.size()) * sizeof(int) +
         m.w_off.size() * sizeof(int64_t) + m.w.size() * sizeof(float) +
         static_cast<size_t>(m.n()) * (sizeof(int) + 5 * sizeof(double));
}

namespace {
// Per-thread copy of the control vertices (4 doubles per row): no allocation per pose.
std::vector<double>& control_scratch() {
  thread_local std::vector<double> X4;
  return X4;
}
}  // namespace

void Multires::reconstruct(const Eigen::Ref<const MatX3d>& X, Eigen::Ref<MatX3d> out) const {
  const Impl& m = *impl_;
  const int nd = m.n();
  if (out.rows() != nd) throw MeshError("reconstruct: the output needs " + std::to_string(nd) + " rows");
  std::vector<double>& X4 = control_scratch();
  m.load_control(X, X4);
  // x_i = S + a t1 + b t2 + c n in the deformed frame.
  if (out.outerStride() == 3) {
    m.run_dense(X4.data(), m.disp.data(), out.data());
  } else {
    MatX3d tmp(nd, 3);
    m.run_dense(X4.data(), m.disp.data(), tmp.data());
    out = tmp;
  }
}

void Multires::reconstruct(const Eigen::Ref<const MatX3d>& X, Eigen::Ref<MatX3f> out) const {
  const Impl& m = *impl_;
  const int nd = m.n();
  if (out.rows() != nd) throw MeshError("reconstruct: the output needs " + std::to_string(nd) + " rows");
  std::vector<double>& X4 = control_scratch();
  m.load_control(X, X4);
  if (out.outerStride() == 3) {
    m.run_dense(X4.data(), m.disp.data(), nullptr, out.data());
  } else {
    MatX3f tmp(nd, 3);
    m.run_dense(X4.data(), m.disp.data(), nullptr, tmp.data());
    out = tmp;
  }
}

MatX3d Multires::reconstruct(const MatX3d& X) const {
  MatX3d out(n_dense(), 3);
  reconstruct(X, Eigen::Ref<MatX3d>(out));
  return out;
}

void Multires::limit_points(const MatX3d& X, MatX3d& points, MatX3d* normals) const {
  const Impl& m = *impl_;
  std::vector<double> X4;
  m.load_control(X, X4);
  const int nd = m.n();
  std::vector<double> frames(12 * static_cast<size_t>(nd));
  m.run_dense(X4.data(), nullptr, frames.data());
  points.resize(nd, 3);
  if (normals) normals->resize(nd, 3);
  for (int i = 0; i < nd; ++i) {
    const double* f = &frames[12 * static_cast<size_t>(i)];
    points.row(i) << f[0], f[1], f[2];
    if (normals) normals->row(i) << f[9], f[10], f[11];
  }
}

void Multires::evaluate(const MatX3d& X, const VecXi& face, const MatX2d& st, MatX3d& P, MatX3d* Ds, MatX3d* Dt) const {
  const Impl& m = *impl_;
  {
    std::vector<double> X4;
    m.load_control(X, X4);  // validates
  }
  const Eigen::Index n = face.size();
  if (st.rows() != n) throw MeshError("evaluate: face and st must have the same number of rows");
  for (Eigen::Index i = 0; i < n; ++i) {
    if (face[i] < 0 || face[i] >= m.surf.F.rows()) throw MeshError("evaluate: face out of range");
    if (!(st(i, 0) >= 0 && st(i, 1) >= 0 && st(i, 0) + st(i, 1) <= 1 + 1e-12))
      throw MeshError("evaluate: (s, t) must satisfy s, t >= 0, s + t <= 1");
  }
  MatX4d pts;
  m.surf.points_exact(X, pts);
  P.resize(n, 3);
  if (Ds) Ds->resize(n, 3);
  if (Dt) Dt->resize(n, 3);
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) {
    Vec3 S, Ss, St;
    m.surf.eval(pts, Loc{face[i], st(i, 0), st(i, 1)}, S, Ss, St);  // a patch covers every face
    P.row(i) = S.transpose();
    if (Ds) Ds->row(i) = Ss.transpose();
    if (Dt) Dt->row(i) = St.transpose();
  }
}

SpMatR Multires::limit_matrix() const {
  std::vector<int> rows(n_dense());
  for (int i = 0; i < n_dense(); ++i) rows[i] = i;
  return limit_rows(impl_->surf, impl_->face, impl_->st, rows);
}

}  // namespace dgmesh
