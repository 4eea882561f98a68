// Tests for dgmesh/io.h: round trips, format features and malformed input.
#include "dgmesh/io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using dgmesh::IoError;
using dgmesh::MatX3d;
using dgmesh::MatX3i;
using dgmesh::MeshData;
using dgmesh::read_mesh;
using dgmesh::write_mesh;

namespace {

class IoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::random_device rd;
    std::string name = std::string(info->test_suite_name()) + "." + info->name();
    std::replace(name.begin(), name.end(), '/', '_');
    // A flat directory per test: a shared parent removed by one test's TearDown raced with
    // another's create_directories under `ctest -j`.
    dir_ = fs::temp_directory_path() / ("dgmesh_test_io_" + name + "_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write_file(const std::string& name, const std::string& content) const {
    const std::string p = path(name);
    std::ofstream f(p, std::ios::binary);
    f.write(content.data(), static_cast<std::streamsize>(content.size()));
    return p;
  }
  static std::string read_file(const std::string& p) {
    std::ifstream f(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  fs::path dir_;
};

// Expects IoError whose message names the file (and contains `needle` if given).
void expect_io_error(const std::string& p, const std::string& needle = "") {
  try {
    read_mesh(p);
    ADD_FAILURE() << "no IoError for " << p;
  } catch (const IoError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(p), std::string::npos) << msg;
    if (!needle.empty()) {
      EXPECT_NE(msg.find(needle), std::string::npos) << "expected '" << needle << "' in: " << msg;
    }
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type for " << p << ": " << e.what();
  }
}

// Reads a file that may be malformed: must either succeed (with a consistent mesh) or throw IoError.
void read_or_io_error(const std::string& p) {
  try {
    const MeshData m = read_mesh(p);
    for (Eigen::Index i = 0; i < m.F.rows(); ++i)
      for (int k = 0; k < 3; ++k) {
        ASSERT_GE(m.F(i, k), 0);
        ASSERT_LT(m.F(i, k), m.V.rows());
      }
    if (m.N.rows()) {
      ASSERT_EQ(m.N.rows(), m.V.rows());
    }
  } catch (const IoError&) {}
}

// A mesh with awkward doubles (non-terminating binary fractions, tiny/huge exponents, negative zero).
void test_mesh(MatX3d& V, MatX3i& F, MatX3d& N) {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 50;
  V.resize(n, 3);
  N.resize(n, 3);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      V(i, k) = u(rng) * std::pow(10.0, (i % 7) * 40 - 120);
      N(i, k) = u(rng);
    }
  V(0, 0) = 1.0 / 3.0;
  V(0, 1) = -0.0;
  V(0, 2) = std::numeric_limits<double>::denorm_min();
  V(1, 0) = std::numeric_limits<double>::max();
  V(1, 1) = std::numeric_limits<double>::lowest();
  V(1, 2) = 0.1;
  F.resize(n - 2, 3);
  for (int i = 0; i < n - 2; ++i) F.row(i) << i, (i * 7 + 1) % n, (i * 13 + 2) % n;
}

void expect_same(const MatX3d& A, const MatX3d& B) {
  ASSERT_EQ(A.rows(), B.rows());
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(A(i, k), B(i, k)) << "row " << i << " col " << k;
      EXPECT_EQ(std::signbit(A(i, k)), std::signbit(B(i, k))) << "row " << i << " col " << k;
    }
}

void expect_same(const MatX3i& A, const MatX3i& B) {
  ASSERT_EQ(A.rows(), B.rows());
  EXPECT_TRUE(A == B);
}

// Little helpers for building binary PLY bodies.
template <class T>
void put_bytes(std::string& s, T v, bool big_endian) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  const uint16_t one = 1;
  unsigned char first;
  std::memcpy(&first, &one, 1);
  const bool host_le = first == 1;
  if (host_le == big_endian) std::reverse(b, b + sizeof(T));
  s.append(reinterpret_cast<const char*>(b), sizeof(T));
}

