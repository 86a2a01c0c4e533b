// The hierarchical Z-buffer (Greene, Kass and Miller 1993), image-space part:
// every triangle is tested against the Z-pyramid before it is drawn, and a
// large triangle that passes is drawn tile by tile, skipping tiles the
// pyramid shows to be nearer than the whole triangle (triangle_batch.h).
// Visiting a mesh's faces near to far (by the coarse cells of its spatial
// order) lets the front of a closed mesh hide its back.
//
// Both tests are strict (the triangle's nearest possible depth, z_lo, must
// be greater than the region's farthest depth), so a culled triangle could
// not have won a single pixel, not even a tie: the output equals the plain
// Z-buffer's bit for bit.
#include "zbuffer/algorithms.h"
#include "zbuffer/triangle_batch.h"
#include "zbuffer/zpyramid.h"

namespace zbuffer {

void render_hiz(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  // A pyramid over the (cleared) depth buffer, kept from 8x8-pixel cells
  // (level 3) up: the batch tests triangles against it, skips hidden tiles
  // of large ones, and keeps it up to date. Faces come cell by cell, nearest
  // first, when the mesh has cells (FaceCells). Batches are tested against
  // the pyramid as it was after the previous batch (or, with lazy upkeep,
  // after the last batch that culled enough to be worth updating for: up to
  // 1 + TriangleBatch::kMaxSkippedUpdates batches back), so smaller ones cull
  // sooner but cost more upkeep: 128 instead of 512 made single meshes ~4%
  // slower. Keeping 4x4 cells too (as the tree algorithms do for meshes of at
  // least as many triangles as pixels) made them
  // 1-4% slower, and so did finer cells (16 x 16 x 16: up to 25% on small
  // meshes, whose cells then hold a few faces each).
  ZPyramid pyramid(target.depth, target.width, target.height, 3, /*cleared=*/true, target.pitch);
  pyramid.record_culls(input.culls);
  render_faces_batched(input, target, stats, &pyramid, TriangleBatch::kCapacity,
                       /*lazy_upkeep=*/true);
  stats.depth_storage_bytes = pyramid.storage_bytes();
}

}  // namespace zbuffer
