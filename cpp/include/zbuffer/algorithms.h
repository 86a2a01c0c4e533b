// The registry of depth algorithms.
//
// Every algorithm is a free function with one signature, found by name. An
// algorithm only decides which triangles and pixels to visit and in what
// order; the vertex stage (vertex_stage.h) and the raster core (raster.h) do
// the rest, which is why all of them produce the same bits.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "zbuffer/types.h"

namespace zbuffer {

// Renders one frame into target, which render() has already cleared to
// depth +inf and id -1. Adds to stats; never throws for valid input.
using AlgorithmFn = void (*)(const RenderInput& input, DepthTarget& target,
                             RenderStats& stats);

struct Algorithm {
  const char* name;     // the name users pass as algo=
  const char* summary;  // one line for help texts
  AlgorithmFn render;
  bool polygons = false;  // draws RenderInput::polygons natively
  bool pyramid = false;   // tests against a Z-pyramid (fills RenderInput::culls)
  bool row_by_row = false;  // writes the target a finished row at a time
};

// All algorithms, in the order they are presented to users.
const std::vector<Algorithm>& algorithms();

// The algorithm called `name`, or nullptr.
const Algorithm* find_algorithm(const std::string& name);

// "zbuffer", "scanline", ... for error messages.
std::string algorithm_names();

// Depth +inf and id -1 everywhere.
void clear_target(DepthTarget& target);

// Design decision: at widths that are a multiple of 1024 pixels a row of
// either plane is a whole number of 4 KiB pages, so all the rows of a
// column share an L1 cache set; if the id plane also starts within 512
// bytes of the depth plane modulo 4 KiB, each pixel's id shares its depth's
// set as well, and drawing small triangles thrashes it: bunny_69k 1.8x
// slower at 1024 x 1024, 1.3x at 2048 x 2048 (two page-aligned np.empty
// planes passed as out= do this; the binding places its own 2 KiB apart).
// There the ids are drawn into a scratch plane placed 2 KiB off the depth
// plane and copied into the caller's at the end, 0.1-0.2 ms at 1024 x 1024.
// Good: the caller's arrays can be anywhere. Bad: a copy, and a scratch
// plane per thread (kept for the next frame after images of up to
// 4096 x 4096 pixels: 64 MiB), in that case alone.
// Algorithms that write a finished row at a time (Algorithm::row_by_row)
// draw into the caller's plane whatever its place.
bool planes_share_cache_sets(const DepthTarget& target);

// The id plane to draw into for `target` (see above): its own, or a scratch
// plane of this thread whose ids finish() copies into it.
class PlacedIds {
 public:
  PlacedIds(const DepthTarget& target, bool allow_scratch);
  int32_t* plane() const { return plane_; }
  bool scratch() const { return plane_ != ids_; }
  void finish() const;  // the scratch plane's ids into the target's plane
  static size_t thread_scratch_size();  // ids this thread's scratch holds (for tests)

 private:
  int32_t* ids_;
  int32_t* plane_;
  size_t pixels_;
};

// Clears the target and has draw(DepthTarget&) render into it: the target
// itself, or the target with its ids in PlacedIds' scratch plane, copied
// into the target's after.
template <class Draw>
void draw_cleared(const DepthTarget& target, bool allow_scratch, Draw&& draw) {
  const PlacedIds ids(target, allow_scratch);
  DepthTarget drawn = target;
  drawn.triangle_id = ids.plane();
  clear_target(drawn);
  draw(drawn);
  ids.finish();
}

// Clear the target, run the algorithm, time the whole call.
void render(const Algorithm& algorithm, const RenderInput& input,
            DepthTarget& target, RenderStats& stats);

// The Algorithms
void render_zbuffer(const RenderInput& input, DepthTarget& target, RenderStats& stats);
void render_hiz(const RenderInput& input, DepthTarget& target, RenderStats& stats);
void render_scanline(const RenderInput& input, DepthTarget& target, RenderStats& stats);
void render_hiz_octree(const RenderInput& input, DepthTarget& target, RenderStats& stats);
void render_hiz_bvh(const RenderInput& input, DepthTarget& target, RenderStats& stats);

}  // namespace zbuffer
