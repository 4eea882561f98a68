// Wavefront OBJ (v, vn, f; other statements skipped); see io.h.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "dgmesh/detail/io_common.h"

namespace dgmesh::detail {

namespace {

// Statements of the OBJ specification (Wavefront, appendix B1) besides v, vn and f.
bool is_obj_keyword(std::string_view kw) {
  static const std::string_view known[] = {
      "vt",     "vp",     "p",      "l",          "g",         "o",     "s",     "mg",       "usemtl",
      "mtllib", "cstype", "deg",    "bmat",       "step",      "curv",  "curv2", "surf",     "parm",
      "trim",   "hole",   "scrv",   "sp",         "end",       "con",   "bevel", "c_interp", "d_interp",
      "lod",    "usemap", "maplib", "shadow_obj", "trace_obj", "ctech", "stech", "call",     "csh"};
  for (std::string_view k : known)
    if (kw == k) return true;
  return false;
}

}  // namespace

MeshData read_obj(const std::string& path, const std::string& buf) {
  std::vector<double> V, VN;
  std::vector<int> F, FN;  // FN: normal index per triangle corner, -1 if none
  bool any_corner_normal = false;
  std::vector<int> poly, polyn;
  int64_t fwd_v = -1, fwd_n = -1;  // largest forward (not yet defined) references
  size_t fwd_v_line = 0, fwd_n_line = 0;

  const char* p = buf.data();
  const char* const end = p + buf.size();
  size_t line = 0, unknown_line = 0;  // the first line that starts with no OBJ keyword
  const char* unknown_kw = nullptr;

  auto read_coords = [&](const char* q, const char* le, std::vector<double>& out, const char* what) {
    for (int k = 0; k < 3; ++k) {
      q = skip_blanks(q, le);
      if (q == le) fail_line(path, line, std::string("expected 3 coordinates after '") + what + "'");
      double x;
      const char* r = parse_double(q, le, x);
      if (!r || (r < le && !is_blank(*r))) fail_line(path, line, "invalid number " + show_token(q, le));
      out.push_back(x);
      q = r;
    }
    // Anything after (w, vertex colors) is ignored.
  };

  // Resolves a 1-based / negative OBJ index against the current count.
  auto resolve = [&](int64_t idx, size_t count, const char* what, int64_t& fwd, size_t& fwd_line) -> int {
    int64_t r;
    if (idx > 0) {
      r = idx - 1;
      if (r >= kMaxIndexCount)
        fail_line(path, line, std::string(what) + " index " + std::to_string(idx) + " out of range");
      if (r >= static_cast<int64_t>(count) && r > fwd) {
        fwd = r;
        fwd_line = line;
      }
    } else if (idx < 0) {
      r = static_cast<int64_t>(count) + idx;
      if (r < 0)
        fail_line(path, line,
                  std::string(what) + " index " + std::to_string(idx) + " out of range (only " + std::to_string(count) +
                      " defined)");
    } else {
      fail_line(path, line, std::string(what) + " index 0 is invalid (OBJ indices start at 1)");
    }
    return static_cast<int>(r);
  };

  while (p < end) {
    ++line;
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
    const char* le = nl ? nl : end;
    const char* const next = nl ? nl + 1 : end;
    const char* q = skip_blanks(p, le);
    p = next;
    if (q == le || *q == '#') continue;
    const char* kw = q;
    q = token_end(q, le);
    const size_t kl = static_cast<size_t>(q - kw);
    const bool is_v = kl == 1 && kw[0] == 'v';
    const bool is_vn = kl == 2 && kw[0] == 'v' && kw[1] == 'n';
    const bool is_f = kl == 1 && kw[0] == 'f';
    if (!is_v && !is_vn && !is_f) {  // vt, vp, g, o, s, usemtl, mtllib, l, ...
      if (!unknown_line && !is_obj_keyword(std::string_view(kw, kl))) unknown_line = line, unknown_kw = kw;
      continue;
    }
    if (const void* hash = std::memchr(q, '#', static_cast<size_t>(le - q)))
      le = static_cast<const char*>(hash);  // trailing comment

    if (is_v) {
      read_coords(q, le, V, "v");
      if (V.size() / 3 > static_cast<size_t>(kMaxIndexCount)) fail_line(path, line, "too many vertices");
    } else if (is_vn) {
      read_coords(q, le, VN, "vn");
      if (VN.size() / 3 > static_cast<size_t>(kMaxIndexCount)) fail_line(path, line, "too many normals");
    } else {
      poly.clear();
      polyn.clear();
      const size_t nv = V.size() / 3, nn = VN.size() / 3;
      for (;;) {
        q = skip_blanks(q, le);
        if (q == le) break;
        const char* tok = q;
        int64_t vi = 0, ti = 0, ni = 0;
        bool has_n = false;
        const char* r = parse_int(q, le, vi);
        if (r && r < le && *r == '/') {
          ++r;
          if (r < le && *r != '/' && !is_blank(*r)) r = parse_int(r, le, ti);  // texture index, ignored
          if (r && r < le && *r == '/') {
            ++r;
            if (r < le && !is_blank(*r)) {
              r = parse_int(r, le, ni);
              has_n = r != nullptr;
            }
          }
        }
        if (!r || (r < le && !is_blank(*r))) fail_line(path, line, "invalid face corner " + show_token(tok, le));
        poly.push_back(resolve(vi, nv, "vertex", fwd_v, fwd_v_line));
        if (has_n) {
          polyn.push_back(resolve(ni, nn, "normal", fwd_n, fwd_n_line));
          any_corner_normal = true;
        } else {
          polyn.push_back(-1);
        }
        q = r;
      }
      if (poly.size() < 3)
        fail_line(path, line, "face with " + std::to_string(poly.size()) + " vertices (need at least 3)");
      fan_triangulate(poly, F);
      fan_triangulate(polyn, FN);
    }
  }

  const size_t nv = V.size() / 3, nn = VN.size() / 3;
  // Any text file reads as an OBJ with no statements: say so rather than return an empty mesh.
  if (nv == 0 && unknown_line)
    fail_line(path, unknown_line, "not an OBJ file: " + show_token(unknown_kw, end) + " is not an OBJ statement");
  if (fwd_v >= static_cast<int64_t>(nv))
    fail_line(path, fwd_v_line,
              "vertex index " + std::to_string(fwd_v + 1) + " out of range (" + std::to_string(nv) + " vertices)");
  if (fwd_n >= static_cast<int64_t>(nn))
    fail_line(path, fwd_n_line,
              "normal index " + std::to_string(fwd_n + 1) + " out of range (" + std::to_string(nn) + " normals)");

  MeshData out;
  out.V = to_matrix<MatX3d>(V);
  out.F = to_matrix<MatX3i>(F);
  if (nn == 0) return out;

  if (!any_corner_normal) {
    if (nn == nv) out.N = to_matrix<MatX3d>(VN);  // unreferenced normals, one per vertex
    return out;
  }
  // Map corner normals to vertices; every vertex used by a face must get one unambiguous normal.
  std::vector<int> vn_of(nv, -1);
  std::vector<char> used(nv, 0);
  for (size_t k = 0; k < F.size(); ++k) {
    const int v = F[k], n = FN[k];
    used[static_cast<size_t>(v)] = 1;
    if (n < 0) continue;
    int& cur = vn_of[static_cast<size_t>(v)];
    if (cur < 0) {
      cur = n;
    } else if (cur != n && std::memcmp(&VN[3 * size_t(cur)], &VN[3 * size_t(n)], 3 * sizeof(double)) != 0) {
      return out;  // a vertex has several different normals: drop N
    }
  }
  std::vector<double> N(3 * nv, 0.0);
  for (size_t v = 0; v < nv; ++v) {
    int n = vn_of[v];
    if (n < 0) {
      if (used[v]) return out;  // a face corner without normal: incomplete, drop N
      if (nn == nv)
        n = static_cast<int>(v);
      else
        continue;  // isolated vertex: zero normal
    }
    std::memcpy(&N[3 * v], &VN[3 * size_t(n)], 3 * sizeof(double));
  }
  out.N = to_matrix<MatX3d>(N);
  return out;
}

void write_obj(Writer& w, const MatX3d& V, const MatX3i& F, const MatX3d* N) {
  w.put("# written by dgmesh\n");
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    w.put("v ");
    w.num(V(i, 0));
    w.put(' ');
    w.num(V(i, 1));
    w.put(' ');
    w.num(V(i, 2));
    w.put('\n');
  }
  if (N) {
    for (Eigen::Index i = 0; i < N->rows(); ++i) {
      w.put("vn ");
      w.num((*N)(i, 0));
      w.put(' ');
      w.num((*N)(i, 1));
      w.put(' ');
      w.num((*N)(i, 2));
      w.put('\n');
    }
  }
  for (Eigen::Index i = 0; i < F.rows(); ++i) {
    w.put('f');
    for (int k = 0; k < 3; ++k) {
      const int64_t idx = int64_t(F(i, k)) + 1;
      w.put(' ');
      w.num(idx);
      if (N) {
        w.put("//");
        w.num(idx);
      }
    }
    w.put('\n');
  }
}

}  // namespace dgmesh::detail
