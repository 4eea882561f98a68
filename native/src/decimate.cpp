#include "dgmesh/decimate.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#include "dgmesh/detail/math.h"
#include "dgmesh/errors.h"

namespace dgmesh {

namespace {

// Symmetric 4x4 quadric, upper triangle: a2 ab ac ad b2 bc bd c2 cd d2.
struct Quadric {
  double q[10] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0};

  static Quadric plane(const Vec3& n, double d, double w) {
    Quadric Q;
    const double a = n.x(), b = n.y(), c = n.z();
    Q.q[0] = w * a * a, Q.q[1] = w * a * b, Q.q[2] = w * a * c, Q.q[3] = w * a * d;
    Q.q[4] = w * b * b, Q.q[5] = w * b * c, Q.q[6] = w * b * d;
    Q.q[7] = w * c * c, Q.q[8] = w * c * d, Q.q[9] = w * d * d;
    return Q;
  }
  Quadric& operator+=(const Quadric& o) {
    for (int i = 0; i < 10; ++i) q[i] += o.q[i];
    return *this;
  }
  friend Quadric operator+(Quadric a, const Quadric& b) { return a += b; }
  double eval(const Vec3& p) const {
    const double x = p.x(), y = p.y(), z = p.z();
    return q[0] * x * x + 2 * q[1] * x * y + 2 * q[2] * x * z + 2 * q[3] * x + q[4] * y * y + 2 * q[5] * y * z +
           2 * q[6] * y + q[7] * z * z + 2 * q[8] * z + q[9];
  }
  // The minimiser when the 3x3 part is well conditioned.
  bool optimum(Vec3& p) const {
    const double a = q[0], b = q[1], c = q[2], d = q[4], e = q[5], f = q[7];
    // Cofactors of [[a b c] [b d e] [c e f]].
    const double A = d * f - e * e, B = c * e - b * f, C = b * e - c * d;
    const double det = a * A + b * B + c * C;
    const double tr = a + d + f;
    if (!(std::abs(det) > 1e-9 * tr * tr * tr)) return false;
    const double D = a * f - c * c, E = b * c - a * e, G = a * d - b * b;
    const double r0 = -q[3], r1 = -q[6], r2 = -q[8];
    p = Vec3(A * r0 + B * r1 + C * r2, B * r0 + D * r1 + E * r2, C * r0 + E * r1 + G * r2) / det;
    return p.allFinite();
  }
};

// A queued edge; the collapse removes one of its ends (chosen when it is evaluated). The vertex
// stamps at queuing time invalidate it lazily once either end changes.
struct Rec {
  int a, b;
  uint32_t sa, sb;
};

// Heap key: the cost as float bits (monotone for non-negative floats) above the record index, so
// the heap moves and compares plain 64-bit integers (a third of the traffic of a struct entry).
inline uint64_t heap_key(double cost, uint32_t rec) {
  const float c = static_cast<float>(cost);
  uint32_t bits;
  std::memcpy(&bits, &c, sizeof bits);
  return (static_cast<uint64_t>(bits) << 32) | rec;
}

struct Candidate {
  double cost;
  int remove, keep;
  Vec3 p;
};

// Squared triangle quality (4 sqrt(3) A / (l0^2 + l1^2 + l2^2))^2 from the squared normal length
// |n|^2 = (2A)^2: no square root in the collapse test.
inline double quality2(const Vec3& a, const Vec3& b, const Vec3& c, double n2) {
  const double l = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  return l > 0 ? 12.0 * n2 / (l * l) : 0.0;
}

class Decimator {
 public:
  Decimator(const Mesh& m, const DecimateOptions& o) : mesh_(m), opt_(o) {}

  DecimateResult run(const ProgressFn& progress_fn);

 private:
  const Mesh& mesh_;
  const DecimateOptions& opt_;
  MatX3d V_;
  MatX3i F_;
  std::vector<Quadric> Q_;
  std::vector<char> face_alive_, vert_alive_, boundary_, fixed_;
  std::vector<uint32_t> stamp_;
  std::vector<int> parent_;
  // Faces around each vertex: refs_[start_[v] .. start_[v] + count_[v]); a merged vertex gets a
  // fresh list appended at the end, compacted when the array has grown too much.
  std::vector<int> start_, count_, refs_;
  std::vector<int> mark_;
  int mark_id_ = 0;
  std::vector<int> nbr_, tmp_faces_;
  // Faces a candidate collapse moves: corners after the collapse, normals before and after.
  struct Moved {
    int f, c[3];
    Vec3 n0, n1;
  };
  std::vector<Moved> moved_;
  std::vector<Rec> recs_;
  // 4-ary min-heap of heap_key: half the depth of a binary heap, and the four children of a node
  // share a cache line, which matters because most pops are stale entries.
  std::vector<uint64_t> heap_;
  int n_faces_ = 0;
  double cos_max_ = 0.0, cos_max2_ = 0.0, min_q2_ = 0.0;

