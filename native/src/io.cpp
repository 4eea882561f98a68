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
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

#include "dgmesh/detail/io_common.h"

namespace dgmesh {
namespace {

namespace fs = std::filesystem;

using detail::fail;
using detail::is_ws;
using detail::kMaxIndexCount;
using detail::read_obj;
using detail::read_off;
using detail::read_ply;
using detail::write_obj;
using detail::write_off;
using detail::write_ply;
using detail::Writer;

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

}  // namespace

MeshData read_mesh(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != ".obj" && ext != ".off" && ext != ".ply")
    fail(path, "unsupported file extension '" + ext + "' (expected .obj, .off or .ply)");
  const std::string buf = read_whole_file(path);
  if (std::all_of(buf.begin(), buf.end(), [](char c) { return is_ws(c); })) fail(path, "empty file");
  MeshData d = ext == ".obj" ? read_obj(path, buf) : ext == ".off" ? read_off(path, buf) : read_ply(path, buf);
  // Every function rejects NaN or inf coordinates; say so where they come from.
  for (Eigen::Index i = 0; i < d.V.rows(); ++i)
    if (!d.V.row(i).allFinite()) fail(path, "vertex " + std::to_string(i) + " has a NaN or infinite coordinate");
  return d;
}

void write_mesh(const std::string& path, const MatX3d& V, const MatX3i& F, const MatX3d* N) {
  const std::string ext = lower_extension(path);
  if (ext != ".obj" && ext != ".off" && ext != ".ply")
    fail(path, "unsupported file extension '" + ext + "' (expected .obj, .off or .ply)");
  if (N && N->rows() != V.rows())
    fail(path,
         "normals have " + std::to_string(N->rows()) + " rows but there are " + std::to_string(V.rows()) + " vertices");
  if (V.rows() > kMaxIndexCount || F.rows() > kMaxIndexCount) fail(path, "mesh too large to write");
  for (Eigen::Index i = 0; i < F.rows(); ++i)
    for (int k = 0; k < 3; ++k)
      if (F(i, k) < 0 || F(i, k) >= V.rows())
        fail(path, "cannot write: face " + std::to_string(i) + " has vertex index " + std::to_string(F(i, k)) +
                       " out of range (" + std::to_string(V.rows()) + " vertices)");
  Writer w(path);
  if (ext == ".obj")
    write_obj(w, V, F, N);
  else if (ext == ".off")
    write_off(w, V, F, N);
  else
    write_ply(w, V, F, N);
  w.close();
}

}  // namespace dgmesh
