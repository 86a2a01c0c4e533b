// Vertex stage: per-vertex transform and Sutherland-Hodgman clipping.
#include "zbuffer/vertex_stage.h"

#include <cmath>

namespace zbuffer {

void transform_vertices(const MeshView& mesh, const double* mvp,
                        const Viewport& vp, ScreenVertex* out) {
  for (int64_t i = 0; i < mesh.n_vertices; ++i) {
    const ClipVertex c = transform_point(mvp, mesh.positions + 3 * i);
    const uint32_t oc = outcode(c, vp);
    ScreenVertex s{};
    // Vertices that need clipping get their window coordinates from the
    // clipped polygon instead; theirs could be unbounded here.
    if (!(oc & (kOutClip | kOutInvalid))) s = to_screen(c, vp);
    s.outcode = oc;
    out[i] = s;
  }
}

int clip_polygon(ClipVertex* poly, int n, const Viewport& vp) {
  ClipVertex tmp[kMaxClipVertices];
  double d[kMaxClipVertices];
  for (int plane = 0; plane < 6 && n >= 3; ++plane) {
    bool any_out = false;
    for (int k = 0; k < n; ++k) {
      d[k] = plane_distance(plane, poly[k], vp);
      any_out |= d[k] < 0.0;
    }
    if (!any_out) continue;  // clipping would return the polygon unchanged

    // Walk the edges (prev -> cur); keep inside vertices and add a vertex
    // where an edge crosses the plane.
    int m = 0;
    for (int k = 0; k < n; ++k) {
      const int prev = (k + n - 1) % n;
      const bool prev_in = d[prev] >= 0.0, cur_in = d[k] >= 0.0;
      if (cur_in != prev_in) {
        tmp[m++] = cur_in ? clip_intersection(poly[k], d[k], poly[prev], d[prev])
                          : clip_intersection(poly[prev], d[prev], poly[k], d[k]);
      }
      if (cur_in) tmp[m++] = poly[k];
    }
    for (int k = 0; k < m; ++k) poly[k] = tmp[k];
    n = m;
  }
  if (n < 3) return 0;
  for (int k = 0; k < n; ++k) {
    const ClipVertex& c = poly[k];
    if (!(c.w > 0.0) || !std::isfinite(c.x) || !std::isfinite(c.y) ||
        !std::isfinite(c.z) || !std::isfinite(c.w))
      return 0;
  }
  return n;
}

}  // namespace zbuffer