  void push(double cost, int a, int b) {
    const uint64_t key = heap_key(cost, static_cast<uint32_t>(recs_.size()));
    recs_.push_back({a, b, stamp_[a], stamp_[b]});
    size_t i = heap_.size();
    heap_.push_back(key);
    while (i > 0) {
      const size_t parent = (i - 1) / 4;
      if (heap_[parent] <= key) break;
      heap_[i] = heap_[parent];
      i = parent;
    }
    heap_[i] = key;
  }
  void sift_down(size_t i) {
    const size_t n = heap_.size();
    const uint64_t key = heap_[i];
    for (;;) {
      const size_t c = 4 * i + 1;
      if (c >= n) break;
      size_t best = c;
      const size_t end = std::min(n, c + 4);
      for (size_t j = c + 1; j < end; ++j)
        if (heap_[j] < heap_[best]) best = j;
      if (heap_[best] >= key) break;
      heap_[i] = heap_[best];
      i = best;
    }
    heap_[i] = key;
  }
  uint64_t pop() {
    const uint64_t top = heap_[0];
    heap_[0] = heap_.back();
    heap_.pop_back();
    if (!heap_.empty()) sift_down(0);
    return top;
  }

  int next_mark() {
    if (++mark_id_ == INT32_MAX) std::fill(mark_.begin(), mark_.end(), 0), mark_id_ = 1;
    return mark_id_;
  }
  // Distinct neighbours of v (via its alive faces) into `out`.
  void neighbours(int v, std::vector<int>& out) {
    out.clear();
    const int id = next_mark();
    mark_[v] = id;
    for (int j = start_[v]; j < start_[v] + count_[v]; ++j) {
      const int f = refs_[j];
      for (int k = 0; k < 3; ++k) {
        const int w = F_(f, k);
        if (mark_[w] != id) mark_[w] = id, out.push_back(w);
      }
    }
  }
  Candidate evaluate(int a, int b) const;
  bool try_collapse(const Candidate& c);
  bool no_new_folds(int u, int v) const;
  void push_edges_of(int v);
  int run_batched(Progress& progress, int to_remove);
  void compact_refs();
};

Candidate Decimator::evaluate(int a, int b) const {
  Candidate c;
  const Quadric Q = Q_[a] + Q_[b];
  const Vec3 pa = V_.row(a), pb = V_.row(b);
  // Fixed vertices (locked, or on a preserved boundary) neither move nor go; else a boundary end
  // stays where it is, so the boundary keeps its shape.
  const char* stay = fixed_[a] != fixed_[b] ? fixed_.data() : boundary_.data();
  if (stay[a] != stay[b]) {
    c.keep = stay[a] ? a : b;
    c.remove = stay[a] ? b : a;
    c.p = stay[a] ? pa : pb;
    c.cost = Q.eval(c.p);
    return c;
  }
  c.keep = a, c.remove = b;
  if (fixed_[a]) {
    c.p = pa, c.cost = std::numeric_limits<double>::infinity();
    return c;
  }
  // Optimal placement (GH97 sec. 4): with a positive definite 3x3 part it is the global minimum,
  // so the ends and the midpoint need not be tried. Far-away optima (nearly singular quadrics)
  // fall back to the best of the ends and the midpoint.
  const Vec3 mid = 0.5 * (pa + pb);
  Vec3 opt;
  if (Q.optimum(opt) && (opt - mid).squaredNorm() <= 4 * (pa - pb).squaredNorm()) {
    c.p = opt;
    c.cost = std::max(0.0, Q.eval(opt));
    return c;
  }
  Vec3 best = pa;
  double cost = Q.eval(pa);
  for (const Vec3& p : {pb, mid}) {
    const double e = Q.eval(p);
    if (e < cost) cost = e, best = p;
  }
  c.p = best;
  c.cost = std::max(0.0, cost);
  return c;
}

void Decimator::push_edges_of(int v) {
  neighbours(v, nbr_);
  for (int w : nbr_) {
    if (w == v) continue;
    const Candidate c = evaluate(v, w);
    if (std::isfinite(c.cost)) push(c.cost, v, w);
  }
}

bool Decimator::try_collapse(const Candidate& c) {
  const int u = c.remove, v = c.keep;
  // Shared faces (1 on a boundary edge, 2 inside) and their opposite vertices.
  int shared = 0, opp[2] = {-1, -1};
  for (int j = start_[u]; j < start_[u] + count_[u]; ++j) {
    const int f = refs_[j];
    if (F_(f, 0) == v || F_(f, 1) == v || F_(f, 2) == v) {
      if (shared == 2) return false;
      opp[shared++] = F_(f, 0) + F_(f, 1) + F_(f, 2) - u - v;
    }
  }
  if (shared == 0) return false;
  // An interior edge between two boundary vertices would pinch the surface.
  if (shared == 2 && boundary_[u] && boundary_[v]) return false;
  // Link condition: the common neighbours of u and v are exactly the opposite vertices.
  {
    const int id = next_mark();
    for (int j = start_[u]; j < start_[u] + count_[u]; ++j)
      for (int k = 0; k < 3; ++k) mark_[F_(refs_[j], k)] = id;
    const int seen = next_mark();
    int common = 0;
    for (int j = start_[v]; j < start_[v] + count_[v]; ++j)
      for (int k = 0; k < 3; ++k) {
        const int w = F_(refs_[j], k);
        if (w == u || w == v) continue;
        if (mark_[w] == id) ++common, mark_[w] = seen;
      }
    if (common != shared) return false;
  }
  // Opposite vertices keep a valid fan: an interior one needs at least 3 faces left.
  for (int s = 0; s < shared; ++s) {
    const int w = opp[s];
    if (count_[w] - 1 < (boundary_[w] ? 1 : 3)) return false;
  }
  if (count_[u] + count_[v] - 2 * shared < (shared == 1 ? 1 : 3)) return false;
  // Geometry guards on every face that survives and moves.
  moved_.clear();
  double before = std::numeric_limits<double>::infinity(), after = before;  // worst quality around (squared)
  for (int side = 0; side < 2; ++side) {
    const int x = side ? v : u;
    for (int j = start_[x]; j < start_[x] + count_[x]; ++j) {
      const int f = refs_[j];
      int k = 0;
      bool has_other = false;
      for (int i = 0; i < 3; ++i) {
        if (F_(f, i) == x) k = i;
        if (F_(f, i) == (side ? u : v)) has_other = true;
      }
      const Vec3 a = V_.row(F_(f, 0)), b = V_.row(F_(f, 1)), cc = V_.row(F_(f, 2));
      const Vec3 n0 = (b - a).cross(cc - a);
      const double s0 = n0.squaredNorm();
      if (min_q2_ > 0) before = std::min(before, quality2(a, b, cc, s0));
      if (has_other) continue;  // removed by the collapse
      Vec3 na = a, nb = b, nc = cc;
      (k == 0 ? na : k == 1 ? nb : nc) = c.p;
      const Vec3 n1 = (nb - na).cross(nc - na);
      const double s1 = n1.squaredNorm(), dot = n0.dot(n1);
      if (!(s1 > 0)) return false;
      // Normal turn beyond max_normal_angle, compared squared (no roots) when the limit is acute.
      if (cos_max_ >= 0 ? (dot <= 0 || dot * dot < cos_max2_ * s0 * s1) : dot < cos_max_ * std::sqrt(s0 * s1))
        return false;
      // Never create (near) degenerate faces: quality 1e-3 is an aspect ratio of about 1000.
      const double q1 = quality2(na, nb, nc, s1);
      if (q1 < 1e-6) return false;
      after = std::min(after, q1);
      Moved m{f, {F_(f, 0), F_(f, 1), F_(f, 2)}, n0, n1};
      m.c[k] = v;
      // No face with its three corners on one mirror plane (DecimateOptions::planes).
      if (!opt_.planes.empty() && (opt_.planes[m.c[0]] & opt_.planes[m.c[1]] & opt_.planes[m.c[2]])) return false;
      moved_.push_back(m);
    }
  }
  // Slivers (DecimateOptions::min_quality): the worst face around the collapse may not get worse.
  // Judged face by face instead (no face below min_quality and worse than it was), a pole's fan of
  // slivers could not be collapsed: a capsule (96 around, 30 cylinder rings, subdivided once) kept
  // 87% of a 2000-face result in its caps, and the cylinder between them became faces as long as
  // it; subdivided twice (80 around, 30 rings), its decimation stopped short of the target (4582
  // faces for 2000), every face in the caps or spanning the cylinder.
  if (after < min_q2_ && after < before) return false;
  if (!no_new_folds(u, v)) return false;

  // Collapse u into v.
  V_.row(v) = c.p.transpose();
  Q_[v] += Q_[u];
  vert_alive_[u] = 0;
  parent_[u] = v;
  ++stamp_[u];
  ++stamp_[v];
  tmp_faces_.clear();
  for (int j = start_[v]; j < start_[v] + count_[v]; ++j) {
    const int f = refs_[j];
    if (F_(f, 0) == u || F_(f, 1) == u || F_(f, 2) == u) {
      face_alive_[f] = 0;
      --n_faces_;
      // The opposite vertex loses this face.
      const int w = F_(f, 0) + F_(f, 1) + F_(f, 2) - u - v;
      int* b = &refs_[start_[w]];
      int* e = b + count_[w];
      int* it = std::find(b, e, f);
      if (it != e) *it = *(e - 1), --count_[w];
    } else {
      tmp_faces_.push_back(f);
    }
  }
  for (int j = start_[u]; j < start_[u] + count_[u]; ++j) {
    const int f = refs_[j];
    if (!face_alive_[f]) continue;
    for (int k = 0; k < 3; ++k)
      if (F_(f, k) == u) F_(f, k) = v;
    tmp_faces_.push_back(f);
  }
  count_[u] = 0;
  if (refs_.size() + tmp_faces_.size() > refs_.capacity()) compact_refs();
  start_[v] = static_cast<int>(refs_.size());
  count_[v] = static_cast<int>(tmp_faces_.size());
  refs_.insert(refs_.end(), tmp_faces_.begin(), tmp_faces_.end());
  if (!opt_.batched) push_edges_of(v);
  return true;
}

// A fold is a dihedral angle beyond 120 degrees (unit normals' dot below -1/2). The per-face turn
// limit alone lets folds build up over many collapses at extreme ratios, e.g. around locked seams;
// refuse a collapse that creates a fold or sharpens one across any edge of the faces it moves.
constexpr double kCosSmallTurn = 0.99863;  // cos 3 degrees

bool Decimator::no_new_folds(int u, int v) const {
  auto fold = [](const Vec3& a, const Vec3& b) {
    const double d = a.dot(b), s = a.squaredNorm() * b.squaredNorm();
    return d < 0 && d * d > 0.25 * s ? d / std::sqrt(s) : 1.0;  // cosine when folded, else 1
  };
  for (const Moved& m : moved_) {
    for (int e = 0; e < 3; ++e) {
      const int p = m.c[e], q = m.c[(e + 1) % 3];
      Vec3 g0, g1;
      bool found = false;
      if (p == v || q == v) {  // inner edge of the new fan: the neighbour moves too
        const int w = p == v ? q : p;
        for (const Moved& o : moved_)
          if (o.f != m.f && (o.c[0] == w || o.c[1] == w || o.c[2] == w)) {
            g0 = o.n0, g1 = o.n1, found = true;
            break;
          }
      } else if (m.n0.dot(m.n1) < kCosSmallTurn * std::sqrt(m.n0.squaredNorm() * m.n1.squaredNorm())) {
        // Link edge: the neighbour is a face around p that the collapse leaves alone. Skipped when
        // m turns less than kCosSmallTurn: it cannot fold a dihedral that was not near one already.
        for (int j = start_[p]; j < start_[p] + count_[p] && !found; ++j) {
          const int g = refs_[j];
          const int a = F_(g, 0), b = F_(g, 1), c = F_(g, 2);
          if (g == m.f || (a != q && b != q && c != q) || a == u || b == u || c == u || a == v || b == v || c == v)
            continue;
          g0 = g1 = (V_.row(b) - V_.row(a)).cross(V_.row(c) - V_.row(a)).transpose();
          found = true;
        }
      }
      if (!found) continue;  // boundary edge
      const double now = fold(m.n1, g1);
      if (now < 1.0 && now < fold(m.n0, g0) - 1e-9) return false;
    }
  }
  return true;
}

// Multiple-choice passes (after Wu and Kobbelt 2002): every live edge is costed in parallel, the
// cheapest half of the collapses still needed are sorted and taken in order, skipping edges with an
// end already merged in this pass (its cost is stale). Edges not touching a merged vertex keep
// their exact cost, so within a pass the order is the greedy one; across passes it is close to it.
// Much less random memory traffic than a global queue holding stale entries.
int Decimator::run_batched(Progress& progress, int to_remove) {
  const int nf = static_cast<int>(F_.rows()), nv = static_cast<int>(V_.rows());
  std::vector<char> touched(nv, 0);
  std::vector<std::pair<int, int>> cand;
  std::vector<uint64_t> keys;
  std::vector<int> live;
  int collapses = 0;
  while (n_faces_ > opt_.target_faces) {
    // Every live edge once: the half-edge with a < b (interior edges have both), plus boundary
    // half-edges with a > b (only when boundary vertices may move).
    cand.clear();
    live.clear();
    for (int f = 0; f < nf; ++f)
      if (face_alive_[f]) live.push_back(f);
    for (int f : live)
      for (int k = 0; k < 3; ++k) {
        const int a = F_(f, k), b = F_(f, (k + 1) % 3);
        if (a < b) {
          cand.emplace_back(a, b);
        } else if (!opt_.preserve_boundary && boundary_[a] && boundary_[b]) {
          bool reverse = false;  // is (b, a) a half-edge of another face?
          for (int j = start_[a]; j < start_[a] + count_[a] && !reverse; ++j) {
            const int g = refs_[j];
            for (int i = 0; i < 3; ++i)
              if (F_(g, i) == b && F_(g, (i + 1) % 3) == a) reverse = true;
          }
          if (!reverse) cand.emplace_back(a, b);
        }
      }
    const int n = static_cast<int>(cand.size());
    keys.resize(n);
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
      const double cost = evaluate(cand[i].first, cand[i].second).cost;
      keys[i] = std::isfinite(cost) ? heap_key(cost, static_cast<uint32_t>(i)) : ~uint64_t(0);
    }
    const size_t needed = static_cast<size_t>(std::max(1, (n_faces_ - opt_.target_faces) / 2));
    const size_t take = std::max<size_t>(needed / 2, 1);
    std::fill(touched.begin(), touched.end(), 0);
    const int before = collapses;
    // Sorted windows of the cheapest candidates until `take` collapses succeeded: refused ones
    // (link condition, flips) do not use up the pass.
    bool stop = false;
    for (size_t lo = 0;
         lo < keys.size() && !stop && size_t(collapses - before) < take && n_faces_ > opt_.target_faces;) {
      const size_t hi = std::min(keys.size(), lo + take);
      std::nth_element(keys.begin() + lo, keys.begin() + (hi - 1), keys.end());
      std::sort(keys.begin() + lo, keys.begin() + hi);
      for (size_t i = lo; i < hi && n_faces_ > opt_.target_faces; ++i) {
        if (keys[i] == ~uint64_t(0)) {
          stop = true;
          break;
        }
        const auto [a, b] = cand[static_cast<uint32_t>(keys[i])];
        if (touched[a] || touched[b]) continue;
        const Candidate c = evaluate(a, b);
        if (c.cost > opt_.max_error) {
          n_faces_ = -n_faces_ - 1;  // flag: stop after this pass (restored below)
          stop = true;
          break;
        }
        if (try_collapse(c)) {
          touched[a] = touched[b] = 1;
          if ((++collapses & 4095) == 0) progress(std::min(1.0, double(nf - n_faces_) / to_remove));
        }
      }
      lo = hi;
    }
    if (n_faces_ < 0) {
      n_faces_ = -n_faces_ - 1;
      break;
    }
    if (collapses == before) break;  // nothing collapsible left
  }
  return collapses;
}

