// The registry of depth algorithms.
//
// Every algorithm is a free function with one signature, found by name. An
// algorithm only decides which triangles and pixels to visit and in what
// order; the vertex stage (vertex_stage.h) and the raster core (raster.h) do
// the rest, which is why all of them produce the same bits.
#pragma once

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
};

// All algorithms, in the order they are presented to users.
const std::vector<Algorithm>& algorithms();

// The algorithm called `name`, or nullptr.
const Algorithm* find_algorithm(const std::string& name);

// "zbuffer", "scanline", ... for error messages.
std::string algorithm_names();

// Depth +inf and id -1 everywhere.
void clear_target(DepthTarget& target);

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
