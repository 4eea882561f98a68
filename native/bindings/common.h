// Shared helpers of the pybind11 module: numpy <-> Eigen without copies where the layout allows,
// progress callbacks that take the GIL, and the per-capability bind functions.
#pragma once
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh::py {

namespace pb = pybind11;

// C-contiguous float64 (n,3) / int32 (m,3) arrays bind without a copy; anything else is converted.
using InV = Eigen::Ref<const MatX3d>;
using InF = Eigen::Ref<const MatX3i>;

// Wraps an optional Python callable(fraction) -> bool|None; None or a truthy result continues.
inline ProgressFn progress_from(const pb::object& cb) {
  if (cb.is_none()) return {};
  return [cb](double fraction) {
    pb::gil_scoped_acquire gil;
    pb::object r = cb(fraction);
    return r.is_none() || static_cast<bool>(pb::bool_(r));  // Python truthiness: False, 0, "" cancel
  };
}

void bind_core(pb::module_& m);
void bind_crest(pb::module_& m);
void bind_fair(pb::module_& m);
void bind_unwrap(pb::module_& m);
void bind_denoise(pb::module_& m);
void bind_skeletal(pb::module_& m);
void bind_multires(pb::module_& m);
void bind_remesh(pb::module_& m);

}  // namespace dgmesh::py
