// Z-order of face centroids, by a radix sort of 30-bit Morton keys.
#include "zbuffer/mesh_order.h"

#include <algorithm>
#include <vector>

#include "morton.h"

namespace zbuffer {

void spatial_order(const MeshView& mesh, int32_t* order) {
  const int64_t n = mesh.n_faces;
  if (n == 0) return;
  // The centroids' cells on the vertex grid the per-frame trees use (see
  // VertexGrid::centroid_code).
  VertexGrid grid;
  grid.build(mesh);
  std::vector<uint32_t> key(static_cast<size_t>(n));
  std::vector<int32_t> faces(static_cast<size_t>(n));
  for (int64_t f = 0; f < n; ++f) {
    key[size_t(f)] = grid.centroid_code(mesh.faces + 3 * f);
    faces[size_t(f)] = int32_t(f);
  }
  radix_sort(key, faces, 30);  // stable: ties keep the input order
  std::copy(faces.begin(), faces.end(), order);
}

}  // namespace zbuffer
