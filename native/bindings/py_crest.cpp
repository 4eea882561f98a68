// Crest lines, feature-sensitive decimation and segmentation (thesis chapter 4).
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <tuple>

#include "common.h"
#include "dgmesh/crest_lines.h"
#include "dgmesh/decimate.h"
#include "dgmesh/segment.h"
#include "dgmesh/validate.h"

namespace dgmesh::py {

namespace {

pb::array_t<int> int_array(const std::vector<int>& v) { return pb::array_t<int>(v.size(), v.data()); }
pb::array_t<double> double_array(const std::vector<double>& v) { return pb::array_t<double>(v.size(), v.data()); }

pb::dict derivatives_dict(CurvatureDerivatives& d) {
  pb::dict out;
  out["k_max"] = std::move(d.k_max);
  out["k_min"] = std::move(d.k_min);
  out["e_max"] = std::move(d.e_max);
  out["e_min"] = std::move(d.e_min);
  out["t_max"] = std::move(d.t_max);
  out["t_min"] = std::move(d.t_min);
  out["normals"] = std::move(d.normals);
  return out;
}

pb::dict lines_dict(CrestLines& c) {
  pb::dict out;
  out["points"] = std::move(c.points);
  out["point_edge"] = std::move(c.point_edge);
  out["point_t"] = std::move(c.point_t);
  out["point_cyclideness"] = std::move(c.point_cyclideness);
  out["segments"] = std::move(c.segments);
  out["segment_line"] = int_array(c.segment_line);
  out["segment_face"] = int_array(c.segment_face);
  out["line_offset"] = int_array(c.line_offset);
  out["line_points"] = int_array(c.line_points);
  out["line_kind"] = int_array(c.line_kind);
  out["line_strength"] = double_array(c.line_strength);
  out["line_length"] = double_array(c.line_length);
  return out;
}

// Crest segments handed back from Python: (segments, segment_face, point_edge).
using CrestArrays = std::tuple<MatX2i, std::vector<int>, MatX2i>;

CrestLines crest_from_arrays(const Mesh& mesh, const CrestArrays& a) {
  CrestLines c;
  std::tie(c.segments, c.segment_face, c.point_edge) = a;
  if (static_cast<Eigen::Index>(c.segment_face.size()) != c.segments.rows())
    throw MeshError("segment_face must have one entry per segment");
  for (int s = 0; s < c.segments.rows(); ++s)
    for (int k = 0; k < 2; ++k)
      if (c.segments(s, k) < 0 || c.segments(s, k) >= c.point_edge.rows())
        throw MeshError("crest segment refers to a missing point");
  for (int p = 0; p < c.point_edge.rows(); ++p)
    for (int k = 0; k < 2; ++k)
      if (c.point_edge(p, k) < -1 || c.point_edge(p, k) >= mesh.V.rows())
        throw MeshError("crest point edge refers to a missing vertex (crest lines of another mesh?)");
  for (int f : c.segment_face)
    if (f < -1 || f >= mesh.F.rows()) throw MeshError("crest segment face out of range (crest lines of another mesh?)");
  return c;
}

// F(d) of eq. 4.12 per face for a feature-guided application, on the caller's validated mesh (one
// validation and topology per call, thesis 4.8-4.9): from the given crest segments, or from crest
// lines detected here with `rings` and `threshold` (progress over [0, share]). Empty when eta is 0.
VecXd feature_values(const Mesh& mesh, double eta, int rings, double threshold, const std::optional<CrestArrays>& crest,
                     const ProgressFn& progress, double share) {
  if (!(eta >= 0.0) || !std::isfinite(eta))
    throw MeshError("feature weight (eta) must be a non-negative number, got " + std::to_string(eta));
  if (eta == 0.0) return {};
  CrestLines lines;
  if (crest) {
    lines = crest_from_arrays(mesh, *crest);
  } else {
    if (!std::isfinite(threshold)) throw MeshError("threshold must be finite");
    DerivativeOptions fit;
    fit.rings = rings;
    CrestOptions opt;
    opt.threshold = threshold;
    ProgressFn sub;
    if (progress) sub = [&progress, share](double f) { return progress(share * f); };
    lines = crest_lines(mesh, fit, opt, sub);
  }
  return feature_function(crest_face_distance(mesh, lines), eta);
}

ProgressFn tail_progress(const ProgressFn& progress, double start) {
  if (!progress || start == 0.0) return progress;
  return [progress, start](double f) { return progress(start + (1.0 - start) * f); };
}

}  // namespace

void bind_crest(pb::module_& m) {
  m.def(
      "curvature_derivatives",
      [](InV Vin, InF Fin, int rings, bool smooth, bool use_normals, bool fit_tangent_plane,
         bool transport_to_vertex, const pb::object& cb) {
        CurvatureDerivatives d;
        {
          NativeScope nogil;
          const Mesh mesh = make_mesh(Vin, Fin, kSurface);
          d = curvature_derivatives(
              mesh, DerivativeOptions{rings, smooth, use_normals, fit_tangent_plane, transport_to_vertex},
              progress_from(cb));
        }
        return derivatives_dict(d);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("rings") = 1, pb::arg("smooth") = true, pb::arg("use_normals") = true,
      pb::arg("fit_tangent_plane") = true, pb::arg("transport_to_vertex") = true, pb::arg("progress") = pb::none());

  // Fit and trace; returns (derivatives, lines) with every line (no thresholding).
  m.def(
      "crest_lines",
      [](InV Vin, InF Fin, int rings, bool smooth, bool use_normals, bool ridges, bool valleys, bool join_gaps,
         bool skip_boundary, const pb::object& cb) {
        CurvatureDerivatives d;
        CrestLines c;
        {
          NativeScope nogil;
          const Mesh mesh = make_mesh(Vin, Fin, kSurface);
          d = curvature_derivatives(mesh, DerivativeOptions{rings, smooth, use_normals}, progress_from(cb));
          CrestOptions opt;
          opt.ridges = ridges;
          opt.valleys = valleys;
          opt.join_gaps = join_gaps;
          opt.skip_boundary = skip_boundary;
          c = trace_crest_lines(mesh, d, opt);
        }
        return pb::make_tuple(derivatives_dict(d), lines_dict(c));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("rings") = 1, pb::arg("smooth") = true, pb::arg("use_normals") = true,
      pb::arg("ridges") = true, pb::arg("valleys") = true, pb::arg("join_gaps") = true,
      pb::arg("skip_boundary") = true, pb::arg("progress") = pb::none());

  // Geodesic distance from each face to the given crest segments (thesis 4.8).
  m.def(
      "crest_face_distance",
      [](InV Vin, InF Fin, const MatX2i& segments, const std::vector<int>& segment_face, const MatX2i& point_edge) {
        NativeScope nogil;
        const Mesh mesh = make_mesh(Vin, Fin, kSurface);
        return crest_face_distance(mesh, crest_from_arrays(mesh, CrestArrays{segments, segment_face, point_edge}));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("segments"), pb::arg("segment_face"), pb::arg("point_edge"));

  m.def(
      "decimate",
      [](InV Vin, InF Fin, int target_faces, std::optional<VecXd> face_weights, bool preserve_boundary,
         double min_quality, double max_normal_angle, double max_error, const pb::object& cb,
         std::optional<std::vector<int>> locked, bool batched, double feature_weight, int rings, double threshold,
         std::optional<CrestArrays> crest, std::optional<std::vector<int>> planes) {
        DecimateResult r;
        {
          NativeScope nogil;
          const Mesh mesh = make_mesh(Vin, Fin, kSurface);
          const ProgressFn progress = progress_from(cb);
          const double share = feature_weight > 0 && !crest ? 0.3 : 0.0;  // of the progress for the fit
          const VecXd Fd = feature_values(mesh, feature_weight, rings, threshold, crest, progress, share);
          DecimateOptions opt;
          opt.target_faces = target_faces;
          if (face_weights) opt.face_weights = std::move(*face_weights);
          if (Fd.size()) {  // thesis 4.8: face quadrics weighted by 1 / F(d)
            if (opt.face_weights.size() == 0) opt.face_weights = VecXd::Ones(Fd.size());
            if (opt.face_weights.size() != Fd.size())
              throw MeshError("face_weights must have one value per face (" + std::to_string(Fd.size()) + ")");
            opt.face_weights.array() /= Fd.array();
          }
          opt.preserve_boundary = preserve_boundary;
          opt.min_quality = min_quality;
          opt.max_normal_angle = max_normal_angle;
          opt.max_error = max_error;
          if (locked) opt.locked.assign(locked->begin(), locked->end());
          if (planes) opt.planes.assign(planes->begin(), planes->end());
          opt.batched = batched;
          r = decimate(mesh, opt, tail_progress(progress, share));
        }
        return pb::make_tuple(std::move(r.V), std::move(r.F), int_array(r.vertex_map), int_array(r.face_map),
                              int_array(r.source_vertex));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("target_faces"), pb::arg("face_weights") = pb::none(),
      pb::arg("preserve_boundary") = true, pb::arg("min_quality") = 0.0, pb::arg("max_normal_angle") = 1.3,
      pb::arg("max_error") = std::numeric_limits<double>::infinity(), pb::arg("progress") = pb::none(),
      pb::arg("locked") = pb::none(), pb::arg("batched") = true, pb::arg("feature_weight") = 0.0,
      pb::arg("rings") = 1, pb::arg("threshold") = 0.0, pb::arg("crest") = pb::none(), pb::arg("planes") = pb::none());

  m.def(
      "segment",
      [](InV Vin, InF Fin, int segments, std::optional<VecXd> face_feature, int iterations, const pb::object& cb,
         double feature_weight, int rings, double threshold, std::optional<CrestArrays> crest) {
        SegmentResult r;
        {
          NativeScope nogil;
          const Mesh mesh = make_mesh(Vin, Fin, kSurface);
          const ProgressFn progress = progress_from(cb);
          const double share = feature_weight > 0 && !crest ? 0.3 : 0.0;
          SegmentOptions opt;
          opt.segments = segments;
          opt.iterations = iterations;
          if (face_feature) opt.face_feature = std::move(*face_feature);
          VecXd Fd = feature_values(mesh, feature_weight, rings, threshold, crest, progress, share);
          if (Fd.size()) {
            if (face_feature) throw MeshError("give either face_feature or feature_weight, not both");
            opt.face_feature = std::move(Fd);
          }
          r = segment(mesh, opt, tail_progress(progress, share));
        }
        pb::dict out;
        out["labels"] = int_array(r.labels);
        out["proxy_normals"] = std::move(r.proxy_normals);
        out["n_segments"] = r.n_segments;
        out["iterations"] = r.iterations;
        out["error"] = r.error;
        return out;
      },
      pb::arg("V"), pb::arg("F"), pb::arg("segments"), pb::arg("face_feature") = pb::none(),
      pb::arg("iterations") = 30, pb::arg("progress") = pb::none(), pb::arg("feature_weight") = 0.0,
      pb::arg("rings") = 1, pb::arg("threshold") = 0.0, pb::arg("crest") = pb::none());
}

}  // namespace dgmesh::py
