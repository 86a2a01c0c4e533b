// A cache-friendly order to visit a mesh's faces in.
//
// Every algorithm's output is independent of the order faces are visited in
// (the depth write is a pure minimum), so an algorithm may visit them in any
// order it likes. Files often list faces in an order with no spatial
// coherence at all; drawn in that order, consecutive triangles land far apart
// in the frame buffer and most depth tests miss the caches.
#pragma once

#include <cstdint>

#include "zbuffer/types.h"

namespace zbuffer {

// Writes to order[0 .. n_faces) a permutation of the faces sorted along a
// Z-order (Morton) curve through their centroids, 10 bits per axis of the
// cube around the vertices (the grid of the per-frame trees, so that their
// buckets come in order too); ties keep the input order. Meant to be
// computed once per mesh and reused.
void spatial_order(const MeshView& mesh, int32_t* order);

}  // namespace zbuffer
