// What the A/B runner (runner.cpp) and each side (side.cpp) agree on: the
// shading inputs and the entry point every side defines under its own name
// (ab_render_a, ab_render_b).
#pragma once

#include <cstdint>

// What shade() reads besides the ids: the mesh as the caller holds it (the
// ids index its faces), the camera and the light; normals for smooth
// shading, nullptr for flat.
struct AbShading {
  const double* positions;
  int64_t n_vertices;
  const int32_t* faces;
  int64_t n_faces;
  const double* normals;
  const double* viewer;  // 4
  const double* light;   // 3
  uint8_t* image;        // (height, width, 3)
};

// Renders one frame into planes whose rows start `pitch` pixels apart;
// with `shading`, shades it too. out: the time measured (the render's
// total_ms, or with `shading` the shading call's), pixels tested, pixels
// written. Returns 1 for an unknown algorithm, 3 if pitch != width and the
// side's core has no row pitch (trees before bc41dc3).
using AbRender = int(const char* algo, const double* positions, int64_t n_vertices,
                     const int32_t* faces, const int32_t* face_ids, int64_t n_faces,
                     const int32_t* cell_start, const double* cell_centre, int64_t n_cells,
                     const double* mvp, float* depth, int32_t* ids, int width, int height,
                     int pitch, const AbShading* shading, double* out);
extern "C" AbRender ab_render_a, ab_render_b;
