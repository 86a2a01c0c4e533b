// Plain data shared by the vertex stage, the raster core and the algorithms.
// Nothing here owns memory: the caller (the Python binding, or a C++ test)
// owns the mesh arrays and the output buffers.
#pragma once

#include <cstddef>
#include <cstdint>

namespace zbuffer {

class CullMap;  // zpyramid.h

// A triangle mesh as two row-major arrays.
// Design decision: a non-owning view of (N, 3) float64 positions and (M, 3)
// int32 faces. Good: numpy arrays pass through without copies and every
// algorithm sees the same input. Bad: int32 caps meshes at 2^31 - 1 vertices,
// and the caller must keep the arrays alive and valid (the bindings check
// them: mesh_checks.h; src/render_common.cpp, mesh_view).
//
// face_ids, if set, gives the id written for each face: an algorithm may then
// be handed the faces in another order (mesh_order.h) and still report the
// caller's face indices.
struct MeshView {
  const double* positions = nullptr;  // (n_vertices, 3) world space
  int64_t n_vertices = 0;
  const int32_t* faces = nullptr;     // (n_faces, 3) vertex indices
  int64_t n_faces = 0;
  const int32_t* face_ids = nullptr;  // (n_faces,) or nullptr: face f has id f

  int32_t id(int64_t f) const { return face_ids ? face_ids[f] : int32_t(f); }
};

// The output of visibility: depth and triangle id per pixel, row-major (H, W).
// Design decision: two separate planes rather than one packed 64-bit key.
// Good: they are the user's numpy arrays, written in place, no final copy.
// Bad: the depth write touches two cache lines instead of one.
//
// Row y of a plane starts `pitch` pixels after row y - 1 (pitch 0 means
// `width`: contiguous rows). The pixels between a row's end and the next
// row's start are not the planes': the core never writes them.
struct DepthTarget {
  float* depth = nullptr;        // +inf where nothing was drawn
  int32_t* triangle_id = nullptr;  // -1 where nothing was drawn
  int width = 0;
  int height = 0;
  int pitch = 0;  // pixels from a row's start to the next row's, >= width; 0: width

