// Bench-only reference (not part of the CMake build or CI): CGAL's hole filling and fairing on the
// same holes as bench/workloads/fair.py, so the restoration table compares against a measured
// figure per hole. Compiled on demand by the bench with g++ into .cache/ (needs libcgal-dev).
//
//   cgal_fair_hole trf  in.off rim_vertex out.off   triangulate_refine_and_fair_hole on the border
//                                                    loop through rim_vertex; writes the patch faces
//   cgal_fair_hole tr   in.off rim_vertex out.off   triangulate_and_refine_hole (no fairing): a fresh
//                                                    flat fill; writes the whole mesh, patch faces last
//   cgal_fair_hole fair in.off mask.txt  out.off    PMP::fair (cotangent weights, continuity 1) of the
//                                                    vertices listed in mask.txt; writes all vertices
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/fair.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "read_off.h"

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<K::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: cgal_fair_hole trf|fair in.off rim_vertex|mask.txt out.off\n";
    return 2;
  }
  const std::string mode = argv[1];
  Mesh m;
  if (!read_off_in_order(argv[2], m)) {
    std::cerr << "cannot read " << argv[2] << "\n";
    return 1;
  }
  std::ofstream out(argv[4]);
  out.precision(17);
  if (mode == "trf" || mode == "tr") {
    Mesh::Vertex_index v(static_cast<Mesh::size_type>(std::atoi(argv[3])));
    Mesh::Halfedge_index border;
    for (auto h : CGAL::halfedges_around_target(m.halfedge(v), m))
      if (m.is_border(h)) border = h;
    if (border == Mesh::null_halfedge()) {
      std::cerr << "rim vertex is not on a border\n";
      return 1;
    }
    std::vector<Mesh::Face_index> faces;
    std::vector<Mesh::Vertex_index> added;
    bool ok = true;
    if (mode == "trf") {
      ok = std::get<0>(
          PMP::triangulate_refine_and_fair_hole(m, border, std::back_inserter(faces), std::back_inserter(added)));
    } else {
      PMP::triangulate_and_refine_hole(m, border, std::back_inserter(faces), std::back_inserter(added));
    }
    // Indices into the mesh's vertex list (all vertices written; new ones follow the input's).
    // trf: the patch faces only; tr: every face, the patch faces last.
    std::vector<Mesh::Face_index> rest;
    if (mode == "tr") {
      std::vector<char> in_patch(m.number_of_faces(), 0);
      for (auto f : faces) in_patch[static_cast<size_t>(f)] = 1;
      for (auto f : m.faces())
        if (!in_patch[static_cast<size_t>(f)]) rest.push_back(f);
    }
    out << "OFF\n" << m.number_of_vertices() << " " << rest.size() + faces.size() << " 0\n";
    for (auto vi : m.vertices()) out << m.point(vi) << "\n";
    rest.insert(rest.end(), faces.begin(), faces.end());
    for (auto f : rest) {
      out << 3;
      for (auto w : CGAL::vertices_around_face(m.halfedge(f), m)) out << " " << static_cast<int>(w);
      out << "\n";
    }
    std::cerr << "fair " << (ok ? "ok" : "failed") << ", " << faces.size() << " faces, " << added.size()
              << " new vertices\n";
    return ok ? 0 : 3;
  }
  if (mode == "fair") {
    std::ifstream in(argv[3]);
    std::vector<Mesh::Vertex_index> vs;
    int i;
    while (in >> i) vs.emplace_back(static_cast<Mesh::size_type>(i));
    const bool ok = PMP::fair(m, vs);
    out << "OFF\n" << m.number_of_vertices() << " 0 0\n";
    for (auto vi : m.vertices()) out << m.point(vi) << "\n";
    std::cerr << "fair " << (ok ? "ok" : "failed") << ", " << vs.size() << " vertices\n";
    return ok ? 0 : 3;
  }
  std::cerr << "unknown mode " << mode << "\n";
  return 2;
}
