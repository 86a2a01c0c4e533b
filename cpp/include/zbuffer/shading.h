// Shading: one pass after visibility, shared by every algorithm.
//
// Lambert diffuse plus ambient under one directional light, lit from both
// sides (a face seen from behind is shaded with its normal flipped towards
// the viewer, so open meshes look right). Colours are uniform, per vertex or
// per face. Interpolation is perspective-correct: the barycentric coordinates
// of a pixel centre are adj(M) (x_ndc, y_ndc, 1), normalised to sum 1, where
// M holds the clip-space (x, y, w) of the triangle's corners as columns --
// exact for any triangle, even one reaching behind the camera -- and
// clamped into [0, 1] (a snapped pixel centre may lie a hair outside the
// triangle). The vector passes interpolate smooth normals by an equivalent
// per-face linear map without that clamp (shading.cpp, FaceShade), and
// shade the faces where that could stray (slivers, near-degenerate faces)
// the clamped way afterwards: within one level of the scalar pass.
#pragma once

#include <cstdint>

#include "zbuffer/types.h"

namespace zbuffer {

enum class ColorSource { kUniform, kPerVertex, kPerFace };

struct ShadingInput {
  MeshView mesh;
  int width = 0, height = 0;
  // Pixels from a row of the ids to the next (0: width; DepthTarget.pitch).
  // The image's rows are contiguous.
  int pitch = 0;
  size_t id_pitch() const { return size_t(pitch ? pitch : width); }
  // (n_vertices, 3) unit vertex normals for smooth shading; nullptr shades
  // flat with each face's geometric normal.
  const double* vertex_normals = nullptr;
  ColorSource color_source = ColorSource::kUniform;
  const float* colors = nullptr;  // (n_vertices or n_faces, 3) RGB in [0, 1]
  float uniform_color[3] = {0.8f, 0.8f, 0.8f};
  double mvp[16] = {};  // row-major model-view-projection matrix of the render
  // The viewer as a homogeneous point: (eye, 1) for a perspective camera,
  // (direction towards the camera, 0) for an orthographic one.
  double viewer[4] = {0, 0, 1, 0};
  double light_dir[3] = {0, 0, -1};  // unit direction the light travels in
  double ambient = 0.2, diffuse = 0.8;
  uint8_t background[3] = {255, 255, 255};
  // True when a pixel may lie anywhere outside the face its id names: a
  // polygon drawn natively gives all its pixels its first triangle's id
  // (docs/rasterization.md, 3.7). Interpolated shading then clamps every
  // pixel the scalar pass's way (the vector passes' bounds assume pixel
  // centres on their face).
  bool pixels_beyond_faces = false;
};

// Writes the (height, width, 3) RGB image for the visibility result ids,
// with the fastest pass this build has (16 pixels at a time in float32 with
// AVX-512, 8 with AVX2, else the scalar pass).
void shade(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image);

// The plain pass in double precision, one pixel at a time: kept callable so
// that tests can hold the vector pass to it (within one level of 255).
void shade_scalar(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image);

// Area-weighted unit vertex normals into out (n_vertices, 3): each vertex
// sums (b - a) x (c - a) of the faces (a, b, c) it is a corner of -- every
// face's first corner in face order, then the second corners, then the
// third -- and the sum is divided by its length (zero where the sum is
// zero, and for unused vertices). The order and the IEEE operations of
// Mesh.vertex_normals' numpy definition (reference.vertex_normals), so the
// same bits. Faces must index the vertices (mesh_checks.h).
void vertex_normals(const MeshView& mesh, double* out);

}  // namespace zbuffer