void Decimator::compact_refs() {
  std::vector<int> fresh;
  fresh.reserve(refs_.capacity());
  for (size_t v = 0; v < start_.size(); ++v) {
    const int s = static_cast<int>(fresh.size());
    fresh.insert(fresh.end(), refs_.begin() + start_[v], refs_.begin() + start_[v] + count_[v]);
    start_[v] = s;
  }
  refs_.swap(fresh);
}

DecimateResult Decimator::run(const ProgressFn& progress_fn) {
  const Topology& topo = mesh_.topo;
  const int nv = topo.n_vertices, nf = topo.n_faces;
  if (opt_.target_faces < 0) throw MeshError("target_faces must be non-negative");
  if (opt_.face_weights.size() != 0 && opt_.face_weights.size() != nf)
    throw MeshError("face_weights has " + std::to_string(opt_.face_weights.size()) + " values for " +
                    std::to_string(nf) + " faces");
  if (opt_.face_weights.size() && !(opt_.face_weights.array() >= 0).all())
    throw MeshError("face_weights must be finite and non-negative");
  if (opt_.face_weights.size() && !opt_.face_weights.allFinite())
    throw MeshError("face_weights must be finite and non-negative");
  if (!(opt_.min_quality >= 0 && opt_.min_quality < 1)) throw MeshError("min_quality must be in [0, 1)");
  if (!opt_.planes.empty() && opt_.planes.size() != static_cast<size_t>(nv))
    throw MeshError("planes has " + std::to_string(opt_.planes.size()) + " values for " + std::to_string(nv) +
                    " vertices");
  if (!opt_.locked.empty() && opt_.locked.size() != static_cast<size_t>(nv))
    throw MeshError("locked has " + std::to_string(opt_.locked.size()) + " values for " + std::to_string(nv) +
                    " vertices");
  if (!(opt_.max_normal_angle > 0 && opt_.max_normal_angle <= detail::kPi))
    throw MeshError("max_normal_angle must be in (0, pi]");
  cos_max_ = std::cos(opt_.max_normal_angle);
  cos_max2_ = cos_max_ * cos_max_;
  min_q2_ = opt_.min_quality * opt_.min_quality;
  Progress progress(progress_fn);
  progress(0.0);

  V_ = mesh_.V;
  F_ = mesh_.F;
  n_faces_ = nf;
  face_alive_.assign(nf, 1);
  vert_alive_.assign(nv, 1);
  boundary_.assign(topo.on_boundary.begin(), topo.on_boundary.end());
  fixed_.assign(nv, 0);
  for (int v = 0; v < nv; ++v)
    fixed_[v] = (opt_.preserve_boundary && boundary_[v]) || (!opt_.locked.empty() && opt_.locked[v]);
  stamp_.assign(nv, 0);
  parent_.resize(nv);
  for (int v = 0; v < nv; ++v) parent_[v] = v;
  mark_.assign(nv, 0);
  start_.assign(topo.vf_offset.begin(), topo.vf_offset.end() - 1);
  count_.resize(nv);
  for (int v = 0; v < nv; ++v) count_[v] = topo.vf_offset[v + 1] - topo.vf_offset[v];
  refs_.reserve(2 * topo.vf_index.size() + 64);
  refs_.assign(topo.vf_index.begin(), topo.vf_index.end());

  // Vertex quadrics: the (weighted) planes of the faces around each vertex.
  Q_.assign(nv, Quadric{});
  std::vector<Quadric> face_q(nf);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    const Vec3 a = V_.row(F_(f, 0)), b = V_.row(F_(f, 1)), c = V_.row(F_(f, 2));
    const Vec3 n2 = (b - a).cross(c - a);
    const double len = n2.norm();
    if (!(len > 0)) continue;
    const Vec3 n = n2 / len;
    double w = opt_.area_weighted ? 0.5 * len : 1.0;
    if (opt_.face_weights.size()) w *= opt_.face_weights[f];
    face_q[f] = Quadric::plane(n, -n.dot(a), w);
  }