// ------------------------------------------------------------------------------------------------
// Round trips

class RoundTrip : public IoTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(RoundTrip, WithoutNormals) {
  MatX3d V, N;
  MatX3i F;
  test_mesh(V, F, N);
  const std::string p = path("mesh" + GetParam());
  write_mesh(p, V, F);
  const MeshData m = read_mesh(p);
  expect_same(m.V, V);
  expect_same(m.F, F);
  EXPECT_EQ(m.N.rows(), 0);
}

TEST_P(RoundTrip, WithNormals) {
  MatX3d V, N;
  MatX3i F;
  test_mesh(V, F, N);
  const std::string p = path("mesh" + GetParam());
  write_mesh(p, V, F, &N);
  const MeshData m = read_mesh(p);
  expect_same(m.V, V);
  expect_same(m.F, F);
  expect_same(m.N, N);
}

TEST_P(RoundTrip, EmptyMesh) {
  // An empty mesh is written with a valid header (the OBJ has a comment line), so it reads back.
  const std::string p = path("empty" + GetParam());
  write_mesh(p, MatX3d(0, 3), MatX3i(0, 3));
  const MeshData m = read_mesh(p);
  EXPECT_EQ(m.V.rows(), 0);
  EXPECT_EQ(m.F.rows(), 0);
}

TEST_P(RoundTrip, UppercaseExtension) {
  MatX3d V, N;
  MatX3i F;
  test_mesh(V, F, N);
  std::string ext = GetParam();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](char c) { return static_cast<char>(std::toupper(c)); });
  const std::string p = path("MESH" + ext);
  write_mesh(p, V, F);
  const MeshData m = read_mesh(p);
  expect_same(m.V, V);
  expect_same(m.F, F);
}

