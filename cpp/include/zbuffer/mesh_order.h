// A cache-friendly order to visit a mesh's faces in.
//
// Every algorithm's output is independent of the order faces are visited in
// (the depth write is a pure minimum), so an algorithm may visit them in any
// order it likes. Files often list faces in an order with no spatial
// coherence at all; drawn in that order, consecutive triangles land far apart
// in the frame buffer and most depth tests miss the caches.
#pragma once

#include <cstdint>
#include <vector>

#include "zbuffer/types.h"

namespace zbuffer {

// The coarse grid of FaceCells: the Z-order's top kCellLevels levels, at
// most 8 x 8 x 8 cells over the cube around the vertices. Finer cells order
// a frame better and cost a partly filled vector of faces each.
constexpr int kCellLevels = 3;

// Writes to order[0 .. n_faces) a permutation of the faces sorted along a
// Z-order (Morton) curve through their centroids, 10 bits per axis of the
// cube around the vertices (the grid of the per-frame trees, so that their
// buckets come in order too); ties keep the input order. Meant to be
// computed once per mesh and reused.
//
// `cell_start` and `cell_centre` receive the FaceCells of the faces in that
// order: the nonempty cells of the coarse grid, in Z-order.
void spatial_order(const MeshView& mesh, int32_t* order, std::vector<int32_t>& cell_start,
                   std::vector<double>& cell_centre);

// Renumbers the vertices of `faces` (n_faces rows of 3 indices below
// n_vertices) in the order the faces first use them, writing the faces so
// renumbered to `renumbered` (which may be `faces` itself); vertices no face
// uses follow, in their old order. old_of_new[0 .. n_vertices) receives the
// permutation: new vertex v is old vertex old_of_new[v].
// Design decision: faces in spatial order and vertices in the order of
// their first use, so that consecutive faces read neighbouring vertices
// (the vertex stage's outputs, read by assembly, stay in the nearest
// caches). Good: 3-6% off single meshes, 10-20% off the 5 x 5 x N spot
// grid at N = 20-40 (one process, medians of 7-9), for the same bits.
// Bad: a prepared mesh holds a second copy of its positions (24 bytes a
// vertex).
void first_use_order(const int32_t* faces, int64_t n_faces, int64_t n_vertices,
                     int32_t* renumbered, int32_t* old_of_new);

// The order to visit `cells` in for a frame with this mvp: nearest first, by
// the clip-space z of their centres (an affine function of the view depth
// under perspective and orthographic projections alike). Ties keep Z-order.
void near_to_far(const FaceCells& cells, const double* mvp, std::vector<int32_t>& visit);

}  // namespace zbuffer
