// Shading: one pass after visibility, shared by every algorithm.
//
// Lambert diffuse plus ambient under one directional light, lit from both
// sides (a face seen from behind is shaded with its normal flipped towards
// the viewer, so open meshes look right). Colours are uniform, per vertex or
// per face. Barycentric coordinates come from intersecting the pixel's view
// ray with the triangle in world space, which makes every interpolation
// perspective-correct without any per-vertex 1/w bookkeeping.
#pragma once

#include <cstdint>

#include "zbuffer/types.h"

namespace zbuffer {

enum class ColorSource { kUniform, kPerVertex, kPerFace };

struct ShadingInput {
  MeshView mesh;
  int width = 0, height = 0;
  // (n_vertices, 3) unit vertex normals for smooth shading; nullptr shades
  // flat with each face's geometric normal.
  const double* vertex_normals = nullptr;
  ColorSource color_source = ColorSource::kUniform;
  const float* colors = nullptr;  // (n_vertices or n_faces, 3) RGB in [0, 1]
  float uniform_color[3] = {0.8f, 0.8f, 0.8f};
  double inv_mvp[16] = {};  // row-major inverse of the render's MVP
  // The viewer as a homogeneous point: (eye, 1) for a perspective camera,
  // (direction towards the camera, 0) for an orthographic one.
  double viewer[4] = {0, 0, 1, 0};
  double light_dir[3] = {0, 0, -1};  // unit direction the light travels in
  double ambient = 0.2, diffuse = 0.8;
  uint8_t background[3] = {255, 255, 255};
};

// Writes the (height, width, 3) RGB image for the visibility result ids.
void shade(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image);

}  // namespace zbuffer
