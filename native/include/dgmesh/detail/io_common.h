/// \file
/// Shared pieces of the mesh file readers and writers (io.cpp dispatches by extension to io_obj.cpp,
/// io_off.cpp and io_ply.cpp): errors naming the file and line, bounds-checked token parsing on
/// [begin, end) ranges, and a buffered writer. Not part of the library's interface.
#pragma once
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "dgmesh/io.h"

namespace dgmesh::detail {

constexpr int64_t kMaxIndexCount = std::numeric_limits<int>::max();

[[noreturn]] inline void fail(const std::string& path, const std::string& msg) { throw IoError(path + ": " + msg); }

[[noreturn]] inline void fail_line(const std::string& path, size_t line, const std::string& msg) {
  throw IoError(path + ":" + std::to_string(line) + ": " + msg);
}

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

/// Token at p, shortened for error messages.
inline std::string show_token(const char* p, const char* e) {
  const char* t = token_end(p, e);
  std::string s(p, t);
  if (s.size() > 40) s = s.substr(0, 40) + "...";
  return "'" + s + "'";
}

/// Parses a double starting exactly at p. Returns the end of the number or nullptr.
inline const char* parse_double(const char* p, const char* e, double& out) {
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

/// Parses an integer starting exactly at p. Returns the end or nullptr (also on overflow).
inline const char* parse_int(const char* p, const char* e, int64_t& out) {
  const char* s = p;
  if (s < e && *s == '+') {
    ++s;
    if (s < e && *s == '-') return nullptr;
  }
  const std::from_chars_result r = std::from_chars(s, e, out);
  if (r.ec != std::errc()) return nullptr;
  return r.ptr;
}

/// Moves a flat buffer into an Eigen matrix with 3 columns.
template <class Mat, class T>
Mat to_matrix(const std::vector<T>& v) {
  Mat m(static_cast<Eigen::Index>(v.size() / 3), 3);
  if (!v.empty()) std::memcpy(m.data(), v.data(), v.size() * sizeof(T));
  return m;
}

inline void fan_triangulate(const std::vector<int>& poly, std::vector<int>& F) {
  for (size_t k = 1; k + 1 < poly.size(); ++k) {
    F.push_back(poly[0]);
    F.push_back(poly[k]);
    F.push_back(poly[k + 1]);
  }
}

inline bool host_little_endian() {
  const uint16_t x = 1;
  unsigned char c;
  std::memcpy(&c, &x, 1);
  return c == 1;
}

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

/// The formats: readers take the whole file's bytes, writers the mesh already checked by write_mesh.
MeshData read_obj(const std::string& path, const std::string& buf);
MeshData read_off(const std::string& path, const std::string& buf);
MeshData read_ply(const std::string& path, const std::string& buf);
void write_obj(Writer& w, const MatX3d& V, const MatX3i& F, const MatX3d* N);
void write_off(Writer& w, const MatX3d& V, const MatX3i& F, const MatX3d* N);
void write_ply(Writer& w, const MatX3d& V, const MatX3i& F, const MatX3d* N);

}  // namespace dgmesh::detail
