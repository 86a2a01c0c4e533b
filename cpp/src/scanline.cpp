// The scanline Z-buffer (scanline.h): sorted polygon and edge tables, an
// active polygon list and an active edge list, one row of depth.
#include "zbuffer/scanline.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <limits>

#include "zbuffer/algorithms.h"

namespace zbuffer {

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
      .count();
}

// floor(n / d) for d > 0 (C++ division truncates towards zero).
inline int64_t floor_div(int64_t n, int64_t d) {
  const int64_t q = n / d;
  return q - ((n % d != 0) & (n < 0));
}

// Stable counting sort of `n` items by row: fills start[0 .. height] with
// bucket offsets and returns each item's position in the sorted order.
void bucket_by_row(const std::vector<int32_t>& row, int height, std::vector<int32_t>& start,
                   std::vector<int32_t>& position) {
  start.assign(size_t(height) + 1, 0);
  for (int32_t y : row) ++start[size_t(y) + 1];
  for (int y = 0; y < height; ++y) start[size_t(y) + 1] += start[size_t(y)];
  position.resize(row.size());
  std::vector<int32_t> next(start.begin(), start.end() - 1);
  for (size_t i = 0; i < row.size(); ++i) position[i] = next[size_t(row[i])]++;
}

}  // namespace

void ScanlineTables::reset(int width, int height) {
  width_ = width;
  height_ = height;
  polys_.clear();
  poly_row_.clear();
  edges_.clear();
  edge_row_.clear();
}

// Edge Table Entries

void ScanlineTables::add_edge(const TriangleSetup& s, int k, int64_t ya, int64_t yb,
                              int32_t poly, RenderStats& stats) {
  // Rows whose centres lie on the edge's closed y range, within the box.
  // On such a row the edge and the triangle's other edges spanning the row
  // give the span exactly; an edge not spanning the row could only cut it
  // where the row leaves the closed triangle, which its spanning edges
  // already do (the edge value of a non-spanning edge is > 0 on the span).
  const int64_t first = std::max<int64_t>(first_pixel_at_or_after(std::min(ya, yb)), s.y_min);
  const int64_t last = std::min<int64_t>(last_pixel_at_or_before(std::max(ya, yb)), s.y_max);
  if (first > last) return;
  ScanEdge e;
  e.poly = poly;
  e.last_row = int32_t(last);
  if (s.step_x[k] == 0) {
    // Horizontal, and exactly on a row of pixel centres: a top edge (bias 0)
    // admits the whole row, a bottom edge (bias 1, edge value 0 there)
    // none of it. Only the latter needs an entry: a left bound beyond any
    // column, for this one row.
    if (s.bias[k] == 0) return;
    e.lower = true;
    e.q = int64_t(1) << 40;
    e.r = e.dq = e.dr = 0;
    e.div = 1;
  } else {
    // Biased edge value at the centre of pixel (0, first).
    const int64_t w0 = s.w_origin[k] + (0 - int64_t(s.x_min)) * s.step_x[k] +
                       (first - s.y_min) * s.step_y[k];
    int64_t n, dn;
    e.lower = s.step_x[k] > 0;
    if (e.lower) {
      // w0 + step_x * x >= 0  <=>  x >= ceil(-w0 / step_x)
      //                       =    floor((-w0 + step_x - 1) / step_x)
      e.div = s.step_x[k];
      n = -w0 + e.div - 1;
      dn = -s.step_y[k];
    } else {
      // w0 - div * x >= 0  <=>  x <= floor(w0 / div)
      e.div = -s.step_x[k];
      n = w0;
      dn = s.step_y[k];
    }
    e.q = floor_div(n, e.div);
    e.r = n - e.q * e.div;
    e.dq = floor_div(dn, e.div);
    e.dr = dn - e.dq * e.div;
  }
  edges_.push_back(e);
  edge_row_.push_back(int32_t(first));
  ++stats.edges_inserted;
}

// Polygon Table Entries

void ScanlineTables::add_triangle(const ScreenTriangle& t, RenderStats& stats) {
  const TriangleSetup s = setup_triangle(t, width_, height_);
  if (s.x_min > s.x_max || s.y_min > s.y_max) return;  // no pixel centre of the image
  const int32_t poly = int32_t(polys_.size());
  polys_.push_back(s);
  poly_row_.push_back(s.y_min);
  ++stats.polygons_inserted;
  for (int k = 0; k < 3; ++k)
    add_edge(s, k, t.v[(k + 1) % 3].y_fx, t.v[(k + 2) % 3].y_fx, poly, stats);
}

// The Row Walk

