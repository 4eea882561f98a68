// Remeshing by double parameterization (thesis 5.4): the options, enums, result and functions of
// dgmesh/remesh.h as they are.
#include "common.h"
#include "dgmesh/errors.h"
#include "dgmesh/remesh.h"

namespace dgmesh::py {

void bind_remesh(pb::module_& m) {
  pb::enum_<RemeshMode>(m, "RemeshMode", "Maps remesh() samples and triangulates on (thesis fig. 5.6-5.9)")
      .value("double", RemeshMode::Double, "sample on Uopt, Delaunay on U0 (thesis 5.4)")
      .value("single_u0", RemeshMode::SingleU0, "sample and triangulate on U0 (Alliez et al.)")
      .value("single_uopt", RemeshMode::SingleUopt, "sample and triangulate on Uopt");
  pb::enum_<RemeshBoundary>(m, "RemeshBoundary", "The chart's boundary in remesh()")
      .value("keep", RemeshBoundary::Keep, "the boundary vertices exactly and in order (stitchable)")
      .value("resample", RemeshBoundary::Resample, "new boundary vertices at the local target spacing");
  pb::enum_<RemeshRelaxMetric>(m, "RemeshRelaxMetric", "Metric of the Lloyd relaxation's Voronoi cells")
      .value("surface", RemeshRelaxMetric::Surface, "nearest sample in 3D")
      .value("map", RemeshRelaxMetric::Map, "nearest sample in the sampling map");
  // RemeshOptions::domain is unwrap.h's UvBoundary, whose binding belongs to py_unwrap.cpp (bound
  // before this file); bound here only when that has not happened.
  if (!pb::detail::get_type_info(typeid(UvBoundary)))
    pb::enum_<UvBoundary>(m, "UvBoundary", "Parameter domain boundary")
        .value("square", UvBoundary::Square, "unit square")
        .value("circle", UvBoundary::Circle, "circle, arc-length spaced")
        .value("free", UvBoundary::Free, "natural boundary (LSCM)");

  Struct<RemeshOptions>(m, "RemeshOptions", "Options of remesh(); see dgmesh/remesh.h for each step")
      .field("target_vertices", &RemeshOptions::target_vertices, "total output vertices, boundary included")
      .field("adaptivity", &RemeshOptions::adaptivity, "0: uniform density; 1: density proportional to curvature")
      .field("resolution", &RemeshOptions::resolution, "raster size of the control map, 16..4096")
      .field("mode", &RemeshOptions::mode, "sampling and triangulation maps")
      .field("boundary", &RemeshOptions::boundary, "keep or resample the chart's boundary")
      .field("domain", &RemeshOptions::domain, "parameter domain of U0 and Uopt: circle or square (convex)")
      .field("boundary_clearance", &RemeshOptions::boundary_clearance,
             "interior samples closer to the boundary than this fraction of the target spacing are dropped")
      .field("curvature_clip", &RemeshOptions::curvature_clip, "curvature density clipped at this multiple of its mean")
      .field("max_uopt_iterations", &RemeshOptions::max_uopt_iterations, "cap on Uopt's equalization steps")
      .field("eta", &RemeshOptions::eta, "eq. 5.6's exponent of the low-stretch map, (0, 1]")
      .field("uopt_steps", &RemeshOptions::uopt_steps, "equalization steps (-1: until eq. 5.5 stops decreasing)")
      .field("flip_3d", &RemeshOptions::flip_3d, "3D Delaunay edge flips after the triangulation")
      .field("lloyd_iterations", &RemeshOptions::lloyd_iterations,
             "at most this many density-weighted Lloyd steps, 0..100")
      .field("smooth_iterations", &RemeshOptions::smooth_iterations, "sweeps of tangential smoothing, 0..100")
      .field("relax_metric", &RemeshOptions::relax_metric, "metric of the Lloyd steps' Voronoi cells")
      .field("min_separation", &RemeshOptions::min_separation,
             "interior samples closer than this fraction of the target spacing are dropped, [0, 1)");

  Struct<RemeshResult>(m, "RemeshResult", "Result of remesh()")
      .result("V", &RemeshResult::V, "(n, 3) the new vertices: the n_boundary boundary vertices first, in loop order")
      .result("F", &RemeshResult::F, "(m, 3) triangles, oriented like the input")
      .result("n_boundary", &RemeshResult::n_boundary, "boundary vertices")
      .result("boundary_source", &RemeshResult::boundary_source,
              "keep: input vertex of each boundary vertex; resample: empty")
      .result("uv", &RemeshResult::uv, "(n, 2) the output vertices in the triangulation map")
      .result("source_face", &RemeshResult::source_face, "(n,) input face each output vertex lies on")
      .result("source_bary", &RemeshResult::source_bary, "(n, 3) its barycentric weights there")
      .result("n_interior_target", &RemeshResult::n_interior_target, "interior samples asked (target minus boundary)")
      .result("n_rejected", &RemeshResult::n_rejected, "interior samples dropped by the boundary clearance (last pass)")
      .result("passes", &RemeshResult::passes, "error-diffusion passes, all rounds")
      .result("resolution", &RemeshResult::resolution, "raster size used (coarser than asked for small targets)")
      .result("sampling_rounds", &RemeshResult::sampling_rounds, "diffusion + relaxation + separation rounds")
      .result("uopt_iterations", &RemeshResult::uopt_iterations, "equalization steps of Uopt")
      .result("n_flips", &RemeshResult::n_flips, "3D Delaunay edge flips")
      .result("lloyd_iterations", &RemeshResult::lloyd_iterations, "Lloyd steps made")
      .result("n_separated", &RemeshResult::n_separated, "interior samples dropped by min_separation (last round)")
      .result("smooth_moves", &RemeshResult::smooth_moves, "vertex moves of the smoothing sweeps")
      .result("n_removed", &RemeshResult::n_removed, "interior valence-3/4 vertices removed by the smoothing")
      .result("seconds_parameterize", &RemeshResult::seconds_parameterize, "wall time: U0 and Uopt")
      .result("seconds_sample", &RemeshResult::seconds_sample, "wall time: rasterizing and error diffusion")
      .result("seconds_relax", &RemeshResult::seconds_relax, "wall time: Lloyd steps and separation")
      .result("seconds_triangulate", &RemeshResult::seconds_triangulate, "wall time: Delaunay, lift, flips, smoothing")
      .result("warnings", &RemeshResult::warnings, "notes for the user (e.g. a resolution too low for the target)");

  m.def(
      "remesh",
      [](InV V, InF F, const RemeshOptions& o, const pb::object& progress) {
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return remesh(V, F, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def(
      "point_mesh_distance",
      [](InV P, InV V, InF F, int candidates) {
        NativeScope nogil;
        return point_mesh_distance(P, V, F, candidates);
      },
      pb::arg("P"), pb::arg("V"), pb::arg("F"), pb::arg("candidates") = 16);
}

}  // namespace dgmesh::py
