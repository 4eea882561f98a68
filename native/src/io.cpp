// Mesh file input/output. See io.h.
//
// Design notes:
//  * The whole file is read into memory once; all parsing works on [begin, end) pointer ranges and
//    checks the end before every access, so malformed input cannot read out of bounds.
//  * Numbers are parsed with std::from_chars (no locale, no allocation).
//  * No allocation is ever sized from a count in the file before the count has been bounded by the
//    number of bytes that are left in the file.
#include "dgmesh/io.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <string_view>
#include <system_error>
#include <vector>

namespace dgmesh {
namespace {

namespace fs = std::filesystem;

constexpr int64_t kMaxIndexCount = std::numeric_limits<int>::max();

[[noreturn]] void fail(const std::string& path, const std::string& msg) {
  throw IoError(path + ": " + msg);
}

[[noreturn]] void fail_line(const std::string& path, size_t line, const std::string& msg) {
  throw IoError(path + ":" + std::to_string(line) + ": " + msg);
}

// ------------------------------------------------------------------------------------------------
// File access

std::string read_whole_file(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) fail(path, "file not found");
  if (fs::is_directory(st)) fail(path, "is a directory, not a mesh file");
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) fail(path, std::string("cannot open file: ") + std::strerror(errno));
  std::string data;
  uintmax_t size = fs::file_size(path, ec);
  if (ec || size > (uintmax_t(1) << 40)) size = 0;  // unknown size: grow while reading
  data.resize(static_cast<size_t>(size));
  size_t got = size ? std::fread(&data[0], 1, data.size(), f.get()) : 0;
  data.resize(got);
  // Keep reading in case the size was unknown or the file grew.
  char chunk[1 << 16];
  for (;;) {
    const size_t n = std::fread(chunk, 1, sizeof chunk, f.get());
    if (n == 0) break;
    data.append(chunk, n);
  }
  if (std::ferror(f.get())) fail(path, "read error");
  return data;
}

std::string lower_extension(const std::string& path) {
  // The C library stops a path at its first NUL: "a\0b.obj" would open the file "a".
  const size_t nul = path.find('\0');
  if (nul != std::string::npos) fail(path.substr(0, nul) + "...", "the path holds a NUL character");
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>((c >= 'A' && c <= 'Z') ? c - 'A' + 'a' : c);
  return ext;
}

// ------------------------------------------------------------------------------------------------
// Text helpers

inline bool is_blank(char c) {  // whitespace other than newline
  return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}
inline bool is_ws(char c) { return is_blank(c) || c == '\n'; }

inline const char* skip_blanks(const char* p, const char* e) {
  while (p < e && is_blank(*p)) ++p;
  return p;
}

inline const char* token_end(const char* p, const char* e) {
  while (p < e && !is_ws(*p)) ++p;
  return p;
}

// Token at p, shortened for error messages.
std::string show_token(const char* p, const char* e) {
  const char* t = token_end(p, e);
  std::string s(p, t);
  if (s.size() > 40) s = s.substr(0, 40) + "...";
  return "'" + s + "'";
}

// Parses a double starting exactly at p. Returns the end of the number or nullptr.
const char* parse_double(const char* p, const char* e, double& out) {
  const char* s = p;
  if (s < e && *s == '+') {
    ++s;
    if (s < e && *s == '-') return nullptr;
  }
  const std::from_chars_result r = std::from_chars(s, e, out, std::chars_format::general);
  if (r.ec == std::errc::result_out_of_range) {
    // Overflow / underflow: follow strtod (inf / 0 / denormal) rather than rejecting.
    const std::string tmp(s, r.ptr);
    out = std::strtod(tmp.c_str(), nullptr);
    return r.ptr;
  }
  if (r.ec != std::errc()) return nullptr;
  return r.ptr;
}

// Parses an integer starting exactly at p. Returns the end or nullptr (also on overflow).
const char* parse_int(const char* p, const char* e, int64_t& out) {
  const char* s = p;
  if (s < e && *s == '+') {
    ++s;
    if (s < e && *s == '-') return nullptr;
  }
  const std::from_chars_result r = std::from_chars(s, e, out);
  if (r.ec != std::errc()) return nullptr;
  return r.ptr;
}