// Every truncation of a valid file and many single-byte corruptions: IoError or a valid mesh.
TEST_P(RoundTrip, TruncationsAndCorruptionsNeverCrash) {
  MatX3d V, N;
  MatX3i F;
  test_mesh(V, F, N);
  V.conservativeResize(6, 3);
  N.conservativeResize(6, 3);
  F.resize(4, 3);
  F << 0, 1, 2, 2, 3, 4, 4, 5, 0, 1, 3, 5;
  const std::string good = path("good" + GetParam());
  write_mesh(good, V, F, &N);
  const std::string bytes = read_file(good);
  const std::string bad = path("bad" + GetParam());
  for (size_t len = 0; len < bytes.size(); ++len) {
    write_file("bad" + GetParam(), bytes.substr(0, len));
    read_or_io_error(bad);
  }
  std::mt19937 rng(7);
  const char repl[] = {'\0', '\n', ' ', '-', '9', 'x', '/', '#', '\xff', '\x7f', '3', '.'};
  for (int it = 0; it < 2000; ++it) {
    std::string b = bytes;
    const int nflips = 1 + static_cast<int>(rng() % 3);
    for (int j = 0; j < nflips; ++j) b[rng() % b.size()] = repl[rng() % sizeof repl];
    write_file("bad" + GetParam(), b);
    read_or_io_error(bad);
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, RoundTrip, ::testing::Values(".obj", ".off", ".ply"),
                         [](const ::testing::TestParamInfo<std::string>& i) { return i.param.substr(1); });

TEST_F(IoTest, PlyWriterIsBinaryLittleEndianDouble) {
  MatX3d V(3, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  MatX3i F(1, 3);
  F << 0, 1, 2;
  const std::string p = path("t.ply");
  write_mesh(p, V, F);
  const std::string s = read_file(p);
  EXPECT_NE(s.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(s.find("property double x"), std::string::npos);
  EXPECT_NE(s.find("property list uchar int vertex_indices"), std::string::npos);
  const size_t hdr = s.find("end_header\n") + 11;
  EXPECT_EQ(s.size() - hdr, 3u * 24u + 13u);
}

TEST_F(IoTest, TextWritersUseFullPrecision) {
  MatX3d V(3, 3);
  V << 0.1, 1.0 / 3.0, 2, 1, 0, 0, 0, 1, 0;
  MatX3i F(1, 3);
  F << 0, 1, 2;
  write_mesh(path("t.obj"), V, F);
  write_mesh(path("t.off"), V, F);
  char expect[128];
  std::snprintf(expect, sizeof expect, "%.17g %.17g %.17g\n", 0.1, 1.0 / 3.0, 2.0);
  EXPECT_NE(read_file(path("t.obj")).find(std::string("v ") + expect), std::string::npos);
  EXPECT_NE(read_file(path("t.off")).find(expect), std::string::npos);
}

TEST_F(IoTest, WriterRejectsBadInput) {
  MatX3d V(3, 3);
  V.setZero();
  MatX3i F(1, 3);
  F << 0, 1, 3;
  EXPECT_THROW(write_mesh(path("a.obj"), V, F), IoError);
  F << 0, 1, -1;
  EXPECT_THROW(write_mesh(path("a.ply"), V, F), IoError);
  F << 0, 1, 2;
  MatX3d N(2, 3);
  N.setZero();
  EXPECT_THROW(write_mesh(path("a.off"), V, F, &N), IoError);
  EXPECT_THROW(write_mesh(path("a.stl"), V, F), IoError);
  EXPECT_THROW(write_mesh((dir_ / "no_such_dir" / "a.obj").string(), V, F), IoError);
}

// ------------------------------------------------------------------------------------------------
// OBJ features

TEST_F(IoTest, ObjPolygonsAreFanTriangulated) {
  const std::string p = write_file("poly.obj",
                                   "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\n"
                                   "f 1 2 3 4\n"
                                   "f 1 2 3 4 5\n"
                                   "f 3 4 5\n");
  const MeshData m = read_mesh(p);
  ASSERT_EQ(m.V.rows(), 5);
  MatX3i expect(6, 3);
  expect << 0, 1, 2, 0, 2, 3,     // quad
      0, 1, 2, 0, 2, 3, 0, 3, 4,  // pentagon
      2, 3, 4;
  expect_same(m.F, expect);
}

TEST_F(IoTest, ObjSlashesNegativeIndicesAndIgnoredStatements) {
  const std::string p = write_file("slash.obj",
                                   "# comment\r\n"
                                   "mtllib scene.mtl\r\n"
                                   "o thing\r\n"
                                   "g group1\r\n"
                                   "v 0 0 0 1.0\r\n"             // w
                                   "v 1 0 0 0.5 0.25 0.125\r\n"  // vertex colors
                                   "v 0 1 0\r\n"
                                   "v 1 1 0   # trailing comment\r\n"
                                   "vt 0 0\r\nvt 1 0\r\nvt 0 1\r\nvn 0 0 1\r\n"
                                   "usemtl red\r\n"
                                   "s off\r\n"
                                   "f 1/1 2/2 3/3\r\n"
                                   "f 2//1 4//1 3//1\r\n"
                                   "f -4/-3 -3/-2 -1/-1\r\n"
                                   "\tf\t1   2\t4 \r\n"
                                   "l 1 2\r\n");
  const MeshData m = read_mesh(p);
  MatX3d V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  expect_same(m.V, V);
  MatX3i F(4, 3);
  F << 0, 1, 2, 1, 3, 2, 0, 1, 3, 0, 1, 3;
  expect_same(m.F, F);
  EXPECT_EQ(m.N.rows(), 0);  // corner normals only on some faces: incomplete, dropped
}

TEST_F(IoTest, ObjNegativeIndicesAreRelativeToCurrentCount) {
  const std::string p = write_file("rel.obj",
                                   "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
                                   "v 5 5 5\nv 6 5 5\nv 5 6 5\nf -3 -2 -1\n");
  const MeshData m = read_mesh(p);
  MatX3i F(2, 3);
  F << 0, 1, 2, 3, 4, 5;
  expect_same(m.F, F);
}

TEST_F(IoTest, ObjCornerNormalsMapToVertices) {
  const std::string p = write_file("n.obj",
                                   "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                                   "vn 0 0 1\nvn 0 0 -1\nvn 0 0 1\n"
                                   "f 1//1 2//3 3//1\n"
                                   "f 2//1 4//2 3//3\n");  // vertex 2 gets normals 3 and 1 (equal values)
  const MeshData m = read_mesh(p);
  ASSERT_EQ(m.N.rows(), 4);
  MatX3d N(4, 3);
  N << 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, -1;
  expect_same(m.N, N);
}

TEST_F(IoTest, ObjInconsistentNormalsAreDropped) {
  const std::string p = write_file("n.obj",
                                   "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                                   "vn 0 0 1\nvn 0 0 -1\n"
                                   "f 1//1 2//1 3//1\n"
                                   "f 2//2 4//2 3//2\n");
  const MeshData m = read_mesh(p);
  EXPECT_EQ(m.F.rows(), 2);
  EXPECT_EQ(m.N.rows(), 0);
}

TEST_F(IoTest, ObjErrors) {
  expect_io_error(write_file("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"), ":4:");
  expect_io_error(write_file("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"), ":4:");
  expect_io_error(write_file("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n"), ":4:");
  expect_io_error(write_file("nrange.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//2 3//1\n"), ":5:");
  expect_io_error(write_file("nan.obj", "v 0 0 0\nv 1 zero 0\n"), ":2:");
  expect_io_error(write_file("nan2.obj", "v 0 0 0\nv 1 0.5.5 0\n"), "0.5.5");
  // NaN and inf parse, but no function takes them: read_mesh says so (issue #34).
  expect_io_error(write_file("nanv.obj", "v 0 0 0\nv 1 0 0\nv nan 0 0\nf 1 2 3\n"), "vertex 2 has a NaN");
  expect_io_error(write_file("infv.off", "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n"), "vertex 1 has a NaN");
  expect_io_error(write_file("short.obj", "v 0 0\n"), ":1:");
  expect_io_error(write_file("badf.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n"), ":4:");
  expect_io_error(write_file("badf2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n"), ":4:");
  expect_io_error(write_file("two.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n"), "2 vertices");
  expect_io_error(write_file("huge.obj", "v 0 0 0\nf 1 2 99999999999999999999999\n"), ":2:");
}

// ------------------------------------------------------------------------------------------------
// OFF features

TEST_F(IoTest, OffVariants) {
  // Counts on the OFF line, comments, blank lines, colors after faces, polygons.
  const std::string p = write_file("a.off",
                                   "OFF 4 2 0 # counts here\n"
                                   "# a comment\n"
                                   "\n"
                                   "0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
                                   "4 0 1 2 3 255 0 0\n"
                                   "3 0 2 3  0.5 0.5 0.5 1\n");
  MeshData m = read_mesh(p);
  ASSERT_EQ(m.V.rows(), 4);
  MatX3i F(3, 3);
  F << 0, 1, 2, 0, 2, 3, 0, 2, 3;
  expect_same(m.F, F);
  EXPECT_EQ(m.N.rows(), 0);

  // COFF: per-vertex colors ignored.
  m = read_mesh(write_file("c.off", "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n"));
  EXPECT_EQ(m.V(1, 0), 1.0);
  EXPECT_EQ(m.F.rows(), 1);
  EXPECT_EQ(m.N.rows(), 0);

  // CNOFF: normals come before colors.
  m = read_mesh(write_file(
      "cn.off", "CNOFF\r\n3 1 3\r\n0 0 0 0 0 1 1 0 0\r\n1 0 0 0 0 1 0 1 0\r\n0 1 0 0 1 0 0 0 1\r\n3 0 1 2\r\n"));
  ASSERT_EQ(m.N.rows(), 3);
  EXPECT_EQ(m.N(2, 1), 1.0);
  EXPECT_EQ(m.N(2, 2), 0.0);

  // Header-less OFF (counts first) and counts on a separate line after a comment.
  m = read_mesh(write_file("h.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_EQ(m.F.rows(), 1);
  m = read_mesh(write_file("k.off", "OFF\n# comment between\n3 1\n0 0 0\n1 0 0\n0 1 0\n3 2 1 0\n"));
  EXPECT_EQ(m.F(0, 0), 2);
}

TEST_F(IoTest, OffErrors) {
  expect_io_error(write_file("hdr.off", "FOO\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), ":1:");
  expect_io_error(write_file("4d.off", "4OFF\n3 1 0\n"), "4OFF");
  expect_io_error(write_file("bin.off", "OFF BINARY\n"), "binary");
  expect_io_error(write_file("nocount.off", "OFF\n"), "counts");
  expect_io_error(write_file("trunc.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n"), "faces");
  expect_io_error(write_file("more.off", "OFF\n30 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  expect_io_error(write_file("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"), ":6:");
  expect_io_error(write_file("negidx.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n"), ":6:");
  expect_io_error(write_file("nan.off", "OFF\n3 1 0\n0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n"), ":4:");
  expect_io_error(write_file("two.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), "2 vertices");
  expect_io_error(write_file("few.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n"), ":6:");
  expect_io_error(write_file("huge.off", "OFF\n1000000000000000000 1 0\n0 0 0\n"), "exceed");
  expect_io_error(write_file("huge2.off", "OFF\n3 2000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), "exceed");
  expect_io_error(write_file("over.off", "OFF\n99999999999999999999999 1 0\n"), ":2:");
  expect_io_error(write_file("negc.off", "OFF\n-3 1 0\n"), ":2:");
}

// ------------------------------------------------------------------------------------------------
// PLY features

TEST_F(IoTest, PlyAsciiWithExtraPropertiesAndElements) {
  const std::string p = write_file("extra.ply",
                                   "ply\r\n"
                                   "format ascii 1.0\r\n"
                                   "comment made by hand\r\n"
                                   "obj_info whatever\r\n"
                                   "element material 2\r\n"
                                   "property uchar red\r\n"
                                   "property list uchar float weights\r\n"
                                   "element vertex 4\r\n"
                                   "property float confidence\r\n"
                                   "property double z\r\n"
                                   "property short y\r\n"
                                   "property float x\r\n"
                                   "property float nx\r\n"
                                   "property float ny\r\n"
                                   "property float nz\r\n"
                                   "property list int int adjacency\r\n"
                                   "property uchar red\r\n"
                                   "element face 2\r\n"
                                   "property int flags\r\n"
                                   "property list uchar uint vertex_index\r\n"
                                   "property list uchar float texcoord\r\n"
                                   "element edge 1\r\n"
                                   "property int vertex1\r\n"
                                   "property int vertex2\r\n"
                                   "end_header\r\n"
                                   "255 3 0.5 0.25 1\r\n"
                                   "0 0\r\n"
                                   "0.9 0.5 0 0 0 0 1 2 1 2 255\r\n"
                                   "0.9 0.5 0 1 0 0 1 0 7\r\n"
                                   "0.9 0.5 1 1 0 0 1 1 3 0\r\n"
                                   "0.9 -0.5 1 0 0 0 -1 0 +9\r\n"
                                   "7 4 0 1 2 3 0\r\n"
                                   "8 3 3 2 1 6 0 0 1 0 1 1\r\n"
                                   "0 1\r\n");
  const MeshData m = read_mesh(p);
  MatX3d V(4, 3);
  V << 0, 0, 0.5, 1, 0, 0.5, 1, 1, 0.5, 0, 1, -0.5;
  expect_same(m.V, V);
  MatX3i F(3, 3);
  F << 0, 1, 2, 0, 2, 3, 3, 2, 1;
  expect_same(m.F, F);
  ASSERT_EQ(m.N.rows(), 4);
  EXPECT_EQ(m.N(3, 2), -1.0);
  EXPECT_EQ(m.N(0, 2), 1.0);
}

TEST_F(IoTest, PlyPartialNormalsAreIgnored) {
  const std::string p = write_file("pn.ply",
                                   "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                   "property float z\nproperty float nx\nelement face 1\n"
                                   "property list uchar int vertex_indices\nend_header\n"
                                   "0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n");
  const MeshData m = read_mesh(p);
  EXPECT_EQ(m.V.rows(), 3);
  EXPECT_EQ(m.N.rows(), 0);
}

// Builds a binary PLY with extra elements/properties and mixed types in the given byte order.
std::string binary_ply(bool big_endian) {
  std::string s = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\n"
                  "comment test\n"
                  "element camera 1\n"
                  "property list ushort double params\n"
                  "property char id\n"
                  "element vertex 4\n"
                  "property float x\n"
                  "property uchar red\n"
                  "property float y\n"
                  "property float z\n"
                  "property list uchar int tags\n"
                  "property int16 nx\n"
                  "property int16 ny\n"
                  "property int16 nz\n"
                  "element face 2\n"
                  "property list char uint32 vertex_indices\n"
                  "property ushort material\n"
                  "property list uint float uv\n"
                  "end_header\n";
  // camera: 2 params + id
  put_bytes<uint16_t>(s, 2, big_endian);
  put_bytes<double>(s, 1.5, big_endian);
  put_bytes<double>(s, 2.5, big_endian);
  put_bytes<int8_t>(s, -3, big_endian);
  const float xyz[4][3] = {{0.f, 0.f, 0.f}, {1.f, 0.f, 0.25f}, {1.f, 1.f, 0.5f}, {0.f, 1.f, -2.75f}};
  for (int i = 0; i < 4; ++i) {
    put_bytes<float>(s, xyz[i][0], big_endian);
    put_bytes<uint8_t>(s, 200, big_endian);
    put_bytes<float>(s, xyz[i][1], big_endian);
    put_bytes<float>(s, xyz[i][2], big_endian);
    put_bytes<uint8_t>(s, static_cast<uint8_t>(i), big_endian);  // i tags
    for (int k = 0; k < i; ++k) put_bytes<int32_t>(s, 1000 + k, big_endian);
    put_bytes<int16_t>(s, 0, big_endian);
    put_bytes<int16_t>(s, static_cast<int16_t>(i - 2), big_endian);
    put_bytes<int16_t>(s, 1, big_endian);
  }
  // face 0: quad, face 1: triangle
  put_bytes<int8_t>(s, 4, big_endian);
  for (uint32_t v : {0u, 1u, 2u, 3u}) put_bytes<uint32_t>(s, v, big_endian);
  put_bytes<uint16_t>(s, 65535, big_endian);
  put_bytes<uint32_t>(s, 2, big_endian);
  put_bytes<float>(s, 0.5f, big_endian);
  put_bytes<float>(s, 0.25f, big_endian);
  put_bytes<int8_t>(s, 3, big_endian);
  for (uint32_t v : {3u, 1u, 0u}) put_bytes<uint32_t>(s, v, big_endian);
  put_bytes<uint16_t>(s, 1, big_endian);
  put_bytes<uint32_t>(s, 0, big_endian);
  return s;
}

void check_binary_ply(const MeshData& m) {
  MatX3d V(4, 3);
  V << 0, 0, 0, 1, 0, 0.25, 1, 1, 0.5, 0, 1, -2.75;
  expect_same(m.V, V);
  MatX3i F(3, 3);
  F << 0, 1, 2, 0, 2, 3, 3, 1, 0;
  expect_same(m.F, F);
  ASSERT_EQ(m.N.rows(), 4);
  MatX3d N(4, 3);
  N << 0, -2, 1, 0, -1, 1, 0, 0, 1, 0, 1, 1;
  expect_same(m.N, N);
}

TEST_F(IoTest, PlyBinaryLittleEndianWithExtraPropertiesAndElements) {
  check_binary_ply(read_mesh(write_file("le.ply", binary_ply(false))));
}

TEST_F(IoTest, PlyBinaryBigEndian) { check_binary_ply(read_mesh(write_file("be.ply", binary_ply(true)))); }

TEST_F(IoTest, PlyBinaryTruncatedAtEveryByte) {
  const std::string s = binary_ply(true);
  const size_t hdr = s.find("end_header\n") + 11;
  for (size_t len = 0; len < s.size(); ++len) {
    const std::string p = write_file("t.ply", s.substr(0, len));
    if (len < hdr)
      expect_io_error(p);
    else
      expect_io_error(p, "truncated");
  }
  // Trailing garbage after the data is tolerated.
  check_binary_ply(read_mesh(write_file("t.ply", s + "xyz")));
}

TEST_F(IoTest, PlyErrors) {
  const std::string hdr =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string verts = "0 0 0\n1 0 0\n0 1 0\n";
  // Sanity: the base file is fine.
  EXPECT_EQ(read_mesh(write_file("ok.ply", hdr + verts + "3 0 1 2\n")).F.rows(), 1);

  expect_io_error(write_file("magic.ply", "plx\n" + hdr.substr(4) + verts + "3 0 1 2\n"), "magic");
  expect_io_error(write_file("noend.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"), "end_header");
  expect_io_error(write_file("nofmt.ply",
                             "ply\nelement vertex 0\nproperty float x\nproperty float y\n"
                             "property float z\nend_header\n"),
                  "format");
  expect_io_error(write_file("fmt.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n"), ":2:");
  expect_io_error(write_file("kw.ply", "ply\nformat ascii 1.0\nelemnt vertex 3\nend_header\n"), ":3:");
  expect_io_error(write_file("prop.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n"), ":3:");
  expect_io_error(write_file("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n"),
                  "float128");
  expect_io_error(write_file("ltype.ply",
                             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                             "property float z\nelement face 1\nproperty list float int vertex_indices\n"
                             "end_header\n0 0 0\n"),
                  ":8:");
  expect_io_error(write_file("ftype.ply",
                             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                             "property float z\nelement face 1\nproperty list uchar float vertex_indices\n"
                             "end_header\n0 0 0\n"),
                  "integer");
  expect_io_error(write_file("noxyz.ply",
                             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                             "end_header\n0 0\n"),
                  "x, y, z");
  expect_io_error(write_file("novert.ply", "ply\nformat ascii 1.0\nend_header\n"), "vertex");
  expect_io_error(write_file("cnt.ply", "ply\nformat ascii 1.0\nelement vertex -1\nend_header\n"), ":3:");
  expect_io_error(write_file("cnt2.ply", "ply\nformat ascii 1.0\nelement vertex abc\nend_header\n"), ":3:");

  // Data errors.
  expect_io_error(write_file("range.ply", hdr + verts + "3 0 1 3\n"), "out of range");
  expect_io_error(write_file("negidx.ply", hdr + verts + "3 0 1 -1\n"), "out of range");
  expect_io_error(write_file("two.ply", hdr + verts + "2 0 1\n"), "2 vertices");
  expect_io_error(write_file("nan.ply", hdr + "0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"), ":11:");
  expect_io_error(write_file("nanidx.ply", hdr + verts + "3 0 1 2.5\n"), ":13:");
  expect_io_error(write_file("short.ply", hdr + verts), "truncated");
  expect_io_error(write_file("short2.ply", hdr + verts + "3 0 1\n"), "unexpected end");
  expect_io_error(write_file("more.ply", hdr + "0 0 0\n1 0 0\n"), "");
}

TEST_F(IoTest, PlyHugeCountsAreRejectedBeforeAllocating) {
  const std::string tail = "property float x\nproperty float y\nproperty float z\nend_header\n";
  for (const char* fmt : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    SCOPED_TRACE(fmt);
    const std::string f = std::string("ply\nformat ") + fmt + " 1.0\n";
    expect_io_error(write_file("h1.ply", f + "element vertex 1000000000000000000\n" + tail + "0 0 0\n"), ":3:");
    expect_io_error(write_file("h2.ply", f + "element vertex 99999999999999999999999\n" + tail), ":3:");
    expect_io_error(write_file("h3.ply", f + "element vertex 1000000\n" + tail + "0 0 0\n"), "exceed");
    expect_io_error(write_file("h4.ply", f + "element vertex 0\n" + tail.substr(0, tail.size() - 11) +
                                             "element face 1000000000000000000\n"
                                             "property list uchar int vertex_indices\nend_header\n"),
                    ":7:");
    // An unrelated element with a huge count.
    expect_io_error(write_file("h5.ply", f + "element vertex 0\n" + tail.substr(0, tail.size() - 11) +
                                             "element junk 1000000000000000000\nproperty double a\nend_header\n"),
                    "junk");
  }
  // A huge list length in binary data.
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n";
  for (int i = 0; i < 9; ++i) put_bytes<float>(s, 0.f, false);
  put_bytes<uint32_t>(s, 0xFFFFFFFFu, false);
  put_bytes<int32_t>(s, 0, false);
  expect_io_error(write_file("hl.ply", s), "truncated");
  // Same in ASCII.
  expect_io_error(write_file("hla.ply",
                             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\nelement face 1\nproperty list uint int vertex_indices\n"
                             "end_header\n0 0 0\n0 0 0\n0 0 0\n4000000000 0 1 2\n"),
                  "unexpected end");
}

// ------------------------------------------------------------------------------------------------
// Generic errors

TEST_F(IoTest, EmptyFiles) {
  for (const char* ext : {".obj", ".off", ".ply", ".OBJ"})
    expect_io_error(write_file(std::string("e") + ext, ""), "empty");
  for (const char* ext : {".obj", ".off", ".ply"})
    expect_io_error(write_file(std::string("w") + ext, " \n\r\n\t"), "empty");
}

// A text file named .obj has no OBJ statement at all: an error, not an empty mesh. Unknown
// statements in a real OBJ are still skipped.
TEST_F(IoTest, TextFileIsNotAnObj) {
  expect_io_error(write_file("notes.obj", "# list\nhello world\nv is a letter\n"), "invalid number");
  expect_io_error(write_file("junk.obj", "hello world\nsecond line\n"), "not an OBJ file: 'hello'");
  const MeshData m = read_mesh(write_file("ok.obj", "myext 1 2\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
  EXPECT_EQ(m.F.rows(), 1);
  EXPECT_EQ(read_mesh(write_file("c.obj", "# only a comment\ng group\n")).V.rows(), 0);
}

TEST_F(IoTest, MissingFileAndBadExtension) {
  expect_io_error(path("does_not_exist.obj"), "not found");
  expect_io_error(path("does_not_exist.ply"), "not found");
  expect_io_error(write_file("mesh.stl", "solid x\n"), "extension");
  expect_io_error(write_file("noext", "v 0 0 0\n"), "extension");
  fs::create_directories(path("dir.obj"));
  expect_io_error(path("dir.obj"), "directory");
}

// A larger mesh through all three formats (exercises the chunked writer and the readers' loops).
TEST_F(IoTest, LargeGridRoundTrip) {
  const int n = 300;  // 90k vertices, ~180k triangles
  MatX3d V(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) V.row(i * n + j) << i * 0.1, j / 3.0, std::sin(i * 0.01) * std::cos(j * 0.02);
  MatX3i F(2 * (n - 1) * (n - 1), 3);
  int t = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = a + 1, c = a + n, d = c + 1;
      F.row(t++) << a, b, d;
      F.row(t++) << a, d, c;
    }
  for (const char* ext : {".obj", ".off", ".ply"}) {
    SCOPED_TRACE(ext);
    const std::string p = path(std::string("grid") + ext);
    write_mesh(p, V, F);
    const MeshData m = read_mesh(p);
    expect_same(m.V, V);
    expect_same(m.F, F);
  }
}

}  // namespace
