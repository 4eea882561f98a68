// Bench-only reference (not part of the CMake build or CI): the time of CGAL's crest-line pipeline
// on a mesh, as in CGAL's Ridges_3 example: per vertex, Monge_via_jet_fitting (d = 3, m = 3, rings
// added until at least 10 points, oriented by the vertex normal), then
// Ridge_approximation::compute_crest_ridges (Ridge_order_3). Single-threaded.
//
//   cgal_ridges in.off      prints "fit_seconds ridge_seconds n_lines"
#include <CGAL/Monge_via_jet_fitting.h>
#include <CGAL/Polygon_mesh_processing/compute_normal.h>
#include <CGAL/Ridges.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <chrono>
#include <iostream>
#include <iterator>
#include <vector>

#include "read_off.h"

using K = CGAL::Simple_cartesian<double>;
using Mesh = CGAL::Surface_mesh<K::Point_3>;
using V = Mesh::Vertex_index;
using Fitting = CGAL::Monge_via_jet_fitting<K>;
namespace PMP = CGAL::Polygon_mesh_processing;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: cgal_ridges in.off\n";
    return 2;
  }
  Mesh m;
  if (!read_off_in_order(argv[1], m)) return 1;
  auto k1 = m.add_property_map<V, double>("v:k1", 0).first, k2 = m.add_property_map<V, double>("v:k2", 0).first;
  auto b0 = m.add_property_map<V, double>("v:b0", 0).first, b3 = m.add_property_map<V, double>("v:b3", 0).first;
  auto P1 = m.add_property_map<V, double>("v:P1", 0).first, P2 = m.add_property_map<V, double>("v:P2", 0).first;
  auto d1 = m.add_property_map<V, K::Vector_3>("v:d1", K::Vector_3(0, 0, 0)).first;
  auto d2 = m.add_property_map<V, K::Vector_3>("v:d2", K::Vector_3(0, 0, 0)).first;
  auto t0 = std::chrono::steady_clock::now();
  std::vector<char> mark(m.number_of_vertices(), 0);
  std::vector<V> ring, front, next;
  std::vector<K::Point_3> pts;
  Fitting fit;
  for (V v : m.vertices()) {
    ring.assign(1, v);
    front.assign(1, v);
    mark[v] = 1;
    while (ring.size() < 10 && !front.empty()) {  // rings until >= 10 points (d = 3)
      next.clear();
      for (V a : front)
        for (V b : CGAL::vertices_around_target(m.halfedge(a), m))
          if (!mark[b]) mark[b] = 1, next.push_back(b), ring.push_back(b);
      front.swap(next);
    }
    for (V a : ring) mark[a] = 0;
    if (ring.size() < 10) continue;
    pts.clear();
    for (V a : ring) pts.push_back(m.point(a));
    Fitting::Monge_form f = fit(pts.begin(), pts.end(), 3, 3);
    f.comply_wrt_given_normal(PMP::compute_vertex_normal(v, m));
    k1[v] = f.principal_curvatures(0), k2[v] = f.principal_curvatures(1);
    b0[v] = f.third_order_coefficients(0), b3[v] = f.third_order_coefficients(3);
    d1[v] = f.maximal_principal_direction(), d2[v] = f.minimal_principal_direction();
  }
  auto t1 = std::chrono::steady_clock::now();
  using Ridges = CGAL::Ridge_approximation<Mesh, decltype(k1), decltype(d1)>;
  Ridges ridges(m, k1, k2, b0, b3, d1, d2, P1, P2);
  std::vector<CGAL::Ridge_line<Mesh>*> lines;
  ridges.compute_crest_ridges(std::back_inserter(lines), CGAL::Ridge_order_3);
  auto t2 = std::chrono::steady_clock::now();
  std::cout << std::chrono::duration<double>(t1 - t0).count() << " " << std::chrono::duration<double>(t2 - t1).count()
            << " " << lines.size() << "\n";
  for (auto* l : lines) delete l;
  return 0;
}