// Moves a flat buffer into an Eigen matrix with 3 columns.
template <class Mat, class T>
Mat to_matrix(const std::vector<T>& v) {
  Mat m(static_cast<Eigen::Index>(v.size() / 3), 3);
  if (!v.empty()) std::memcpy(m.data(), v.data(), v.size() * sizeof(T));
  return m;
}

void fan_triangulate(const std::vector<int>& poly, std::vector<int>& F) {
  for (size_t k = 1; k + 1 < poly.size(); ++k) {
    F.push_back(poly[0]);
    F.push_back(poly[k]);
    F.push_back(poly[k + 1]);
  }
}

// ------------------------------------------------------------------------------------------------
// OBJ

// Statements of the OBJ specification (Wavefront, appendix B1) besides v, vn and f.
bool is_obj_keyword(std::string_view kw) {
  static const std::string_view known[] = {
      "vt", "vp", "p", "l", "g", "o", "s", "mg", "usemtl", "mtllib", "cstype", "deg", "bmat",
      "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp", "end", "con", "bevel",
      "c_interp", "d_interp", "lod", "usemap", "maplib", "shadow_obj", "trace_obj", "ctech",
      "stech", "call", "csh"};
  for (std::string_view k : known)
    if (kw == k) return true;
  return false;
}

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
      if (!r || (r < le && !is_blank(*r)))
        fail_line(path, line, "invalid number " + show_token(q, le));
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
        fail_line(path, line, std::string(what) + " index " + std::to_string(idx) +
                                  " out of range (only " + std::to_string(count) + " defined)");
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
        if (!r || (r < le && !is_blank(*r)))
          fail_line(path, line, "invalid face corner " + show_token(tok, le));
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
    fail_line(path, fwd_v_line, "vertex index " + std::to_string(fwd_v + 1) + " out of range (" +
                                    std::to_string(nv) + " vertices)");
  if (fwd_n >= static_cast<int64_t>(nn))
    fail_line(path, fwd_n_line, "normal index " + std::to_string(fwd_n + 1) + " out of range (" +
                                    std::to_string(nn) + " normals)");

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
      if (nn == nv) n = static_cast<int>(v);
      else continue;  // isolated vertex: zero normal
    }
    std::memcpy(&N[3 * v], &VN[3 * size_t(n)], 3 * sizeof(double));
  }
  out.N = to_matrix<MatX3d>(N);
  return out;
}

