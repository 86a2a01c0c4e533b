// One side of an A/B comparison (benchmarks/ab.py): compiled once per source
// tree with -Dzbuffer=zb_a or -Dzbuffer=zb_b and -DAB_SIDE=ab_render_a or
// ab_render_b, so that the two cores live in one process under two
// namespaces. It builds its own RenderInput, DepthTarget and ShadingInput
// from plain arrays, so the two trees' structs may differ.
#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>

#include "zbuffer/algorithms.h"
#include "zbuffer/bvh.h"
#include "zbuffer/object_tree.h"
#include "zbuffer/octree.h"
#include "zbuffer/shading.h"
#include "side.h"

namespace {
// `hiz_octree@once`, `hiz_bvh@once`: the kind of tree zbuffer.Scene builds
// (default parameters; here over the case's prepared arrays), built at the
// first frame of a mesh and rendered from then on with its frame state, as
// Scene.render does. False for any other name.
bool render_built_once(const std::string& algo, const zbuffer::RenderInput& in,
                       zbuffer::DepthTarget& target, zbuffer::RenderStats& stats) {
  static std::string built_for;
  static const double* built_positions = nullptr;
  static int64_t built_faces = -1;
  static zbuffer::ObjectTree tree;
  static zbuffer::TreeFrame frame;
  if (algo != "hiz_octree@once" && algo != "hiz_bvh@once") return false;
  if (algo != built_for || in.mesh.positions != built_positions || in.mesh.n_faces != built_faces) {
    if (algo == "hiz_octree@once")
      tree = zbuffer::build_octree(in.mesh, zbuffer::OctreeParams());
    else
      tree = zbuffer::build_bvh(in.mesh, zbuffer::BvhParams());
    frame = zbuffer::TreeFrame();
    built_for = algo;
    built_positions = in.mesh.positions;
    built_faces = in.mesh.n_faces;
  }
  zbuffer::render_tree_frame(tree, in, target, stats, frame);
  return true;
}

// Sets t.pitch where the side's core has one (DepthTarget, ShadingInput);
// false where it has none.
template <class T>
auto set_pitch(T& t, int pitch, int) -> decltype(t.pitch = pitch, bool()) {
  t.pitch = pitch;
  return true;
}
template <class T>
bool set_pitch(T&, int, long) {
  return false;
}
}  // namespace

// The declaration the definition below must match (side.h: AbRender).
extern "C" AbRender AB_SIDE;

extern "C" int AB_SIDE(const char* algo, const double* positions, int64_t n_vertices,
                       const int32_t* faces, const int32_t* face_ids, int64_t n_faces,
                       const int32_t* cell_start, const double* cell_centre, int64_t n_cells,
                       const double* mvp, float* depth, int32_t* ids, int width, int height,
                       int pitch, const AbShading* shading, double* out) {
  zbuffer::RenderInput in;
  in.mesh.positions = positions;
  in.mesh.n_vertices = n_vertices;
  in.mesh.faces = faces;
  in.mesh.face_ids = face_ids;
  in.mesh.n_faces = n_faces;
  in.cells.start = cell_start;
  in.cells.centre = cell_centre;
  in.cells.n = n_cells;
  std::memcpy(in.mvp, mvp, sizeof(in.mvp));
  zbuffer::DepthTarget target;
  target.depth = depth;
  target.triangle_id = ids;
  target.width = width;
  target.height = height;
  if (!set_pitch(target, pitch, 0) && pitch != width) return 3;
  zbuffer::RenderStats stats;
  if (const zbuffer::Algorithm* algorithm = zbuffer::find_algorithm(algo))
    zbuffer::render(*algorithm, in, target, stats);
  else if (!render_built_once(algo, in, target, stats))
    return 1;
  out[0] = stats.total_ms;
  out[1] = double(stats.pixels_tested);
  out[2] = double(stats.pixels_written);
  if (shading) {
    zbuffer::ShadingInput s;
    s.mesh.positions = shading->positions;
    s.mesh.n_vertices = shading->n_vertices;
    s.mesh.faces = shading->faces;
    s.mesh.n_faces = shading->n_faces;
    s.width = width;
    s.height = height;
    set_pitch(s, pitch, 0);
    s.vertex_normals = shading->normals;
    std::memcpy(s.mvp, mvp, sizeof(s.mvp));
    std::memcpy(s.viewer, shading->viewer, sizeof(s.viewer));
    std::memcpy(s.light_dir, shading->light, sizeof(s.light_dir));
    const auto start = std::chrono::steady_clock::now();
    zbuffer::shade(s, ids, shading->image);
    out[0] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  return 0;
}
