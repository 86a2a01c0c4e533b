// Z-order of face centroids, by a radix sort of 30-bit Morton keys, and the
// coarse cells of that order.
#include "zbuffer/mesh_order.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "morton.h"

namespace zbuffer {

void spatial_order(const MeshView& mesh, int32_t* order, std::vector<int32_t>& cell_start,
                   std::vector<double>& cell_centre) {
  cell_start.assign(1, 0);
  cell_centre.clear();
  const int64_t n = mesh.n_faces;
  if (n == 0) return;
  // The centroids' cells on the vertex grid the per-frame trees use (see
  // VertexGrid::centroid_code).
  VertexGrid grid;
  grid.build(mesh);
  std::vector<uint64_t> words;  // code << 32 | face
  sorted_centroid_codes(grid, mesh, words);  // stable: ties keep the input order
  for (int64_t f = 0; f < n; ++f) order[f] = int32_t(uint32_t(words[size_t(f)]));

  // Runs of equal top 3 * kCellLevels key bits; a cell's centre from its
  // coordinates on the grid (each coarse cell is 2^(10 - kCellLevels) grid
  // cells a side).
  constexpr int kShift = 3 * (VertexGrid::kBits - kCellLevels);
  const double side = grid.cell_size * double(1 << (VertexGrid::kBits - kCellLevels));
  for (int64_t f = 0; f < n; ++f) {
    const uint32_t cell = uint32_t(words[size_t(f)] >> (32 + kShift));
    if (f + 1 < n && words[size_t(f) + 1] >> (32 + kShift) == cell) continue;
    cell_start.push_back(int32_t(f + 1));
    for (int a = 0; a < 3; ++a) {
      uint32_t c = 0;  // every third bit of the code, from bit a
      for (int b = 0; b < kCellLevels; ++b) c |= ((cell >> (3 * b + a)) & 1u) << b;
      cell_centre.push_back(grid.origin[a] + (double(c) + 0.5) * side);
    }
  }
}

void first_use_order(const int32_t* faces, int64_t n_faces, int64_t n_vertices,
                     int32_t* renumbered, int32_t* old_of_new) {
  std::vector<int32_t> new_of_old(static_cast<size_t>(n_vertices), -1);
  int32_t next = 0;
  for (int64_t i = 0; i < 3 * n_faces; ++i) {
    const int32_t v = faces[i];
    int32_t& renamed = new_of_old[size_t(v)];
    if (renamed < 0) {
      renamed = next;
      old_of_new[next++] = v;
    }
    renumbered[i] = renamed;
  }
  for (int64_t v = 0; v < n_vertices; ++v)
    if (new_of_old[size_t(v)] < 0) old_of_new[next++] = int32_t(v);
}

void near_to_far(const FaceCells& cells, const double* mvp, std::vector<int32_t>& visit) {
  std::vector<double> z(static_cast<size_t>(cells.n));
  for (int64_t k = 0; k < cells.n; ++k) {
    const double* c = cells.centre + 3 * k;
    const double key = mvp[8] * c[0] + mvp[9] * c[1] + mvp[10] * c[2] + mvp[11];
    // (Finite centres can still sum to NaN, inf - inf: such a cell goes last,
    // so that the comparison stays a strict weak order.)
    z[size_t(k)] = std::isnan(key) ? std::numeric_limits<double>::infinity() : key;
  }
  visit.resize(size_t(cells.n));
  std::iota(visit.begin(), visit.end(), 0);
  std::stable_sort(visit.begin(), visit.end(), [&](int32_t a, int32_t b) { return z[size_t(a)] < z[size_t(b)]; });
}

}  // namespace zbuffer
