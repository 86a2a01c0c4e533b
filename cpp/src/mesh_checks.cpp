#include "zbuffer/mesh_checks.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace zbuffer {

int64_t find_negative_id(const MeshView& mesh) {
  if (!mesh.face_ids) return -1;
  int32_t lowest = 0;
  for (int64_t f = 0; f < mesh.n_faces; ++f) lowest = std::min(lowest, mesh.face_ids[f]);
  if (lowest >= 0) return -1;
  for (int64_t f = 0; f < mesh.n_faces; ++f)
    if (mesh.face_ids[f] < 0) return f;
  return -1;
}

int64_t find_bad_face_index(const MeshView& mesh) {
  const int64_t n = mesh.n_faces * 3;
  // The largest index read as unsigned catches negative ones too; a max
  // reduction vectorises, and only a failure looks for where.
  const uint32_t limit = uint32_t(mesh.n_vertices);
  uint32_t largest = 0;
  for (int64_t i = 0; i < n; ++i) largest = std::max(largest, uint32_t(mesh.faces[i]));
  if (n == 0 || largest < limit) return -1;
  for (int64_t i = 0; i < n; ++i)
    if (uint32_t(mesh.faces[i]) >= limit) return i;
  return -1;
}

int64_t find_bad_triangle_id(const int32_t* ids, int64_t n, int64_t n_faces) {
  // As above: id + 1 read as unsigned is at most n_faces exactly for the
  // ids in [-1, n_faces) (wrapping in uint32: -1 -> 0, INT32_MIN -> 2^31 + 1).
  uint32_t largest = 0;
  for (int64_t i = 0; i < n; ++i) largest = std::max(largest, uint32_t(ids[i]) + 1u);
  if (int64_t(largest) <= n_faces) return -1;
  for (int64_t i = 0; i < n; ++i)
    if (int64_t(uint32_t(ids[i]) + 1u) > n_faces) return i;
  return -1;
}

int64_t find_nonfinite_vertex(const MeshView& mesh) {
  const int64_t n = mesh.n_vertices * 3;
  // Inf and NaN have all exponent bits set: an integer test on the bits
  // vectorises (a floating-point one would not, without -ffast-math).
  constexpr uint64_t kExponent = 0x7FF0000000000000ull;
  uint64_t any = 0;
  for (int64_t i = 0; i < n; ++i) {
    uint64_t bits;
    std::memcpy(&bits, mesh.positions + i, sizeof bits);
    any |= uint64_t((bits & kExponent) == kExponent);
  }
  if (!any) return -1;
  for (int64_t i = 0; i < n; ++i)
    if (!std::isfinite(mesh.positions[i])) return i / 3;
  return -1;
}

}  // namespace zbuffer
