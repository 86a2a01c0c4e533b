// Input validation the bindings run before any rendering (with the GIL held),
// so that bad input becomes a Python exception instead of a crash.
#pragma once

#include <cstdint>

#include "zbuffer/types.h"

namespace zbuffer {

// Position in the flattened (M * 3) face array of the first index outside
// [0, n_vertices), or -1 if all are valid. n_vertices must be below 2^31
// (it is compared as uint32; the bindings refuse larger meshes first).
int64_t find_bad_face_index(const MeshView& mesh);

// Index of the first face whose face_ids entry is negative, or -1 (also if
// the mesh has no face_ids).
int64_t find_negative_id(const MeshView& mesh);

// Index of the first vertex with a NaN or infinite coordinate, or -1.
int64_t find_nonfinite_vertex(const MeshView& mesh);

// Index of the first of the n ids outside [-1, n_faces) (a triangle_id
// image: -1 where nothing was drawn), or -1.
int64_t find_bad_triangle_id(const int32_t* ids, int64_t n, int64_t n_faces);

}  // namespace zbuffer