#pragma omp parallel for schedule(static)
  for (int v = 0; v < nv; ++v)
    for (int j = topo.vf_offset[v]; j < topo.vf_offset[v + 1]; ++j) Q_[v] += face_q[topo.vf_index[j]];
  if (!opt_.preserve_boundary) {
    // Planes through each boundary edge, perpendicular to its face (GH97 sec. 6).
    for (int e = 0; e < topo.n_edges(); ++e) {
      const int f = topo.edge_faces(e, 0) >= 0 && topo.edge_faces(e, 1) < 0 ? topo.edge_faces(e, 0) : -1;
      if (f < 0) continue;
      const int a = topo.edges(e, 0), b = topo.edges(e, 1);
      const Vec3 pa = V_.row(a), pb = V_.row(b);
      const Vec3 fn =
          (Vec3(V_.row(F_(f, 1))) - Vec3(V_.row(F_(f, 0)))).cross(Vec3(V_.row(F_(f, 2))) - Vec3(V_.row(F_(f, 0))));
      const Vec3 n = (pb - pa).cross(fn).normalized();
      if (!n.allFinite()) continue;
      double w = opt_.boundary_weight * (opt_.area_weighted ? (pb - pa).squaredNorm() : 1.0);
      if (opt_.face_weights.size()) w *= opt_.face_weights[f];
      const Quadric q = Quadric::plane(n, -n.dot(pa), w);
      Q_[a] += q;
      Q_[b] += q;
    }
  }
  face_q.clear();
  face_q.shrink_to_fit();

  // All edges into the heap (costs in parallel, heapified in O(n)).
  if (!opt_.batched) {
    const int ne = topo.n_edges();
    std::vector<double> cost(ne);
#pragma omp parallel for schedule(static)
    for (int e = 0; e < ne; ++e) cost[e] = evaluate(topo.edges(e, 0), topo.edges(e, 1)).cost;
    // About 7 new entries per collapse (the edges around the merged vertex), 2 faces per collapse.
    const size_t expected = ne + 4 * static_cast<size_t>(std::max(0, nf - opt_.target_faces)) + 16;
    recs_.clear();
    recs_.reserve(expected);
    heap_.clear();
    heap_.reserve(expected);
    for (int e = 0; e < ne; ++e) {
      if (!std::isfinite(cost[e])) continue;
      heap_.push_back(heap_key(cost[e], static_cast<uint32_t>(recs_.size())));
      recs_.push_back({topo.edges(e, 0), topo.edges(e, 1), 0, 0});
    }
    for (size_t i = heap_.size() / 4 + 1; i-- > 0;)
      if (i < heap_.size()) sift_down(i);
  }

  int collapses = 0;
  const int to_remove = std::max(1, nf - opt_.target_faces);
  if (opt_.batched) {
    collapses = run_batched(progress, to_remove);
    heap_.clear();
  }
  while (!opt_.batched && n_faces_ > opt_.target_faces && !heap_.empty()) {
    const Rec top = recs_[static_cast<uint32_t>(pop())];
    if (!vert_alive_[top.a] || !vert_alive_[top.b] || stamp_[top.a] != top.sa || stamp_[top.b] != top.sb) continue;
    const Candidate c = evaluate(top.a, top.b);
    if (c.cost > opt_.max_error) break;
    if (try_collapse(c)) {
      ++collapses;
      if ((collapses & 4095) == 0) progress(std::min(1.0, double(nf - n_faces_) / to_remove));
    }
  }

  // Compact the output.
  DecimateResult r;
  r.collapses = collapses;
  std::vector<int> new_index(nv, -1);
  int n_out = 0;
  for (int f = 0; f < nf; ++f)
    if (face_alive_[f])
      for (int k = 0; k < 3; ++k)
        if (new_index[F_(f, k)] < 0) new_index[F_(f, k)] = n_out++;
  // Keep the surviving vertices in input order.
  n_out = 0;
  for (int v = 0; v < nv; ++v)
    if (new_index[v] >= 0) new_index[v] = n_out++;
  r.V.resize(n_out, 3);
  r.source_vertex.resize(n_out);
  for (int v = 0; v < nv; ++v)
    if (new_index[v] >= 0) r.V.row(new_index[v]) = V_.row(v), r.source_vertex[new_index[v]] = v;
  r.F.resize(n_faces_, 3);
  r.face_map.resize(n_faces_);
  int j = 0;
  for (int f = 0; f < nf; ++f)
    if (face_alive_[f]) {
      for (int k = 0; k < 3; ++k) r.F(j, k) = new_index[F_(f, k)];
      r.face_map[j++] = f;
    }
  r.vertex_map.resize(nv);
  for (int v = 0; v < nv; ++v) {
    int w = v;
    while (parent_[w] != w) w = parent_[w];
    r.vertex_map[v] = topo.vf_offset[v] == topo.vf_offset[v + 1] ? -1 : new_index[w];
  }
  progress(1.0);
  return r;
}

}  // namespace

DecimateResult decimate(const Mesh& mesh, const DecimateOptions& opt, const ProgressFn& progress) {
  Decimator d(mesh, opt);
  return d.run(progress);
}

}  // namespace dgmesh
