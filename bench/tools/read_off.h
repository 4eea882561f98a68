// Plain OFF reader shared by the bench's CGAL tools: it keeps the file's vertex order, so vertex
// indices and per-vertex results match the bench's numpy arrays.
#pragma once
#include <cstddef>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

template <class Mesh>
bool read_off_in_order(const char* path, Mesh& m) {
  std::ifstream in(path);
  std::string head;
  std::size_t nv = 0, nf = 0, ne = 0;
  if (!(in >> head) || head != "OFF" || !(in >> nv >> nf >> ne)) return false;
  std::vector<typename Mesh::Vertex_index> vs(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    double x, y, z;
    if (!(in >> x >> y >> z)) return false;
    vs[i] = m.add_vertex(typename Mesh::Point(x, y, z));
  }
  for (std::size_t i = 0; i < nf; ++i) {
    std::size_t k, a, b, c;
    if (!(in >> k >> a >> b >> c) || k != 3 || a >= nv || b >= nv || c >= nv) return false;
    if (m.add_face(vs[a], vs[b], vs[c]) == Mesh::null_face()) {
      std::cerr << "non-manifold face " << i << "\n";
      return false;
    }
  }
  return true;
}
