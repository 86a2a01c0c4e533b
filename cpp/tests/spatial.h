// A test mesh's faces passed in spatial order (mesh_order.h), as
// Mesh.prepare passes them: reordered, with their input indices as ids, the
// coarse cells of that order, and the vertices renumbered in the order those
// faces first use them.
#pragma once

#include <cstdint>
#include <vector>

#include "zbuffer/mesh_order.h"
#include "zbuffer/types.h"

struct SpatialMesh {
  zbuffer::MeshView base;
  std::vector<int32_t> order;  // row k is input face order[k]
  std::vector<int32_t> faces, cell_start;
  std::vector<double> cell_centre;
  std::vector<double> positions;  // base's, renumbered (first_use_order)

  explicit SpatialMesh(const zbuffer::MeshView& mesh) : base(mesh), order(size_t(mesh.n_faces)) {
    zbuffer::spatial_order(base, order.data(), cell_start, cell_centre);
    relist();
  }
  // Lists the faces in `order` again (after a test rearranged it).
  void relist() {
    faces.clear();
    for (const int32_t f : order)
      for (int k = 0; k < 3; ++k) faces.push_back(base.faces[3 * int64_t(f) + k]);
    std::vector<int32_t> old_of_new(size_t(base.n_vertices));
    zbuffer::first_use_order(faces.data(), base.n_faces, base.n_vertices, faces.data(),
                             old_of_new.data());
    positions.resize(3 * size_t(base.n_vertices));
    for (size_t v = 0; v < old_of_new.size(); ++v)
      for (int a = 0; a < 3; ++a) positions[3 * v + a] = base.positions[3 * int64_t(old_of_new[v]) + a];
  }
  zbuffer::MeshView view() const {
    zbuffer::MeshView v = base;
    v.positions = positions.data();
    v.faces = faces.data();
    v.face_ids = order.data();
    return v;
  }
  zbuffer::FaceCells cells() const {
    return {cell_start.data(), cell_centre.data(), int64_t(cell_centre.size() / 3)};
  }
};
