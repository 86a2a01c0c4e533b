// Z-order of face centroids, by a two-pass radix sort of 30-bit keys.
#include "zbuffer/mesh_order.h"

#include <algorithm>
#include <vector>

namespace zbuffer {

namespace {

// Spread the low 10 bits of v so that bit i lands on bit 3 i.
uint32_t spread_bits(uint32_t v) {
  v &= 0x3FF;
  v = (v | (v << 16)) & 0x030000FF;
  v = (v | (v << 8)) & 0x0300F00F;
  v = (v | (v << 4)) & 0x030C30C3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

}  // namespace

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

  const size_t faces = size_t(n);
  std::vector<uint32_t> key(faces), key_tmp(faces);
  std::vector<int32_t> tmp(faces);
  for (int64_t f = 0; f < n; ++f) {
    uint32_t code = 0;
    for (int k = 0; k < 3; ++k) {
      const double q = (double(centre[3 * f + k]) - lo[k]) * scale[k];
      const uint32_t cell = uint32_t(std::min(1023.0, std::max(0.0, q)));
      code |= spread_bits(cell) << k;
    }
    key[f] = code;
    order[f] = int32_t(f);
  }

  // Stable LSD radix sort on 2 x 15 bits.
  std::vector<int64_t> count(1 << 15);
  for (int shift = 0; shift < 30; shift += 15) {
    std::fill(count.begin(), count.end(), 0);
    for (int64_t f = 0; f < n; ++f) ++count[(key[f] >> shift) & 0x7FFF];
    int64_t sum = 0;
    for (auto& c : count) {
      const int64_t here = c;
      c = sum;
      sum += here;
    }
    for (int64_t f = 0; f < n; ++f) {
      const int64_t dst = count[(key[f] >> shift) & 0x7FFF]++;
      key_tmp[dst] = key[f];
      tmp[dst] = order[f];
    }
    key.swap(key_tmp);
    std::copy(tmp.begin(), tmp.end(), order);
  }
}

}  // namespace zbuffer
