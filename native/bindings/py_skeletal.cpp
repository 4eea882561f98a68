// Bindings of skeletal.h and delaunay.h: the options and the skeletal mesh as they are, the rig.
#include <optional>
#include <vector>

#include "common.h"
#include "dgmesh/delaunay.h"
#include "dgmesh/errors.h"
#include "dgmesh/ring_weights.h"
#include "dgmesh/self_intersection.h"
#include "dgmesh/skeletal.h"
#include "dgmesh/validate.h"

namespace dgmesh::py {

namespace {

using Mats = pb::array_t<double, pb::array::c_style | pb::array::forcecast>;

std::vector<Mat4> to_mats(const Mats& a, const char* what) {
  if (a.ndim() != 3 || a.shape(1) != 4 || a.shape(2) != 4)
    throw MeshError(std::string(what) + " must have shape (B, 4, 4)");
  auto r = a.unchecked<3>();
  std::vector<Mat4> out(r.shape(0));
  for (pb::ssize_t b = 0; b < r.shape(0); ++b)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) out[b](i, j) = r(b, i, j);
  return out;
}

pb::array_t<double> from_mats(const std::vector<Mat4>& m) {
  pb::array_t<double> a({static_cast<pb::ssize_t>(m.size()), pb::ssize_t(4), pb::ssize_t(4)});
  auto w = a.mutable_unchecked<3>();
  for (size_t b = 0; b < m.size(); ++b)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) w(b, i, j) = m[b](i, j);
  return a;
}

template <class T>
T get(const pb::dict& d, const char* key) {
  if (!d.contains(key)) throw MeshError(std::string("skeletal data: missing '") + key + "'");
  try {
    return d[key].cast<T>();
  } catch (const pb::cast_error&) {  // pybind11's own message names the C++ type, not the field
    throw MeshError(std::string("skeletal data: '") + key +
                    "' has the wrong type or shape: " + pb::repr(pb::type::handle_of(d[key])).cast<std::string>());
  }
}

}  // namespace

