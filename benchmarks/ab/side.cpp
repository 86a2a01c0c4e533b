// One side of an A/B comparison (benchmarks/ab.py): compiled once per source
// tree with -Dzbuffer=zb_a or -Dzbuffer=zb_b and -DAB_SIDE=ab_render_a or
// ab_render_b, so that the two cores live in one process under two
// namespaces. It builds its own RenderInput and DepthTarget from plain
// arrays, so the two trees' structs may differ.
#include <cstdint>
#include <cstring>

#include "zbuffer/algorithms.h"

extern "C" int AB_SIDE(const char* algo, const double* positions, int64_t n_vertices,
                       const int32_t* faces, const int32_t* face_ids, int64_t n_faces,
                       const int32_t* cell_start, const double* cell_centre, int64_t n_cells,
                       const double* mvp, float* depth, int32_t* ids, int width, int height,
                       double* out /* total_ms, pixels_tested, pixels_written */) {
  const zbuffer::Algorithm* algorithm = zbuffer::find_algorithm(algo);
  if (!algorithm) return 1;
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
  zbuffer::RenderStats stats;
  zbuffer::render(*algorithm, in, target, stats);
  out[0] = stats.total_ms;
  out[1] = double(stats.pixels_tested);
  out[2] = double(stats.pixels_written);
  return 0;
}
