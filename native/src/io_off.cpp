// OFF and NOFF (Geomview); see io.h.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "dgmesh/detail/io_common.h"

namespace dgmesh::detail {

namespace {

// Iterates over content lines (comments stripped, blank lines skipped).
struct LineReader {
  const char* p;
  const char* end;
  size_t line = 0;
  const char* b = nullptr;  // current line content [b, e)
  const char* e = nullptr;

  bool next() {
    while (p < end) {
      ++line;
      const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
      const char* le = nl ? nl : end;
      const char* q = skip_blanks(p, le);
      p = nl ? nl + 1 : end;
      if (const void* hash = std::memchr(q, '#', static_cast<size_t>(le - q))) le = static_cast<const char*>(hash);
      while (le > q && is_blank(le[-1])) --le;
      if (q == le) continue;
      b = q;
      e = le;
      return true;
    }
    return false;
  }
};

}  // namespace

MeshData read_off(const std::string& path, const std::string& buf) {
  LineReader lr{buf.data(), buf.data() + buf.size()};
  if (!lr.next()) fail(path, "empty file (no OFF header)");

  // Header keyword: [ST][C][N][4][n]OFF, optional (a file may start with the counts).
  bool has_normals = false;
  const char* q = lr.b;
  if (!(*q >= '0' && *q <= '9')) {
    const char* kw_end = token_end(q, lr.e);
    std::string_view kw(q, static_cast<size_t>(kw_end - q));
    const std::string kws(kw);
    if (kw.substr(0, 2) == "ST") kw.remove_prefix(2);
    if (!kw.empty() && kw[0] == 'C') kw.remove_prefix(1);
    if (!kw.empty() && kw[0] == 'N') {
      has_normals = true;
      kw.remove_prefix(1);
    }
    if (!kw.empty() && (kw[0] == '4' || kw[0] == 'n'))
      fail_line(path, lr.line, "unsupported OFF variant '" + kws + "' (only 3D OFF is supported)");
    if (kw != "OFF") fail_line(path, lr.line, "bad OFF header " + show_token(lr.b, lr.e));
    q = skip_blanks(kw_end, lr.e);
    if (q < lr.e && std::string_view(q, static_cast<size_t>(lr.e - q)).substr(0, 6) == "BINARY")
      fail_line(path, lr.line, "binary OFF is not supported");
    if (q == lr.e) {
      if (!lr.next()) fail(path, "missing vertex/face counts after OFF header");
      q = lr.b;
    }
  }
  int64_t counts[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k) {
    q = skip_blanks(q, lr.e);
    if (q == lr.e) {
      if (k < 2) fail_line(path, lr.line, "expected vertex and face counts");
      break;  // edge count is optional
    }
    const char* r = parse_int(q, lr.e, counts[k]);
    if (!r || (r < lr.e && !is_blank(*r)) || counts[k] < 0)
      fail_line(path, lr.line, "invalid count " + show_token(q, lr.e));
    q = r;
  }
  const int64_t nv = counts[0], nf = counts[1];
  const size_t count_line = lr.line;
  // Smallest possible vertex line is "0 0 0\n" (6 bytes); a face line has at least "n\n" (2 bytes,
  // so that a malformed short face is still reported as such).
  const int64_t remaining = static_cast<int64_t>(lr.end - lr.p);
  if (nv > kMaxIndexCount || nf > kMaxIndexCount || nv * 6 + nf * 2 > remaining + 1)
    fail_line(path, count_line,
              "header counts (" + std::to_string(nv) + " vertices, " + std::to_string(nf) +
                  " faces) exceed what the file can hold (" + std::to_string(remaining) +
                  " bytes left; truncated file or bad counts)");

  std::vector<double> V(static_cast<size_t>(3 * nv)), N(has_normals ? static_cast<size_t>(3 * nv) : 0);
  const int ncoord = has_normals ? 6 : 3;
  for (int64_t i = 0; i < nv; ++i) {
    if (!lr.next())
      fail(path, "unexpected end of file: expected " + std::to_string(nv) + " vertices, found " + std::to_string(i));
    const char* c = lr.b;
    for (int k = 0; k < ncoord; ++k) {
      c = skip_blanks(c, lr.e);
      if (c == lr.e)
        fail_line(path, lr.line, "vertex " + std::to_string(i) + ": expected " + std::to_string(ncoord) + " numbers");
      double x;
      const char* r = parse_double(c, lr.e, x);
      if (!r || (r < lr.e && !is_blank(*r)))
        fail_line(path, lr.line, "vertex " + std::to_string(i) + ": invalid number " + show_token(c, lr.e));
      if (k < 3)
        V[static_cast<size_t>(3 * i + k)] = x;
      else
        N[static_cast<size_t>(3 * i + k - 3)] = x;
      c = r;
    }
    // Colors / texture coordinates after the coordinates are ignored.
  }

  std::vector<int> F, poly;
  F.reserve(static_cast<size_t>(3 * nf));
  for (int64_t i = 0; i < nf; ++i) {
    if (!lr.next())
      fail(path, "unexpected end of file: expected " + std::to_string(nf) + " faces, found " + std::to_string(i));
    const char* c = lr.b;
    int64_t n;
    const char* r = parse_int(c, lr.e, n);
    if (!r || (r < lr.e && !is_blank(*r)))
      fail_line(path, lr.line, "face " + std::to_string(i) + ": invalid vertex count " + show_token(c, lr.e));
    if (n < 3)
      fail_line(path, lr.line,
                "face " + std::to_string(i) + " has " + std::to_string(n) + " vertices (need at least 3)");
    c = r;
    poly.clear();
    for (int64_t k = 0; k < n; ++k) {
      c = skip_blanks(c, lr.e);
      if (c == lr.e)
        fail_line(path, lr.line,
                  "face " + std::to_string(i) + ": expected " + std::to_string(n) + " vertex indices, found " +
                      std::to_string(k));
      int64_t idx;
      r = parse_int(c, lr.e, idx);
      if (!r || (r < lr.e && !is_blank(*r)))
        fail_line(path, lr.line, "face " + std::to_string(i) + ": invalid vertex index " + show_token(c, lr.e));
      if (idx < 0 || idx >= nv)
        fail_line(path, lr.line,
                  "face " + std::to_string(i) + ": vertex index " + std::to_string(idx) + " out of range (" +
                      std::to_string(nv) + " vertices)");
      poly.push_back(static_cast<int>(idx));
      c = r;
    }
    // Face colors after the indices are ignored.
    fan_triangulate(poly, F);
  }

  MeshData out;
  out.V = to_matrix<MatX3d>(V);
  out.F = to_matrix<MatX3i>(F);
  if (has_normals) out.N = to_matrix<MatX3d>(N);
  return out;
}

void write_off(Writer& w, const MatX3d& V, const MatX3i& F, const MatX3d* N) {
  w.put(N ? "NOFF\n" : "OFF\n");
  w.num(int64_t(V.rows()));
  w.put(' ');
  w.num(int64_t(F.rows()));
  w.put(" 0\n");
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    w.num(V(i, 0));
    w.put(' ');
    w.num(V(i, 1));
    w.put(' ');
    w.num(V(i, 2));
    if (N) {
      for (int k = 0; k < 3; ++k) {
        w.put(' ');
        w.num((*N)(i, k));
      }
    }
    w.put('\n');
  }
  for (Eigen::Index i = 0; i < F.rows(); ++i) {
    w.put('3');
    for (int k = 0; k < 3; ++k) {
      w.put(' ');
      w.num(int64_t(F(i, k)));
    }
    w.put('\n');
  }
}

}  // namespace dgmesh::detail
