// Private to the core: Morton (Z-order) codes and the radix sort that orders
// faces by them. The spatial visiting order (mesh_order.cpp), the octree and
// the BVH all start from faces sorted along this curve.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace zbuffer {

// Spread the low 10 bits of v so that bit i lands on bit 3 i.
inline uint32_t spread_bits_10(uint32_t v) {
  v &= 0x3FF;
  v = (v | (v << 16)) & 0x030000FF;
  v = (v | (v << 8)) & 0x0300F00F;
  v = (v | (v << 4)) & 0x030C30C3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

// The 30-bit Morton code of a cell of a 1024^3 grid: x in bits 0, 3, 6 ...
inline uint32_t morton_30(uint32_t x, uint32_t y, uint32_t z) {
  return spread_bits_10(x) | (spread_bits_10(y) << 1) | (spread_bits_10(z) << 2);
}

// Sorts (key, value) pairs by the low `key_bits` bits of key, stably, with
// passes of up to 12 bits (LSD radix sort). Both vectors are permuted.
// Design decision: LSD radix rather than a comparison sort. Good: linear in
// the number of faces (a few ns per face and pass), which keeps building a
// tree per frame affordable. Bad: a scratch copy of both arrays.
template <class Key, class Value>
void radix_sort(std::vector<Key>& key, std::vector<Value>& value, int key_bits) {
  const size_t n = key.size();
  if (n < 2 || key_bits <= 0) return;
  const int passes = (key_bits + 11) / 12;
  const int bits = (key_bits + passes - 1) / passes;
  const Key mask = (Key(1) << bits) - 1;
  std::vector<Key> key_tmp(n);
  std::vector<Value> value_tmp(n);
  std::vector<size_t> count(size_t(1) << bits);
  for (int pass = 0; pass < passes; ++pass) {
    const int shift = pass * bits;
    std::fill(count.begin(), count.end(), 0);
    for (size_t i = 0; i < n; ++i) ++count[(key[i] >> shift) & mask];
    size_t sum = 0;
    for (size_t& c : count) {
      const size_t here = c;
      c = sum;
      sum += here;
    }
    for (size_t i = 0; i < n; ++i) {
      const size_t dst = count[(key[i] >> shift) & mask]++;
      key_tmp[dst] = key[i];
      value_tmp[dst] = value[i];
    }
    key.swap(key_tmp);
    value.swap(value_tmp);
  }
}

}  // namespace zbuffer
