// Typed exceptions. Algorithms throw these; the Python module maps each to its own exception
// class (MeshError is a ValueError there), and the add-on turns them into operator reports.
#pragma once
#include <stdexcept>
#include <string>

namespace dgmesh {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The input mesh violates what an algorithm accepts (see validate.h for the kinds).
struct MeshError : Error {
  using Error::Error;
};

// A file could not be read or written.
struct IoError : Error {
  using Error::Error;
};

// A linear system could not be factored or solved (singular, not positive definite, ...).
struct SolverError : Error {
  using Error::Error;
};

// The user's progress callback asked to stop; nothing was changed.
struct CancelledError : Error {
  CancelledError() : Error("cancelled") {}
};

}  // namespace dgmesh
