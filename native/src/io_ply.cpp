// PLY (ascii, binary little and big endian); see io.h.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "dgmesh/detail/io_common.h"

namespace dgmesh::detail {

namespace {

enum class PT { I8, U8, I16, U16, I32, U32, F32, F64 };

bool parse_ply_type(std::string_view s, PT& t) {
  if (s == "char" || s == "int8")
    t = PT::I8;
  else if (s == "uchar" || s == "uint8")
    t = PT::U8;
  else if (s == "short" || s == "int16")
    t = PT::I16;
  else if (s == "ushort" || s == "uint16")
    t = PT::U16;
  else if (s == "int" || s == "int32")
    t = PT::I32;
  else if (s == "uint" || s == "uint32")
    t = PT::U32;
  else if (s == "float" || s == "float32")
    t = PT::F32;
  else if (s == "double" || s == "float64")
    t = PT::F64;
  else
    return false;
  return true;
}

inline size_t pt_size(PT t) {
  switch (t) {
    case PT::I8:
    case PT::U8:
      return 1;
    case PT::I16:
    case PT::U16:
      return 2;
    case PT::I32:
    case PT::U32:
    case PT::F32:
      return 4;
    case PT::F64:
      return 8;
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
    case PT::I8:
      return load<int8_t>(p, swap);
    case PT::U8:
      return load<uint8_t>(p, swap);
    case PT::I16:
      return load<int16_t>(p, swap);
    case PT::U16:
      return load<uint16_t>(p, swap);
    case PT::I32:
      return load<int32_t>(p, swap);
    case PT::U32:
      return load<uint32_t>(p, swap);
    case PT::F32:
      return load<float>(p, swap);
    case PT::F64:
      return load<double>(p, swap);
  }
  return 0;
}

inline int64_t load_int(PT t, const unsigned char* p, bool swap) {  // t must be an integer type
  // Integers up to 32 bits are exact in a double.
  return t == PT::F32 || t == PT::F64 ? 0 : static_cast<int64_t>(load_double(t, p, swap));
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
    if (role >= kX && role <= kZ)
      V[static_cast<size_t>(3 * i + (role - kX))] = x;
    else if (role >= kNX && role <= kNZ)
      N[static_cast<size_t>(3 * i + (role - kNX))] = x;
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
        auto where = [&]() {
          return "element '" + el.name + "' " + std::to_string(i) + ", property '" + pr.name + "'";
        };
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
              fail_line(path, tk.line,
                        "vertex index " + std::to_string(idx) + " out of range (" + std::to_string(mb.nv) +
                            " vertices) in " + where());
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

}  // namespace

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
      if (toks[1] == "ascii")
        format = PlyFormat::Ascii;
      else if (toks[1] == "binary_little_endian")
        format = PlyFormat::BinaryLE;
      else if (toks[1] == "binary_big_endian")
        format = PlyFormat::BinaryBE;
      else
        fail_line(path, line, "unknown PLY format '" + std::string(toks[1]) + "'");
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
          if (!pt_is_int(pr.type)) fail_line(path, el.line, "face indices must have an integer type");
          pr.role = kFaceIndices;
          found = true;
        }
      }
      if (!found) fail_line(path, el.line, "face element has no 'vertex_indices' list property");
      if (el.count > kMaxIndexCount)
        fail_line(path, el.line, "face count " + std::to_string(el.count) + " is too large");
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
      fail_line(path, el.line,
                "element '" + el.name + "' count " + std::to_string(el.count) + " exceeds what the file can hold (" +
                    std::to_string(end - p) + " data bytes; truncated file or bad count)");
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

}  // namespace dgmesh::detail