  size_t row_pitch() const { return size_t(pitch ? pitch : width); }
  // How many pixels from the planes' start a vector may load and store back
  // whole, across the end of a row (AVX2 builds, whose masked stores are
  // slow): every pixel when the rows are contiguous, none when padded.
  size_t whole_pixels() const {
    return row_pitch() == size_t(width) ? size_t(width) * size_t(height) : 0;
  }
};

// Calls run(offset, count) for the pixels of a width x height plane whose
// rows start `pitch` pixels apart, as stretches of consecutive pixels: the
// whole plane at once when its rows are contiguous, else row by row (the
// padding between rows is not the plane's). For passes over every pixel:
// clearing, scanning the ids.
template <class Run>
void for_each_run(size_t width, size_t height, size_t pitch, Run&& run) {
  if (pitch == width) {
    run(size_t(0), width * height);
    return;
  }
  for (size_t y = 0; y < height; ++y) run(y * pitch, width);
}

// The pitch of the planes the core allocates itself (the Python binding)
// for an image `width` pixels wide: `width`, or 16 pixels (64 bytes) more
// where rows `width` pixels apart would fall 4 KiB apart within one or two
// rows -- widths that are multiples of 512 from 1024 up. There a column's
// pixels in consecutive rows share an L1 cache set and every load of a row
// 4K-aliases the stores of the row above it. Padded rows drew bunny_69k
// 13% faster at 1024 x 1024 and 37% at 2048 x 2048 (benchmarks/ab.py), 17%
// at 1536 and 13% at 2560 (the same frame drawn into wider planes); 512,
// 640, 768 and 1280 gained 0-3% (benchmarks/README.md).
inline int padded_pitch(int width) {
  return width >= 1024 && width % 512 == 0 ? width + 16 : width;
}

// Where an id plane goes beside the depth plane at address `depth`: the
// first address at or after `from` that lies 2 KiB past `depth` modulo
// 4 KiB, so that a pixel's id and its depth never share an L1 cache set
// (algorithms.h, planes_share_cache_sets). For the planes the binding
// allocates and the scratch plane of PlacedIds.
inline uintptr_t id_plane_address(uintptr_t depth, uintptr_t from) {
  const uintptr_t want = (depth + 2048) % 4096;
  return from + (want - from % 4096 + 4096) % 4096;
}

// Polygon faces, for the algorithms that draw polygons natively (the
// scanline; see Algorithm::polygons). Polygon p has the vertices
// indices[offsets[p] .. offsets[p + 1]) (at least 3), and its triangulation
// is the next size - 2 faces of the MeshView, in polygon order: the first
// polygon's triangles first. Other algorithms draw those faces.
struct PolygonView {
  const int64_t* offsets = nullptr;  // (n_polygons + 1,), offsets[0] == 0
  const int32_t* indices = nullptr;  // (offsets[n_polygons],) vertex indices
  int64_t n_polygons = 0;            // 0: no polygons, draw the faces
};

// Runs of consecutive faces that share a cell of a coarse grid over the mesh
// (mesh_order.h), so that an algorithm can visit the faces cell by cell,
// nearest cell first: a Z-pyramid then sees the front of a mesh before its
// back and culls what lies behind.
struct FaceCells {
  const int32_t* start = nullptr;   // (n + 1,): cell k holds faces start[k] .. start[k + 1] - 1
  const double* centre = nullptr;   // (n, 3) cell centres, world space
  int64_t n = 0;                    // 0: no cells, faces are visited in order
};

// Everything an algorithm needs to render one frame.
struct RenderInput {
  MeshView mesh;
  FaceCells cells;              // optional: visit the faces cell by cell, near to far
  PolygonView polygons;         // optional: the faces grouped into polygons
  double mvp[16] = {};        // row-major model-view-projection matrix
  bool cull_backfaces = false;  // drop triangles wound clockwise in NDC
  // Non-null: the algorithms with a Z-pyramid count there where it culled.
  CullMap* culls = nullptr;
};

// Counters and timings of one render. Triangle counters follow a triangle
// through the pipeline: every input face is culled_in_nodes (never reached:
// an object-space algorithm culled a tree node holding it), culled_invalid,
// culled_frustum, clipped_away, or handed on (split into clip_pieces if it
// was clipped). Each triangle handed on is culled_backface,
// culled_degenerate, culled_hidden (by a hierarchical algorithm's occlusion
// test) or rasterized:
//   triangles_in - culled_in_nodes - culled_invalid - culled_frustum - clipped
//     + clip_pieces == culled_backface + culled_degenerate + culled_hidden + rasterized
struct RenderStats {
  int64_t triangles_in = 0;        // input faces
  int64_t culled_in_nodes = 0;     // in tree nodes culled whole (hidden or outside)
  int64_t culled_invalid = 0;      // a vertex overflowed in the transform
  int64_t culled_frustum = 0;      // wholly outside one plane of the view volume
  int64_t clipped = 0;             // crossed the near, far or guard-band planes
  int64_t clipped_away = 0;        // ...and nothing of them was left
  int64_t clip_pieces = 0;         // triangles produced by clipping
  int64_t culled_backface = 0;     // pieces wound clockwise in NDC (cull on)
  int64_t culled_degenerate = 0;   // pieces with zero snapped area
  int64_t culled_hidden = 0;       // found hidden by an occlusion test
  int64_t rasterized = 0;          // pieces handed to the raster core
  int64_t pixels_tested = 0;       // pixel centres whose coverage was tested
  int64_t pixels_covered = 0;      // ...that the triangle covered
  int64_t pixels_written = 0;      // ...that won the depth test
  int64_t tiles_skipped = 0;       // 8x8 tiles of drawn triangles found hidden
  int64_t pyramid_cells_updated = 0;  // Z-pyramid cells recomputed
  // The scanline algorithm's tables and lists (zero for the others). Means
  // of the active lists are their sums over scanline_rows rows.
  int64_t polygons_inserted = 0;   // entries of the polygon table
  int64_t edges_inserted = 0;      // entries of the edge table
  int64_t scanline_rows = 0;       // rows walked
  int64_t active_polygons_max = 0;
  int64_t active_polygons_sum = 0;
  int64_t active_edges_max = 0;
  int64_t active_edges_sum = 0;
  int64_t spans_drawn = 0;         // non-empty spans handed to the raster core
  // Bytes of depth values the algorithm keeps while it works (the full
  // W x H buffer for image-space algorithms, one row for the scanline).
  int64_t depth_storage_bytes = 0;
  int64_t nodes_visited = 0;       // tree nodes tested (or not testable) and kept
  int64_t nodes_hidden = 0;        // tree nodes culled by the Z-pyramid
  int64_t nodes_outside = 0;       // tree nodes culled as outside the view volume
  double build_ms = 0.0;           // building an object-space tree
  double traversal_ms = 0.0;       // visiting and testing tree nodes
  double vertex_ms = 0.0;          // per-vertex transform and snapping
  double raster_ms = 0.0;          // assembly, clipping, setup, rasterization
  double pyramid_ms = 0.0;         // Z-pyramid upkeep (part of raster_ms)
  double total_ms = 0.0;           // the whole C++ render call: Python's stats["render_ms"]
                                   // (its "total_ms" adds shading and Python; benchmarks/ab
                                   // builds old trees with this name)
};

}  // namespace zbuffer
