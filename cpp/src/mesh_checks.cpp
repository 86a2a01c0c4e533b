#include "zbuffer/mesh_checks.h"

#include <cmath>

namespace zbuffer {

int64_t find_bad_face_index(const MeshView& mesh) {
  const int64_t n = mesh.n_faces * 3;
  // One unsigned comparison per index catches negative ones too; the loop
  // has no early exit so that it vectorises, and only then looks for where.
  const uint32_t limit = uint32_t(mesh.n_vertices);
  bool bad = false;
  for (int64_t i = 0; i < n; ++i) bad |= uint32_t(mesh.faces[i]) >= limit;
  if (!bad) return -1;
  for (int64_t i = 0; i < n; ++i)
    if (uint32_t(mesh.faces[i]) >= limit) return i;
  return -1;
}

int64_t find_nonfinite_vertex(const MeshView& mesh) {
  const int64_t n = mesh.n_vertices * 3;
  bool bad = false;
  for (int64_t i = 0; i < n; ++i) bad |= !std::isfinite(mesh.positions[i]);
  if (!bad) return -1;
  for (int64_t i = 0; i < n; ++i)
    if (!std::isfinite(mesh.positions[i])) return i / 3;
  return -1;
}

}  // namespace zbuffer
