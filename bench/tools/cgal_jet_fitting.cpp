// Bench-only reference (not part of the CMake build or CI): CGAL's Monge_via_jet_fitting (Cazals and
// Pouget 2005) on neighbourhoods given by the bench, so that both methods fit the same points.
// Compiled on demand by the bench with g++ into .cache/ (needs libcgal-dev and Eigen).
//
//   cgal_jet_fitting d m in.txt out.txt
//
// in.txt: one neighbourhood per line, "count x0 y0 z0 x1 y1 z1 ...", the first point being the
// vertex itself. out.txt: one line per neighbourhood, "k1 k2 b0 b1 b2 b3 nx ny nz d1x d1y d1z d2x
// d2y d2z" of the Monge form (z = (k1 x^2 + k2 y^2) / 2 + (b0 x^3 + 3 b1 x^2 y + 3 b2 x y^2 + b3
// y^3) / 6 + ... over the frame (d1, d2, n)), or "nan" when the neighbourhood has fewer points
// than the jet of degree d has coefficients ((d + 1)(d + 2) / 2; CGAL's precondition).
#include <CGAL/Monge_via_jet_fitting.h>
#include <CGAL/Simple_cartesian.h>

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <vector>

using K = CGAL::Simple_cartesian<double>;
using Fitting = CGAL::Monge_via_jet_fitting<K>;

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: cgal_jet_fitting d m in.txt out.txt\n";
    return 2;
  }
  const std::size_t d = std::atoi(argv[1]), m = std::atoi(argv[2]);
  const std::size_t needed = (d + 1) * (d + 2) / 2;
  std::ifstream in(argv[3]);
  std::ofstream out(argv[4]);
  out.precision(17);
  std::size_t count;
  std::vector<K::Point_3> pts;
  Fitting fit;
  while (in >> count) {
    pts.clear();
    for (std::size_t i = 0; i < count; ++i) {
      double x, y, z;
      in >> x >> y >> z;
      pts.emplace_back(x, y, z);
    }
    if (!in) return 1;
    if (count < needed) {
      out << "nan\n";
      continue;
    }
    const Fitting::Monge_form f = fit(pts.begin(), pts.end(), d, m);
    out << f.principal_curvatures(0) << " " << f.principal_curvatures(1);
    for (int i = 0; i < 4; ++i) out << " " << f.third_order_coefficients(i);
    out << " " << f.normal_direction() << " " << f.maximal_principal_direction() << " "
        << f.minimal_principal_direction() << "\n";
  }
  return 0;
}
