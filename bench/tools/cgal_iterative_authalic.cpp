// Bench-only reference (not part of the CMake build or CI): CGAL's Iterative_authalic and
// Discrete_authalic parameterizers on a disk mesh, so bench/workloads/unwrap.py compares against
// figures measured in the same run on the same machine instead of quoted ones. Compiled on demand
// by the bench with g++ into .cache/ (needs libcgal-dev); see bench/common.py `cgal_tool`.
//
//   cgal_iterative_authalic iterative|discrete in.off out.txt runs [warmups] [iterations] [circle|square]
//
// CGAL's defaults unless told otherwise: Circular_border_arc_length_parameterizer_3 on the longest
// border (square: Square_border_arc_length_parameterizer_3, as CGAL's examples use), Eigen
// BiCGSTAB + IncompleteLUT, 15 iterations for Iterative_authalic (its default argument).
// Only the parameterization call is timed (wall: steady_clock; CPU: this process's CPU clock), on
// a fresh copy of the mesh each run (the copy is made outside the timing); `warmups` untimed runs
// first (default 1). This binary is compiled without OpenMP, so CGAL (and Eigen) run on one thread.
// out.txt: line 1 "wall <median s> cpu <median s> status <CGAL error code> best_iteration <i>
// runs <k>", line 2 the wall seconds of every timed run, then one "u v" line per vertex in the
// OFF's vertex order (%.17g).
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/Discrete_authalic_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Iterative_authalic_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Square_border_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "read_off.h"

using K = CGAL::Simple_cartesian<double>;
using Mesh = CGAL::Surface_mesh<K::Point_3>;
using VD = Mesh::Vertex_index;
using HD = Mesh::Halfedge_index;
namespace SMP = CGAL::Surface_mesh_parameterization;
namespace PMP = CGAL::Polygon_mesh_processing;

// One parameterization call with border parameterizer B; iterations in/out (best iteration).
template <class B>
static SMP::Error_code run_once(const std::string& method, Mesh& m, HD bhd, Mesh::Property_map<VD, K::Point_2> uvmap,
                                unsigned& iters) {
  if (method == "iterative") {
    SMP::Iterative_authalic_parameterizer_3<Mesh, B> p;
    auto vimap = get(boost::vertex_index, m);
    auto vpmap = m.add_property_map<VD, bool>("v:dgmesh_parameterized", false).first;
    double error = 0;
    return p.parameterize(m, bhd, uvmap, vimap, vpmap, iters, error);
  }
  iters = 0;
  return SMP::parameterize(m, SMP::Discrete_authalic_parameterizer_3<Mesh, B>(), bhd, uvmap);
}

static double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

static double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int main(int argc, char** argv) {
  if (argc < 5 || argc > 8) {
    std::cerr << "usage: cgal_iterative_authalic iterative|discrete in.off out.txt runs [warmups] [iterations]"
                 " [circle|square]\n";
    return 2;
  }
  const std::string method = argv[1];
  if (method != "iterative" && method != "discrete") {
    std::cerr << "unknown method " << method << "\n";
    return 2;
  }
  const int runs = std::max(1, std::atoi(argv[4]));
  const int warmups = argc > 5 ? std::max(0, std::atoi(argv[5])) : 1;
  const unsigned iterations = argc > 6 ? unsigned(std::atoi(argv[6])) : 15u;  // CGAL's default
  const std::string border = argc > 7 ? argv[7] : "circle";                   // CGAL's default
  if (border != "circle" && border != "square") {
    std::cerr << "unknown border " << border << "\n";
    return 2;
  }
  Mesh input;
  if (!read_off_in_order(argv[2], input)) {
    std::cerr << "cannot read " << argv[2] << "\n";
    return 1;
  }
  // Surface_mesh's vertex index is the OFF order (no removals), and serves as the parameterizers'
  // row index: valid because the bench passes one connected disk (all vertices in the component).

  std::vector<double> walls, cpus;
  std::vector<K::Point_2> uv_out(input.number_of_vertices());
  int status = 0;
  unsigned best_iteration = 0;
  for (int r = 0; r < warmups + runs; ++r) {
    Mesh m = input;  // fresh copy: the parameterizers add property maps to the mesh
    auto uvmap = m.add_property_map<VD, K::Point_2>("v:dgmesh_uv", K::Point_2(0, 0)).first;
    SMP::Error_code err = SMP::OK;
    unsigned iters = iterations;
    const auto w0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds();
    const HD bhd = PMP::longest_border(m).first;
    if (border == "circle")
      err = run_once<SMP::Circular_border_arc_length_parameterizer_3<Mesh>>(method, m, bhd, uvmap, iters);
    else
      err = run_once<SMP::Square_border_arc_length_parameterizer_3<Mesh>>(method, m, bhd, uvmap, iters);
    const double c1 = cpu_seconds();
    const auto w1 = std::chrono::steady_clock::now();
    if (r >= warmups) {
      walls.push_back(std::chrono::duration<double>(w1 - w0).count());
      cpus.push_back(c1 - c0);
    }
    status = int(err);
    best_iteration = iters;
    if (r == warmups + runs - 1)
      for (VD v : m.vertices()) uv_out[size_t(v)] = get(uvmap, v);
  }
  FILE* f = std::fopen(argv[3], "w");
  if (!f) {
    std::cerr << "cannot write " << argv[3] << "\n";
    return 1;
  }
  std::fprintf(f, "wall %.9g cpu %.9g status %d best_iteration %u runs %d\n", median(walls), median(cpus), status,
               best_iteration, runs);
  for (size_t i = 0; i < walls.size(); ++i) std::fprintf(f, "%s%.9g", i ? " " : "", walls[i]);
  std::fprintf(f, "\n");
  for (const auto& p : uv_out) std::fprintf(f, "%.17g %.17g\n", p.x(), p.y());
  std::fclose(f);
  if (status != 0) std::cerr << "CGAL error: " << SMP::get_error_message(status) << "\n";
  return status == 0 ? 0 : 3;
}
