// A depth target owned by a C++ test, and exact comparison of two of them.
#pragma once

#include <cstring>
#include <limits>
#include <vector>

#include "zbuffer/types.h"

struct Frame {
  int w, h;
  std::vector<float> depth;
  std::vector<int32_t> ids;
  zbuffer::DepthTarget target;
  Frame(int w_, int h_)
      : w(w_), h(h_), depth(size_t(w_) * h_, std::numeric_limits<float>::infinity()),
        ids(size_t(w_) * h_, -1) {
    target = {depth.data(), ids.data(), w, h};
  }
};

// Same depth bits and ids at every pixel.
inline bool same_pixels(const Frame& a, const Frame& b) {
  bool same = true;
  for (size_t p = 0; p < a.depth.size(); ++p)
    same &= a.ids[p] == b.ids[p] && std::memcmp(&a.depth[p], &b.depth[p], sizeof(float)) == 0;
  return same;
}