void bind_skeletal(pb::module_& m) {
  m.def(
      "delaunay_3d",
      [](InV P) {
        Delaunay3 d;
        {
          NativeScope nogil;
          d = delaunay_3d(P);
        }
        pb::dict out;
        out["tets"] = std::move(d.tets);
        out["circumcenters"] = std::move(d.circumcenters);
        out["circumradii"] = std::move(d.circumradii);
        out["point_offset"] = pb::array_t<int>(d.point_offset.size(), d.point_offset.data());
        out["point_tets"] = pb::array_t<int>(d.point_tets.size(), d.point_tets.data());
        return out;
      },
      pb::arg("points"));
  m.def(
      "delaunay_2d",
      [](Eigen::Ref<const MatX2d> P) {
        NativeScope nogil;
        return delaunay_2d(P);
      },
      pb::arg("points"));
  Struct<SkeletonOptions>(m, "SkeletonOptions", "Options of skeletal_mesh() (thesis 6.1)")
      .field("presmooth_iterations", &SkeletonOptions::presmooth_iterations,
             "bilaplacian tangential flow steps on a copy of the mesh before the Voronoi poles")
      .field("presmooth_step", &SkeletonOptions::presmooth_step, "its step, of the uniform bi-umbrella (< 0.5)")
      .field("postsmooth_iterations", &SkeletonOptions::postsmooth_iterations,
             "bi-umbrella steps on the skeletal mesh (inward-pointing, spikes, inverted vertices)")
      .field("postsmooth_step", &SkeletonOptions::postsmooth_step, "their step")
      .field("spike_factor", &SkeletonOptions::spike_factor,
             "a radius above this times the median of its ring's radii is a spike")
      .field("max_pole_angle", &SkeletonOptions::max_pole_angle,
             "inner pole candidates lie within this angle (radians) of the inward normal");

  Struct<SkeletalMesh>(m, "SkeletalMesh", "Result of skeletal_mesh(): M = S + d N (eq. 6.1)")
      .result("S", &SkeletalMesh::S, "(n, 3) skeletal vertices, one per mesh vertex; faces are the mesh's")
      .result("radii", &SkeletalMesh::radii, "(n,) medial-ball radius d(i) = |x_i - s_i| (eq. 6.7)")
      .result("n_fallback", &SkeletalMesh::n_fallback, "vertices without an inner Voronoi pole")
      .result("n_postsmoothed", &SkeletalMesh::n_postsmoothed, "vertices moved by the post-smoothing");

  Struct<SkeletalRigOptions>(m, "SkeletalRigOptions", "Options of SkeletalRig.bind()")
      .field("skeleton", &SkeletalRigOptions::skeleton, "the skeletal mesh's SkeletonOptions")
      .field("control_faces", &SkeletalRigOptions::control_faces,
             "meshes with more faces go through a multiresolution control mesh of about this many")
      .field("multires_level", &SkeletalRigOptions::multires_level, "subdivision level of the multiresolution layer")
      .field("multires_fit_iterations", &SkeletalRigOptions::multires_fit_iterations,
             "fitting iterations of the multiresolution layer")
      .field("gaussian_sigma", &SkeletalRigOptions::gaussian_sigma,
             "width of the Gaussian bone weights when none are given (0: a fifth of the median medial radius)")
      .field("frame_regularization", &SkeletalRigOptions::frame_regularization,
             "weight of the bone rotation in the frames of degenerate skeletal triangles");

  pb::enum_<SkeletalMethod>(m, "SkeletalMethod", "Reconstruction of the deformed mesh")
      .value("variational", SkeletalMethod::Variational, "thesis 6.5: eq. 6.8-6.12 and the fairing eq. 6.15")
      .value("basic", SkeletalMethod::Basic, "thesis 6.3: homotopy eq. 6.3-6.6 (comparison)");

  Struct<RingWeightOptions>(m, "RingWeightOptions", "Options of ring_weights()")
      .field("scale", &RingWeightOptions::scale, "smoothing length over each vertex's radius")
      .field("floor", &RingWeightOptions::floor, "smoothed weights below this are dropped");

  Struct<SkeletalDeformOptions>(m, "SkeletalDeformOptions", "Options of SkeletalRig.deform()")
      .field("method", &SkeletalDeformOptions::method, "the reconstruction")
      .field("fairing_steps", &SkeletalDeformOptions::fairing_steps,
             "steps of eq. 6.15 (variational) or eq. 6.6 (basic)")
      .field("fairing_step", &SkeletalDeformOptions::fairing_step, "epsilon of eq. 6.15")
      .field("projection", &SkeletalDeformOptions::projection,
             "weight of the explicit step out to each vertex's rest distance to the union of balls, where "
             "it is nearer (one-sided; 0: off)")
      .field("projection_passes", &SkeletalDeformOptions::projection_passes, "passes of that step, at most")
      .field("dense_projection_passes", &SkeletalDeformOptions::dense_projection_passes,
             "passes of the dense mesh's step (multiresolution layer)")
      .field("dual_quaternion", &SkeletalDeformOptions::dual_quaternion,
             "pose the skeletal mesh by dual quaternion blending (false: the linear blend of eq. 6.2)")
      .field("integrate_skeleton", &SkeletalDeformOptions::integrate_skeleton,
             "rebuild the posed skeletal mesh from its rest edges turned (and stretched as a beam's) by the blended "
             "rotations, anchored where one bone dominates (false: the blend's positions)")
      .field("joint_fillet", &SkeletalDeformOptions::joint_fillet,
             "joint fillets: at each bent joint the skeletal mesh follows an arc tangent to both bones and the "
             "reconstructed surface the same map of the rest surface; the fillet radius sought over the limb's "
             "radius (0: off)")
      .field("ring_twist", &SkeletalDeformOptions::ring_twist,
             "blend the twists that dominate their bone's swing with the weights smoothed around each limb "
             "(SkeletalRig.ring_weights), so each cross-section turns as one (false: the weights)")
      .field("bone_clearance", &SkeletalDeformOptions::bone_clearance,
             "keep each vertex at least this fraction of its rest distance from its bones (0: off)")
      .field("contact_slide", &SkeletalDeformOptions::contact_slide,
             "joint contact: slide each limb's crease band off the bisector plane of the bent joint, over kappa "
             "times its crossing depth (>= 1; 0: off)")
      .field("untangle_iterations", &SkeletalDeformOptions::untangle_iterations,
             "untangling: iterations of the local smoothing of the self-intersecting triangles' vertices (0: off)")
      .field("untangle_rings", &SkeletalDeformOptions::untangle_rings,
             "untangling: rings around the crossing triangles' vertices smoothed with them")
      .field("fold_guard", &SkeletalDeformOptions::fold_guard,
             "fold guard: iterations of the smoothing of the displacement around faces the thickness steps turned "
             "over (0: off)")
      .field("follow_twist", &SkeletalDeformOptions::follow_twist,
             "measure the thickness (eq. 6.13) and fit the frames (eq. 6.8) in the twist-free pose, each vertex "
             "carried there by its own blended twist")
      .field("homotopy_steps", &SkeletalDeformOptions::homotopy_steps, "L of eq. 6.3 (basic)")
      .field("fold_iterations", &SkeletalDeformOptions::fold_iterations, "steps of eq. 6.5 (basic)");

  m.def(
      "skeletal_mesh",
      [](InV V, InF F, const SkeletonOptions& o) {
        NativeScope nogil;
        return skeletal_mesh(make_mesh(V, F, kSurface), o);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"));
  m.def(
      "ring_weights",
      [](InV V, InF F, const Eigen::MatrixXd& W, InV bone_dirs, const VecXd& radius, const RingWeightOptions& o) {
        if (!V.allFinite() || !W.allFinite() || !bone_dirs.allFinite() || !radius.allFinite())
          throw MeshError("ring_weights: inputs must be finite");
        NativeScope nogil;
        return ring_weights(V, F, W, bone_dirs, radius, o);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("W"), pb::arg("bone_dirs"), pb::arg("radius"), pb::arg("options"));
  m.def("union_of_balls_distance", [](InV X, InV C, const VecXd& r) {
    NativeScope nogil;
    if (!X.allFinite() || !C.allFinite() || !r.allFinite()) throw MeshError("union of balls: inputs must be finite");
    return union_of_balls_distance(X, C, r);
  });
  m.def(
      "self_intersecting_pairs",
      [](InV V, InF F, std::optional<std::vector<int>> touching) {
        if (!V.allFinite()) throw MeshError("self_intersecting_pairs: V must be finite");
        if (F.size() && (F.minCoeff() < 0 || F.maxCoeff() >= V.rows()))
          throw MeshError("self_intersecting_pairs: F has a vertex index out of range");
        if (touching && static_cast<Eigen::Index>(touching->size()) != F.rows())
          throw MeshError("self_intersecting_pairs: touching needs one flag per face");
        NativeScope nogil;
        const MatX3d Vd = V;
        const MatX3i Fd = F;
        const std::vector<char> flags =
            touching ? std::vector<char>(touching->begin(), touching->end()) : std::vector<char>();
        const auto pairs =
            touching ? self_intersecting_pairs_touching(Vd, Fd, nullptr, flags) : self_intersecting_pairs(Vd, Fd);
        MatX2i out(static_cast<Eigen::Index>(pairs.size()), 2);
        for (size_t k = 0; k < pairs.size(); ++k) out(k, 0) = pairs[k].first, out(k, 1) = pairs[k].second;
        return out;
      },
      pb::arg("V"), pb::arg("F"), pb::arg("touching") = pb::none());
  m.def("gaussian_bone_weights", [](InV P, InV heads, InV tails, double sigma) {
    NativeScope nogil;
    return gaussian_bone_weights(P, heads, tails, sigma);
  });
  m.def(
      "skeletal_subspace_deform",
      [](InV P, const Eigen::MatrixXd& W, const Mats& rest, const Mats& pose, bool dual_quaternion) {
        const auto r = to_mats(rest, "bones_rest"), p = to_mats(pose, "bones_pose");
        NativeScope nogil;
        return skeletal_subspace_deform(P, W, r, p, nullptr, dual_quaternion);
      },
      pb::arg("P"), pb::arg("W"), pb::arg("rest"), pb::arg("pose"), pb::arg("dual_quaternion") = false);

  pb::class_<SkeletalRig>(m, "SkeletalRig")
      .def_static(
          "bind",
          [](InV V, InF F, const Mats& rest, std::optional<Eigen::MatrixXd> weights, std::optional<MatX3d> heads,
             std::optional<MatX3d> tails, const SkeletalRigOptions& o, const pb::object& progress) {
            const auto r = to_mats(rest, "bones_rest");
            const ProgressFn cb = progress_from(progress);
            NativeScope nogil;
            return SkeletalRig::bind(V, F, r, weights ? *weights : Eigen::MatrixXd(), heads ? *heads : MatX3d(0, 3),
                                     tails ? *tails : MatX3d(0, 3), o, cb);
          },
          pb::arg("V"), pb::arg("F"), pb::arg("bones_rest"), pb::arg("weights"), pb::arg("heads"), pb::arg("tails"),
          pb::arg("options"), pb::arg("progress") = pb::none())
      .def(
          "deform",
          [](const SkeletalRig& rig, const Mats& pose, const SkeletalDeformOptions& o, pb::object out,
             std::optional<MatX3d> skeleton) -> pb::object {
            const auto p = to_mats(pose, "bones_pose");
            const MatX3d* sk = skeleton ? &*skeleton : nullptr;
            if (out.is_none()) {
              MatX3d X;
              {
                NativeScope nogil;
                X = rig.deform(p, o, sk);
              }
              return pb::cast(std::move(X));
            }
            // A C-contiguous float64 or float32 (n, 3) array is written in place (no copy, no
            // allocation of the dense result).
            if (pb::isinstance<pb::array>(out) && out.cast<pb::array>().dtype().is(pb::dtype::of<float>())) {
              auto ref = out.cast<Eigen::Ref<MatX3f>>();
              NativeScope nogil;
              rig.deform(p, o, ref, sk);
            } else {
              auto ref = out.cast<Eigen::Ref<MatX3d>>();
              NativeScope nogil;
              rig.deform(p, o, ref, sk);
            }
            return out;
          },
          pb::arg("pose"), pb::arg("options"), pb::arg("out") = pb::none(), pb::arg("skeleton") = pb::none())
      .def(
          "deform_control",
          [](const SkeletalRig& rig, const Mats& pose, const SkeletalDeformOptions& o, std::optional<MatX3d> skeleton) {
            const auto p = to_mats(pose, "bones_pose");
            MatX3d X, Sd;
            {
              NativeScope nogil;
              X = rig.deform_control(p, o, &Sd, skeleton ? &*skeleton : nullptr);
            }
            return pb::make_tuple(std::move(X), std::move(Sd));
          },
          pb::arg("pose"), pb::arg("options"), pb::arg("skeleton") = pb::none())
      .def("skeleton_pose",
           [](const SkeletalRig& rig, const Mats& pose) {
             const auto p = to_mats(pose, "bones_pose");
             NativeScope nogil;
             return rig.skeleton_pose(p);
           })
      .def_property_readonly("n_vertices", &SkeletalRig::n_vertices)
      .def_property_readonly("n_control", &SkeletalRig::n_control)
      .def_property_readonly("n_bones", &SkeletalRig::n_bones)
      .def_property_readonly("has_multires", &SkeletalRig::has_multires)
      .def_property_readonly("control_vertices", [](const SkeletalRig& r) { return MatX3d(r.control_vertices()); })
      .def_property_readonly("control_faces", [](const SkeletalRig& r) { return MatX3i(r.control_faces()); })
      .def_property_readonly("skeleton_vertices", [](const SkeletalRig& r) { return MatX3d(r.skeleton_vertices()); })
      .def_property_readonly("radii", [](const SkeletalRig& r) { return VecXd(r.radii()); })
      .def_property_readonly("weights", [](const SkeletalRig& r) { return Eigen::MatrixXd(r.weights()); })
      .def_property_readonly("ring_weights", [](const SkeletalRig& r) { return Eigen::MatrixXd(r.ring_weights()); })
      .def_property_readonly("bones_rest", [](const SkeletalRig& r) { return from_mats(r.bones_rest()); })
      .def("data",
           [](const SkeletalRig& r) {
             const SkeletalRigData d = r.data();
             pb::dict o;
             o["control_V"] = d.control_V;
             o["control_F"] = d.control_F;
             o["S"] = d.S;
             o["weights"] = d.weights;
             o["bones_rest"] = from_mats(d.bones_rest);
             if (d.bone_heads.rows() > 0) {
               o["bone_heads"] = d.bone_heads;
               o["bone_tails"] = d.bone_tails;
             }
             o["frame_regularization"] = d.frame_regularization;
             o["has_multires"] = d.has_multires;
             if (d.has_multires) {
               o["mr_control_V"] = d.multires.control_V;
               o["mr_control_F"] = d.multires.control_F;
               o["mr_level"] = d.multires.level;
               o["mr_face"] = d.multires.face;
               o["mr_st"] = d.multires.st;
               o["mr_disp"] = d.multires.disp;
               o["mr_dense_F"] = d.dense_F;
             }
             return o;
           })
      .def_static("from_data", [](const pb::dict& o) {
        SkeletalRigData d;
        d.control_V = get<MatX3d>(o, "control_V");
        d.control_F = get<MatX3i>(o, "control_F");
        d.S = get<MatX3d>(o, "S");
        d.weights = get<Eigen::MatrixXd>(o, "weights");
        d.bones_rest = to_mats(get<Mats>(o, "bones_rest"), "bones_rest");
        if (o.contains("bone_heads") || o.contains("bone_tails")) {  // absent in older data
          d.bone_heads = get<MatX3d>(o, "bone_heads");
          d.bone_tails = get<MatX3d>(o, "bone_tails");
        }
        d.frame_regularization = get<double>(o, "frame_regularization");
        d.has_multires = get<bool>(o, "has_multires");
        if (d.has_multires) {
          d.multires.control_V = get<MatX3d>(o, "mr_control_V");
          d.multires.control_F = get<MatX3i>(o, "mr_control_F");
          d.multires.level = get<int>(o, "mr_level");
          d.multires.face = get<VecXi>(o, "mr_face");
          d.multires.st = get<MatX2d>(o, "mr_st");
          d.multires.disp = get<MatX3d>(o, "mr_disp");
          if (o.contains("mr_dense_F")) d.dense_F = get<MatX3i>(o, "mr_dense_F");  // absent in older data
          // (mr_dense_bones / mr_dense_weights, kept by data saved in sessions 25-35 for follow_twist
          // through the layer, are no longer read.)
        }
        NativeScope nogil;
        return SkeletalRig::from_data(d);
      });
}

}  // namespace dgmesh::py