// ------------------------------------------------------------------------------------------------
// OFF

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
    fail_line(path, count_line, "header counts (" + std::to_string(nv) + " vertices, " + std::to_string(nf) +
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
      if (k < 3) V[static_cast<size_t>(3 * i + k)] = x;
      else N[static_cast<size_t>(3 * i + k - 3)] = x;
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
      fail_line(path, lr.line, "face " + std::to_string(i) + " has " + std::to_string(n) + " vertices (need at least 3)");
    c = r;
    poly.clear();
    for (int64_t k = 0; k < n; ++k) {
      c = skip_blanks(c, lr.e);
      if (c == lr.e)
        fail_line(path, lr.line, "face " + std::to_string(i) + ": expected " + std::to_string(n) + " vertex indices, found " +
                                     std::to_string(k));
      int64_t idx;
      r = parse_int(c, lr.e, idx);
      if (!r || (r < lr.e && !is_blank(*r)))
        fail_line(path, lr.line, "face " + std::to_string(i) + ": invalid vertex index " + show_token(c, lr.e));
      if (idx < 0 || idx >= nv)
        fail_line(path, lr.line, "face " + std::to_string(i) + ": vertex index " + std::to_string(idx) +
                                     " out of range (" + std::to_string(nv) + " vertices)");
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

// ------------------------------------------------------------------------------------------------
// PLY

enum class PT { I8, U8, I16, U16, I32, U32, F32, F64 };

bool parse_ply_type(std::string_view s, PT& t) {
  if (s == "char" || s == "int8") t = PT::I8;
  else if (s == "uchar" || s == "uint8") t = PT::U8;
  else if (s == "short" || s == "int16") t = PT::I16;
  else if (s == "ushort" || s == "uint16") t = PT::U16;
  else if (s == "int" || s == "int32") t = PT::I32;
  else if (s == "uint" || s == "uint32") t = PT::U32;
  else if (s == "float" || s == "float32") t = PT::F32;
  else if (s == "double" || s == "float64") t = PT::F64;
  else return false;
  return true;
}

inline size_t pt_size(PT t) {
  switch (t) {
    case PT::I8: case PT::U8: return 1;
    case PT::I16: case PT::U16: return 2;
    case PT::I32: case PT::U32: case PT::F32: return 4;
    case PT::F64: return 8;
  }
  return 1;
}

inline bool pt_is_int(PT t) { return t != PT::F32 && t != PT::F64; }

template <class T>
inline T load(const unsigned char* p, bool swap) {
  unsigned char b[sizeof(T)];
  if (swap) {
    for (size_t i = 0; i < sizeof(T); ++i) b[i] = p[sizeof(T) - 1 - i];
  } else {
    std::memcpy(b, p, sizeof(T));
  }
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

inline double load_double(PT t, const unsigned char* p, bool swap) {
  switch (t) {
    case PT::I8: return load<int8_t>(p, swap);
    case PT::U8: return load<uint8_t>(p, swap);
    case PT::I16: return load<int16_t>(p, swap);
    case PT::U16: return load<uint16_t>(p, swap);
    case PT::I32: return load<int32_t>(p, swap);
    case PT::U32: return load<uint32_t>(p, swap);
    case PT::F32: return load<float>(p, swap);
    case PT::F64: return load<double>(p, swap);
  }
  return 0;
}

inline int64_t load_int(PT t, const unsigned char* p, bool swap) {  // t must be an integer type
  switch (t) {
    case PT::I8: return load<int8_t>(p, swap);
    case PT::U8: return load<uint8_t>(p, swap);
    case PT::I16: return load<int16_t>(p, swap);
    case PT::U16: return load<uint16_t>(p, swap);
    case PT::I32: return load<int32_t>(p, swap);
    case PT::U32: return load<uint32_t>(p, swap);
    default: return 0;
  }
}

inline bool host_little_endian() {
  const uint16_t x = 1;
  unsigned char c;
  std::memcpy(&c, &x, 1);
  return c == 1;
}

// Role of a property in the mesh being built.
enum Role : int { kSkip = 0, kX, kY, kZ, kNX, kNY, kNZ, kFaceIndices };

struct PlyProp {
  std::string name;
  PT type = PT::F32;  // scalar type, or list item type
  bool is_list = false;
  PT count_type = PT::U8;
  int role = kSkip;
};

struct PlyElem {
  std::string name;
  int64_t count = 0;
  size_t line = 0;
  std::vector<PlyProp> props;
};

enum class PlyFormat { Ascii, BinaryLE, BinaryBE };

struct PlyBuilder {
  const std::string& path;
  std::vector<double> V, N;
  std::vector<int> F;
  std::vector<int> poly;
  int64_t nv = 0;
  bool has_normals = false;

  void add_index(int64_t idx, const PlyElem& el, int64_t i) {
    if (idx < 0 || idx >= nv)
      fail(path, "element '" + el.name + "' " + std::to_string(i) + ": vertex index " + std::to_string(idx) +
                     " out of range (" + std::to_string(nv) + " vertices)");
    poly.push_back(static_cast<int>(idx));
  }
  void begin_face(int64_t n, const PlyElem& el, int64_t i, size_t line) {
    if (n < 3) {
      const std::string msg = "element '" + el.name + "' " + std::to_string(i) + " has " + std::to_string(n) +
                              " vertices (need at least 3)";
      if (line) fail_line(path, line, msg);
      fail(path, msg);
    }
    poly.clear();
  }
  void end_face() { fan_triangulate(poly, F); }
  void set_scalar(int role, int64_t i, double x) {
    if (role >= kX && role <= kZ) V[static_cast<size_t>(3 * i + (role - kX))] = x;
    else if (role >= kNX && role <= kNZ) N[static_cast<size_t>(3 * i + (role - kNX))] = x;
  }
};

void read_ply_binary(const std::string& path, const std::vector<PlyElem>& elems, const unsigned char* p,
                     const unsigned char* const end, bool swap, PlyBuilder& mb) {
  for (const PlyElem& el : elems) {
    if (el.props.empty()) continue;
    // Fast path: element without lists and without used properties is a fixed-size block.
    bool fixed = true;
    size_t stride = 0;
    bool used = false;
    for (const PlyProp& pr : el.props) {
      if (pr.is_list) fixed = false;
      stride += pt_size(pr.type);
      if (pr.role != kSkip) used = true;
    }
    if (fixed && !used) {
      if (static_cast<uint64_t>(el.count) > static_cast<uint64_t>(end - p) / stride)
        fail(path, "truncated binary data in element '" + el.name + "' (" + std::to_string(el.count) + " declared)");
      p += static_cast<size_t>(el.count) * stride;
      continue;
    }
    for (int64_t i = 0; i < el.count; ++i) {
      for (const PlyProp& pr : el.props) {
        if (!pr.is_list) {
          const size_t sz = pt_size(pr.type);
          if (static_cast<size_t>(end - p) < sz)
            fail(path, "truncated binary data in element '" + el.name + "' " + std::to_string(i) + ", property '" +
                           pr.name + "'");
          if (pr.role != kSkip) mb.set_scalar(pr.role, i, load_double(pr.type, p, swap));
          p += sz;
          continue;
        }
        const size_t cs = pt_size(pr.count_type);
        if (static_cast<size_t>(end - p) < cs)
          fail(path, "truncated binary data in element '" + el.name + "' " + std::to_string(i) + ", property '" +
                         pr.name + "'");
        const int64_t n = load_int(pr.count_type, p, swap);
        p += cs;
        if (n < 0)
          fail(path, "element '" + el.name + "' " + std::to_string(i) + ": negative list length " + std::to_string(n));
        const size_t isz = pt_size(pr.type);
        if (static_cast<uint64_t>(n) > static_cast<uint64_t>(end - p) / isz)
          fail(path, "truncated binary data in element '" + el.name + "' " + std::to_string(i) + ", property '" +
                         pr.name + "' (list of " + std::to_string(n) + ")");
        if (pr.role == kFaceIndices) {
          mb.begin_face(n, el, i, 0);
          for (int64_t k = 0; k < n; ++k, p += isz) mb.add_index(load_int(pr.type, p, swap), el, i);
          mb.end_face();
        } else {
          p += static_cast<size_t>(n) * isz;
        }
      }
    }
  }
}

struct AsciiTokens {
  const char* p;
  const char* end;
  size_t line;
  // Returns the next token [b, e) or false at end of data.
  bool next(const char*& b, const char*& e) {
    while (p < end && is_ws(*p)) {
      if (*p == '\n') ++line;
      ++p;
    }
    if (p == end) return false;
    b = p;
    while (p < end && !is_ws(*p)) ++p;
    e = p;
    return true;
  }
};

void read_ply_ascii(const std::string& path, const std::vector<PlyElem>& elems, const char* p, const char* end,
                    size_t line, PlyBuilder& mb) {
  AsciiTokens tk{p, end, line};
  for (const PlyElem& el : elems) {
    if (el.props.empty()) continue;
    for (int64_t i = 0; i < el.count; ++i) {
      for (const PlyProp& pr : el.props) {
        const char* b;
        const char* e;
        auto where = [&]() { return "element '" + el.name + "' " + std::to_string(i) + ", property '" + pr.name + "'"; };
        auto next_tok = [&]() {
          if (!tk.next(b, e))
            fail(path, "unexpected end of file in " + where() + " (" + std::to_string(el.count) + " declared)");
        };
        auto get_int = [&]() -> int64_t {
          next_tok();
          int64_t v;
          const char* r = parse_int(b, e, v);
          if (!r || r != e) fail_line(path, tk.line, "invalid integer " + show_token(b, e) + " in " + where());
          return v;
        };
        auto get_value = [&](PT t) -> double {
          if (pt_is_int(t)) return static_cast<double>(get_int());
          next_tok();
          double v;
          const char* r = parse_double(b, e, v);
          if (!r || r != e) fail_line(path, tk.line, "invalid number " + show_token(b, e) + " in " + where());
          return v;
        };
        if (!pr.is_list) {
          const double x = get_value(pr.type);
          if (pr.role != kSkip) mb.set_scalar(pr.role, i, x);
          continue;
        }
        const int64_t n = get_int();
        if (n < 0) fail_line(path, tk.line, "negative list length in " + where());
        if (pr.role == kFaceIndices) {
          mb.begin_face(n, el, i, tk.line);
          for (int64_t k = 0; k < n; ++k) {
            const int64_t idx = get_int();
            if (idx < 0 || idx >= mb.nv)
              fail_line(path, tk.line, "vertex index " + std::to_string(idx) + " out of range (" +
                                           std::to_string(mb.nv) + " vertices) in " + where());
            mb.poly.push_back(static_cast<int>(idx));
          }
          mb.end_face();
        } else {
          for (int64_t k = 0; k < n; ++k) (void)get_value(pr.type);  // each item needs >= 1 byte: loop is bounded
        }
      }
    }
  }
}

MeshData read_ply(const std::string& path, const std::string& buf) {
  const char* p = buf.data();
  const char* const end = p + buf.size();
  size_t line = 0;
  std::vector<std::string_view> toks;

  // Reads the next header line into toks; returns false at end of file.
  auto next_line = [&]() -> bool {
    if (p >= end) return false;
    ++line;
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
    const char* le = nl ? nl : end;
    const char* q = p;
    p = nl ? nl + 1 : end;
    toks.clear();
    for (;;) {
      q = skip_blanks(q, le);
      if (q == le) break;
      const char* t = token_end(q, le);
      toks.emplace_back(q, static_cast<size_t>(t - q));
      q = t;
    }
    return true;
  };

  if (!next_line() || toks.size() != 1 || toks[0] != "ply") fail_line(path, 1, "not a PLY file (missing 'ply' magic)");
  bool have_format = false, have_end = false;
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElem> elems;
  while (next_line()) {
    if (toks.empty()) continue;
    const std::string_view kw = toks[0];
    if (kw == "comment" || kw == "obj_info") continue;
    if (kw == "end_header") {
      have_end = true;
      break;
    }
    if (kw == "format") {
      if (toks.size() != 3) fail_line(path, line, "bad format line");
      if (toks[1] == "ascii") format = PlyFormat::Ascii;
      else if (toks[1] == "binary_little_endian") format = PlyFormat::BinaryLE;
      else if (toks[1] == "binary_big_endian") format = PlyFormat::BinaryBE;
      else fail_line(path, line, "unknown PLY format '" + std::string(toks[1]) + "'");
      if (toks[2] != "1.0") fail_line(path, line, "unsupported PLY version '" + std::string(toks[2]) + "'");
      have_format = true;
    } else if (kw == "element") {
      if (toks.size() != 3) fail_line(path, line, "bad element line");
      PlyElem el;
      el.name = std::string(toks[1]);
      el.line = line;
      const char* r = parse_int(toks[2].data(), toks[2].data() + toks[2].size(), el.count);
      if (!r || r != toks[2].data() + toks[2].size() || el.count < 0)
        fail_line(path, line, "invalid element count '" + std::string(toks[2]) + "'");
      elems.push_back(std::move(el));
    } else if (kw == "property") {
      if (elems.empty()) fail_line(path, line, "property before any element");
      PlyProp pr;
      if (toks.size() >= 2 && toks[1] == "list") {
        if (toks.size() != 5) fail_line(path, line, "bad list property line");
        if (!parse_ply_type(toks[2], pr.count_type))
          fail_line(path, line, "unsupported property type '" + std::string(toks[2]) + "'");
        if (!pt_is_int(pr.count_type))
          fail_line(path, line, "list count type must be an integer type, not '" + std::string(toks[2]) + "'");
        if (!parse_ply_type(toks[3], pr.type))
          fail_line(path, line, "unsupported property type '" + std::string(toks[3]) + "'");
        pr.is_list = true;
        pr.name = std::string(toks[4]);
      } else {
        if (toks.size() != 3) fail_line(path, line, "bad property line");
        if (!parse_ply_type(toks[1], pr.type))
          fail_line(path, line, "unsupported property type '" + std::string(toks[1]) + "'");
        pr.name = std::string(toks[2]);
      }
      elems.back().props.push_back(std::move(pr));
    } else {
      fail_line(path, line, "unknown header keyword '" + std::string(kw) + "'");
    }
  }
  if (!have_end) fail(path, "truncated header (no end_header)");
  if (!have_format) fail(path, "header has no format line");

  // Assign roles.
  PlyBuilder mb{path, {}, {}, {}, {}, 0, false};
  bool seen_vertex = false, seen_face = false;
  for (PlyElem& el : elems) {
    if (el.name == "vertex" && !seen_vertex) {
      seen_vertex = true;
      int found[7] = {0, 0, 0, 0, 0, 0, 0};
      for (PlyProp& pr : el.props) {
        static const char* names[7] = {"", "x", "y", "z", "nx", "ny", "nz"};
        for (int r = kX; r <= kNZ; ++r) {
          if (pr.name == names[r] && !found[r]) {
            if (pr.is_list) fail_line(path, el.line, "vertex property '" + pr.name + "' must not be a list");
            pr.role = r;
            found[r] = 1;
          }
        }
      }
      if (!found[kX] || !found[kY] || !found[kZ]) fail_line(path, el.line, "vertex element lacks x, y, z properties");
      mb.has_normals = found[kNX] && found[kNY] && found[kNZ];
      if (!mb.has_normals)
        for (PlyProp& pr : el.props)
          if (pr.role >= kNX) pr.role = kSkip;
      if (el.count > kMaxIndexCount)
        fail_line(path, el.line, "vertex count " + std::to_string(el.count) + " is too large");
      mb.nv = el.count;
    } else if (el.name == "face" && !seen_face) {
      seen_face = true;
      bool found = false;
      for (PlyProp& pr : el.props) {
        if (!found && pr.is_list && (pr.name == "vertex_indices" || pr.name == "vertex_index")) {
          if (!pt_is_int(pr.type))
            fail_line(path, el.line, "face indices must have an integer type");
          pr.role = kFaceIndices;
          found = true;
        }
      }
      if (!found) fail_line(path, el.line, "face element has no 'vertex_indices' list property");
      if (el.count > kMaxIndexCount) fail_line(path, el.line, "face count " + std::to_string(el.count) + " is too large");
    }
  }
  if (!seen_vertex) fail(path, "no 'vertex' element in header");

  // Bound every count by the bytes left before allocating anything.
  const bool ascii = format == PlyFormat::Ascii;
  uint64_t remaining = static_cast<uint64_t>(end - p) + (ascii ? 1 : 0);
  int64_t face_count = 0;
  for (const PlyElem& el : elems) {
    uint64_t min_size = 0;  // minimal bytes per instance
    for (const PlyProp& pr : el.props) min_size += ascii ? 2 : pt_size(pr.is_list ? pr.count_type : pr.type);
    if (min_size == 0) continue;
    if (static_cast<uint64_t>(el.count) > remaining / min_size)
      fail_line(path, el.line, "element '" + el.name + "' count " + std::to_string(el.count) +
                                   " exceeds what the file can hold (" + std::to_string(end - p) +
                                   " data bytes; truncated file or bad count)");
    remaining -= static_cast<uint64_t>(el.count) * min_size;
    for (const PlyProp& pr : el.props)
      if (pr.role == kFaceIndices) face_count = el.count;
  }

  mb.V.assign(static_cast<size_t>(3 * mb.nv), 0.0);
  if (mb.has_normals) mb.N.assign(static_cast<size_t>(3 * mb.nv), 0.0);
  mb.F.reserve(static_cast<size_t>(3 * face_count));

  if (ascii) {
    read_ply_ascii(path, elems, p, end, line + 1, mb);
  } else {
    const bool file_le = format == PlyFormat::BinaryLE;
    read_ply_binary(path, elems, reinterpret_cast<const unsigned char*>(p), reinterpret_cast<const unsigned char*>(end),
                    file_le != host_little_endian(), mb);
  }

  MeshData out;
  out.V = to_matrix<MatX3d>(mb.V);
  out.F = to_matrix<MatX3i>(mb.F);
  if (mb.has_normals) out.N = to_matrix<MatX3d>(mb.N);
  return out;
}

// ------------------------------------------------------------------------------------------------
// Writing

class Writer {
 public:
  explicit Writer(const std::string& path) : path_(path), f_(std::fopen(path.c_str(), "wb"), &std::fclose) {
    if (!f_) fail(path, std::string("cannot open file for writing: ") + std::strerror(errno));
    buf_.reserve(kChunk + 256);
  }
  void put(const char* s, size_t n) {
    buf_.append(s, n);
    if (buf_.size() >= kChunk) flush();
  }
  void put(std::string_view s) { put(s.data(), s.size()); }
  void put(char c) {
    buf_.push_back(c);
    if (buf_.size() >= kChunk) flush();
  }
  void num(double x) {  // same text as printf("%.17g")
    char tmp[64];
    const auto r = std::to_chars(tmp, tmp + sizeof tmp, x, std::chars_format::general, 17);
    put(tmp, static_cast<size_t>(r.ptr - tmp));
  }
  void num(int64_t x) {
    char tmp[24];
    const auto r = std::to_chars(tmp, tmp + sizeof tmp, x);
    put(tmp, static_cast<size_t>(r.ptr - tmp));
  }
  template <class T>
  void raw_le(T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (!host_little_endian()) std::reverse(b, b + sizeof(T));
    put(reinterpret_cast<const char*>(b), sizeof(T));
  }
  void close() {
    flush();
    FILE* f = f_.release();
    if (std::fclose(f) != 0) fail(path_, std::string("error closing file: ") + std::strerror(errno));
  }

 private:
  static constexpr size_t kChunk = size_t(1) << 20;
  void flush() {
    if (!buf_.empty() && std::fwrite(buf_.data(), 1, buf_.size(), f_.get()) != buf_.size())
      fail(path_, std::string("write error: ") + std::strerror(errno));
    buf_.clear();
  }
  const std::string& path_;
  std::unique_ptr<FILE, int (*)(FILE*)> f_;
  std::string buf_;
};

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

void write_ply(Writer& w, const MatX3d& V, const MatX3i& F, const MatX3d* N) {
  std::string h = "ply\nformat binary_little_endian 1.0\ncomment written by dgmesh\n";
  h += "element vertex " + std::to_string(V.rows()) + "\n";
  h += "property double x\nproperty double y\nproperty double z\n";
  if (N) h += "property double nx\nproperty double ny\nproperty double nz\n";
  h += "element face " + std::to_string(F.rows()) + "\n";
  h += "property list uchar int vertex_indices\nend_header\n";
  w.put(h);
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    for (int k = 0; k < 3; ++k) w.raw_le<double>(V(i, k));
    if (N)
      for (int k = 0; k < 3; ++k) w.raw_le<double>((*N)(i, k));
  }
  for (Eigen::Index i = 0; i < F.rows(); ++i) {
    w.raw_le<uint8_t>(3);
    for (int k = 0; k < 3; ++k) w.raw_le<int32_t>(F(i, k));
  }
}

}  // namespace

MeshData read_mesh(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != ".obj" && ext != ".off" && ext != ".ply")
    fail(path, "unsupported file extension '" + ext + "' (expected .obj, .off or .ply)");
  const std::string buf = read_whole_file(path);
  if (std::all_of(buf.begin(), buf.end(), [](char c) { return is_ws(c); })) fail(path, "empty file");
  if (ext == ".obj") return read_obj(path, buf);
  if (ext == ".off") return read_off(path, buf);
  return read_ply(path, buf);
}

void write_mesh(const std::string& path, const MatX3d& V, const MatX3i& F, const MatX3d* N) {
  const std::string ext = lower_extension(path);
  if (ext != ".obj" && ext != ".off" && ext != ".ply")
    fail(path, "unsupported file extension '" + ext + "' (expected .obj, .off or .ply)");
  if (N && N->rows() != V.rows())
    fail(path, "normals have " + std::to_string(N->rows()) + " rows but there are " + std::to_string(V.rows()) +
                   " vertices");
  if (V.rows() > kMaxIndexCount || F.rows() > kMaxIndexCount) fail(path, "mesh too large to write");
  for (Eigen::Index i = 0; i < F.rows(); ++i)
    for (int k = 0; k < 3; ++k)
      if (F(i, k) < 0 || F(i, k) >= V.rows())
        fail(path, "cannot write: face " + std::to_string(i) + " has vertex index " + std::to_string(F(i, k)) +
                       " out of range (" + std::to_string(V.rows()) + " vertices)");
  Writer w(path);
  if (ext == ".obj") write_obj(w, V, F, N);
  else if (ext == ".off") write_off(w, V, F, N);
  else write_ply(w, V, F, N);
  w.close();
}

}  // namespace dgmesh