void ScanlineTables::render(DepthTarget& target, RenderStats& stats) {
  const int width = target.width, height = target.height;

  // Sorted Polygon Table and Edge Table
  std::vector<int32_t> position;
  bucket_by_row(poly_row_, height, poly_start_, position);
  poly_table_.resize(polys_.size());
  for (size_t i = 0; i < polys_.size(); ++i) poly_table_[size_t(position[i])] = int32_t(i);
  bucket_by_row(edge_row_, height, edge_start_, position);
  edge_table_.resize(edges_.size());
  for (size_t i = 0; i < edges_.size(); ++i) edge_table_[size_t(position[i])] = edges_[i];

  span_lo_.resize(polys_.size());
  span_hi_.resize(polys_.size());
  active_polys_.clear();
  active_edges_.clear();
  depth_row_.assign(size_t(width), std::numeric_limits<float>::infinity());
  id_row_.assign(size_t(width), -1);
  stats.depth_storage_bytes = int64_t(width) * int64_t(sizeof(float));

  for (int y = 0; y < height; ++y) {
    // Polygons and edges entering at this row
    for (int32_t i = poly_start_[size_t(y)]; i < poly_start_[size_t(y) + 1]; ++i) {
      const int32_t p = poly_table_[size_t(i)];
      active_polys_.push_back(p);
      span_lo_[size_t(p)] = polys_[size_t(p)].x_min;
      span_hi_[size_t(p)] = polys_[size_t(p)].x_max;
    }
    active_edges_.insert(active_edges_.end(), edge_table_.begin() + edge_start_[size_t(y)],
                         edge_table_.begin() + edge_start_[size_t(y) + 1]);
    ++stats.scanline_rows;
    stats.active_polygons_sum += int64_t(active_polys_.size());
    stats.active_edges_sum += int64_t(active_edges_.size());
    stats.active_polygons_max = std::max(stats.active_polygons_max, int64_t(active_polys_.size()));
    stats.active_edges_max = std::max(stats.active_edges_max, int64_t(active_edges_.size()));
    if (active_polys_.empty()) continue;

    // Active edges: narrow their polygons' spans, step to the next row,
    // drop those that end here
    size_t kept = 0;
    for (size_t i = 0; i < active_edges_.size(); ++i) {
      ScanEdge e = active_edges_[i];
      if (e.lower) {
        if (e.q > span_lo_[size_t(e.poly)])
          span_lo_[size_t(e.poly)] = int32_t(std::min<int64_t>(e.q, width));
      } else {
        if (e.q < span_hi_[size_t(e.poly)])
          span_hi_[size_t(e.poly)] = int32_t(std::max<int64_t>(e.q, -1));
      }
      if (e.last_row == y) continue;
      e.step();
      active_edges_[kept++] = e;
    }
    active_edges_.resize(kept);

    // Active polygons: draw their spans into the row, drop those that end here
    int touched_lo = width, touched_hi = -1;
    kept = 0;
    for (size_t i = 0; i < active_polys_.size(); ++i) {
      const int32_t p = active_polys_[i];
      const TriangleSetup& s = polys_[size_t(p)];
      const int lo = span_lo_[size_t(p)], hi = span_hi_[size_t(p)];
      if (lo <= hi) {
        rasterize_span(s, y, lo, hi, depth_row_.data(), id_row_.data(), stats);
        ++stats.spans_drawn;
        touched_lo = std::min(touched_lo, lo);
        touched_hi = std::max(touched_hi, hi);
      }
      if (s.y_max == y) continue;
      span_lo_[size_t(p)] = s.x_min;
      span_hi_[size_t(p)] = s.x_max;
      active_polys_[kept++] = p;
    }
    active_polys_.resize(kept);

    // The finished row into the image; the row buffer cleared behind it
    if (touched_lo <= touched_hi) {
      const size_t n = size_t(touched_hi - touched_lo + 1);
      const size_t base = size_t(y) * size_t(width) + size_t(touched_lo);
      std::memcpy(target.depth + base, depth_row_.data() + touched_lo, n * sizeof(float));
      std::memcpy(target.triangle_id + base, id_row_.data() + touched_lo, n * sizeof(int32_t));
      std::fill_n(depth_row_.data() + touched_lo, n, std::numeric_limits<float>::infinity());
      std::fill_n(id_row_.data() + touched_lo, n, int32_t(-1));
    }
  }
}

// The Algorithm

void render_scanline(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  const Viewport vp(target.width, target.height);

  // Vertex stage: shared with every algorithm, each vertex once.
  auto t0 = std::chrono::steady_clock::now();
  thread_local ScreenVertices screen;
  transform_vertices(input.mesh, input.mvp, vp, screen);
  stats.vertex_ms += ms_since(t0);

  // Assembly into the tables, then the row walk.
  t0 = std::chrono::steady_clock::now();
  thread_local ScanlineTables tables;
  tables.reset(target.width, target.height);
  for (int64_t f = 0; f < input.mesh.n_faces; ++f)
    assemble_triangle(input.mesh, input.mvp, vp, screen, f, input.cull_backfaces, stats,
                      [&](const ScreenTriangle& t) {
                        ++stats.rasterized;
                        tables.add_triangle(t, stats);
                      });
  tables.render(target, stats);
  stats.raster_ms += ms_since(t0);
}

}  // namespace zbuffer
