// Mesh file input/output: OBJ, OFF and PLY (ascii, binary little/big endian).
// Readers never trust counts in a file: every count is bounded by the file size before anything is
// allocated, and every malformed input raises IoError naming the file and the line or element.
#pragma once
#include <string>

#include "dgmesh/errors.h"
#include "dgmesh/types.h"

namespace dgmesh {

struct MeshData {
  MatX3d V;
  MatX3i F;
  MatX3d N;  // per-vertex normals if the file has them (else 0 rows)
};

// Reads OBJ, OFF or PLY (ascii, binary_little_endian, binary_big_endian), chosen by extension
// (case-insensitive). Polygons are fan-triangulated. Throws IoError with a message naming the file
// and the line/element for anything malformed: missing file, bad header, truncated data,
// non-numeric tokens, index out of range, faces with < 3 vertices, unsupported PLY property types,
// absurd counts.
MeshData read_mesh(const std::string& path);

// Writes by extension: .obj, .off (text, %.17g, lossless) or .ply (binary little endian with
// float64 coordinates and int32 indices). N, if given, must have as many rows as V and is written as
// per-vertex normals (OBJ: vn with f v//n corners; OFF: NOFF; PLY: nx ny nz).
// Throws IoError if the file cannot be written, the extension is unknown, N has the wrong number of
// rows or a face index is out of range.
void write_mesh(const std::string& path, const MatX3d& V, const MatX3i& F, const MatX3d* N = nullptr);

}  // namespace dgmesh
