// Z-order of face centroids, by a radix sort of 30-bit Morton keys.
#include "zbuffer/mesh_order.h"

#include <algorithm>
#include <vector>

#include "morton.h"

namespace zbuffer {

void spatial_order(const MeshView& mesh, int32_t* order) {
  const int64_t n = mesh.n_faces;
  if (n == 0) return;

  // Centroids (times 3) and their bounds.
  std::vector<float> centre(3 * size_t(n));
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (int64_t f = 0; f < n; ++f) {
    const int32_t* idx = mesh.faces + 3 * f;
    for (int k = 0; k < 3; ++k) {
      const double c = mesh.positions[3 * int64_t(idx[0]) + k] +
                       mesh.positions[3 * int64_t(idx[1]) + k] +
                       mesh.positions[3 * int64_t(idx[2]) + k];
      centre[3 * f + k] = float(c);
      lo[k] = std::min(lo[k], c);
      hi[k] = std::max(hi[k], c);
    }
  }
  double scale[3];
  for (int k = 0; k < 3; ++k) scale[k] = hi[k] > lo[k] ? 1023.0 / (hi[k] - lo[k]) : 0.0;

  std::vector<uint32_t> key(static_cast<size_t>(n));
  std::vector<int32_t> faces(static_cast<size_t>(n));
  for (int64_t f = 0; f < n; ++f) {
    uint32_t cell[3];
    for (int k = 0; k < 3; ++k) {
      const double q = (double(centre[3 * f + k]) - lo[k]) * scale[k];
      cell[k] = uint32_t(std::min(1023.0, std::max(0.0, q)));
    }
    key[size_t(f)] = morton_30(cell[0], cell[1], cell[2]);
    faces[size_t(f)] = int32_t(f);
  }
  radix_sort(key, faces, 30);  // stable: ties keep the input order
  std::copy(faces.begin(), faces.end(), order);
}

}  // namespace zbuffer
