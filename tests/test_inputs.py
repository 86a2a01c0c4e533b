"""Every accepted mesh type renders the same; files load in every format."""

import numpy as np
import pytest
import trimesh

import zbuffer
from zbuffer import scenes


def test_all_input_types_give_the_same_result(tmp_path):
    v, f = scenes.torus()
    v = np.round(v * 64) / 64  # exact in float32 PLY and in OBJ's decimal text
    cam = zbuffer.Camera.look_at((0.5, 2, 3), (0, 0, 0))
    expected = zbuffer.render((v, f), camera=cam, width=48, height=40, shading="none")
    path = tmp_path / "torus.ply"
    trimesh.Trimesh(v, f, process=False).export(path)
    inputs = {
        "Mesh": zbuffer.Mesh(v, f),
        "tuple": (v, f),
        "lists": (v.tolist(), f.tolist()),
        "float32": (v.astype(np.float32).astype(np.float64), f.astype(np.uint16)),
        "Trimesh": trimesh.Trimesh(v, f, process=False),
        "Scene": trimesh.Scene([trimesh.Trimesh(v, f, process=False)]),
        "path": str(path),
        "Path": path,
    }
    for name, mesh in inputs.items():
        res = zbuffer.render(mesh, camera=cam, width=48, height=40, shading="none")
        np.testing.assert_array_equal(res.triangle_id, expected.triangle_id, err_msg=name)
        np.testing.assert_array_equal(res.depth, expected.depth, err_msg=name)


def test_pyvista_polydata_is_triangulated():
    pv = pytest.importorskip("pyvista")
    cube = pv.Cube()  # six quads
    res = zbuffer.render(cube, width=32, height=32, shading="none")
    assert res.stats["triangles_in"] == 12
    assert res.mask.any()
    pts = pv.PolyData(np.random.default_rng(0).uniform(size=(5, 3)))  # no faces
    assert not zbuffer.render(pts, width=8, height=8, shading="none").mask.any()
    # Polygons of mixed sizes (a triangle beside a concave pentagon): their
    # triangulation, which covers what the polygons do.
    points = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [1, 0.5, 0], [0, 2, 0], [3, 0, 0]], float)
    mixed = pv.PolyData(points, faces=[5, 0, 1, 2, 3, 4, 3, 1, 5, 2])
    cam = zbuffer.Camera.look_at((1.5, 1, 5), (1.5, 1, 0), fov_y=50)
    res = zbuffer.render(mixed, camera=cam, width=48, height=32, shading="none")
    ref = zbuffer.render(zbuffer.Mesh(points, [[0, 1, 3], [1, 2, 3], [3, 4, 0], [1, 5, 2]]),
                         camera=cam, width=48, height=32, shading="none")
    assert res.stats["triangles_in"] == 4
    np.testing.assert_array_equal(res.mask, ref.mask)


def test_other_pyvista_datasets_render_their_outer_surface():
    pv = pytest.importorskip("pyvista")
    sphere = pv.Sphere(theta_resolution=16, phi_resolution=12)
    grid = sphere.cast_to_unstructured_grid()
    cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0))
    a = zbuffer.render(sphere, camera=cam, width=48, height=40, shading="none")
    b = zbuffer.render(grid, camera=cam, width=48, height=40, shading="none")
    np.testing.assert_array_equal(a.depth, b.depth)
    box = zbuffer.render(pv.ImageData(dimensions=(3, 3, 3)), camera=cam, width=48, height=40,
                         shading="none")
    assert box.mask.any()


def test_pyvista_colours_are_kept():
    # Active uint8 RGB(A) scalars are colours (per point: vertex colours, per
    # cell: face colours); other scalars are data.
    pv = pytest.importorskip("pyvista")
    sphere = pv.Sphere(theta_resolution=16, phi_resolution=12)
    sphere.point_data["RGB"] = np.tile(np.array([0, 0, 255], np.uint8), (sphere.n_points, 1))
    mesh = zbuffer.as_mesh(sphere)
    np.testing.assert_array_equal(mesh.vertex_colors, np.tile([0, 0, 1], (sphere.n_points, 1)))
    image = zbuffer.render(sphere, width=32, height=32, light_dir=(0, 0, -1)).image
    assert image[16, 16, 2] > 200 and image[16, 16, :2].max() == 0
    sphere.point_data["height"] = sphere.points[:, 2]
    sphere.set_active_scalars("height")  # data, not a colour
    assert zbuffer.as_mesh(sphere).vertex_colors is None
    # Cells: a line and a point come first in a PolyData's cells; a quad is two triangles.
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 2, 0]], float)
    poly = pv.PolyData(points, faces=[3, 0, 1, 2, 4, 1, 3, 4, 2], lines=[2, 0, 4], verts=[1, 3])
    poly.cell_data["RGBA"] = np.array([[9, 9, 9, 255], [9, 9, 9, 255], [255, 0, 0, 255],
                                       [0, 255, 0, 255]], np.uint8)
    mesh = zbuffer.as_mesh(poly)
    assert len(mesh.faces) == 3
    np.testing.assert_array_equal(mesh.face_colors, [[1, 0, 0], [0, 1, 0], [0, 1, 0]])
    # Triangles and a strip: VTK's triangle filter given both loses the
    # triangles' cell data; the strip's triangles come last.
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [3, 0, 0], [3, 1, 0],
                       [4, 0, 0], [4, 1, 0]], float)
    poly = pv.PolyData(points, faces=[3, 0, 1, 2, 3, 1, 3, 2], strips=[4, 4, 5, 6, 7])
    poly.cell_data["RGB"] = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255]], np.uint8)
    mesh = zbuffer.as_mesh(poly)
    np.testing.assert_array_equal(mesh.faces[:2], [[0, 1, 2], [1, 3, 2]])
    np.testing.assert_array_equal(mesh.face_colors, [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1]])


def test_scene_is_concatenated_with_colours():
    a = trimesh.creation.box()
    a.visual.face_colors = [255, 0, 0, 255]
    b = trimesh.creation.icosphere()
    b.apply_translation([3, 0, 0])
    scene = trimesh.Scene([a, b])
    mesh = zbuffer.as_mesh(scene)
    assert len(mesh.faces) == len(a.faces) + len(b.faces)
    # the box's faces red, the sphere's not (their order: the scene's)
    red = (mesh.face_colors == [1, 0, 0]).all(axis=1)
    assert red.sum() == len(a.faces)
    assert red[:len(a.faces)].all() or red[-len(a.faces):].all()


def test_trimesh_vertex_colours_are_kept():
    s = trimesh.creation.icosphere(subdivisions=2)
    s.visual.vertex_colors = np.tile([0, 255, 0, 255], (len(s.vertices), 1))
    np.testing.assert_array_equal(zbuffer.as_mesh(s).vertex_colors,
                                  np.tile([0, 1, 0], (len(s.vertices), 1)))
    image = zbuffer.render(s, width=32, height=32, ambient=1.0, diffuse=0.0).image
    assert (image[16, 16] == [0, 255, 0]).all()


def test_merged_keeps_vertices_that_differ_in_colour():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0], [1, 0, 0], [0, -1, 0]], float)
    f = np.array([[0, 1, 2], [3, 5, 4]])
    colours = np.array([[1, 0, 0]] * 3 + [[0, 0, 1]] * 3, np.float32)
    merged = zbuffer.Mesh(v, f, vertex_colors=colours).merged()
    assert len(merged.vertices) == 6
    np.testing.assert_array_equal(merged.vertex_colors[merged.faces], colours[f])
    assert len(zbuffer.Mesh(v, f).merged().vertices) == 4


def test_load_merges_repeated_positions_except_in_obj_files(tmp_path):
    # (An OBJ file's v records stay its vertices; other formats' corners
    # are shared -- a speed matter, and the same triangles either way.)
    v, f = scenes.box()
    split = v[f].reshape(-1, 3)
    faces = np.arange(len(split)).reshape(-1, 3)
    for ext in ("ply", "off", "stl", "obj"):
        path = tmp_path / f"b.{ext}"
        trimesh.Trimesh(split, faces, process=False).export(path)
        if ext == "obj":  # (by hand: a v record for every corner)
            path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in split)
                            + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))
        merged = zbuffer.load(path)
        kept = zbuffer.load(path, merge_vertices=False)
        assert len(kept.vertices) == 36
        assert len(merged.vertices) == (36 if ext == "obj" else 8), ext
        np.testing.assert_array_equal(merged.vertices[merged.faces], kept.vertices[kept.faces])


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "off", "glb"])
def test_load_round_trips_through_formats(tmp_path, ext):
    v, f = scenes.box((0.5, 0, 0), (1, 2, 3))
    path = tmp_path / f"box.{ext}"
    trimesh.Trimesh(v, f, process=False).export(path)
    mesh = zbuffer.load(path)
    cam = zbuffer.Camera.look_at((2, 3, 4), (0.5, 0, 0))
    a = zbuffer.render(mesh, camera=cam, width=40, height=30, shading="none")
    b = zbuffer.render((v, f), camera=cam, width=40, height=30, shading="none")
    np.testing.assert_array_equal(a.depth, b.depth)
    assert len(mesh.faces) == 12


def test_merging_vertices_keeps_face_order_and_ids():
    v, f = scenes.box()
    split = v[f].reshape(-1, 3)  # every corner its own vertex
    unmerged = zbuffer.Mesh(split, np.arange(len(split)).reshape(-1, 3))
    merged = unmerged.merged()
    assert len(merged.vertices) == 8
    np.testing.assert_array_equal(merged.vertices[merged.faces], unmerged.vertices[unmerged.faces])


def test_mesh_arrays_are_read_only_and_faces_private():
    v, f = scenes.box()
    f = f.astype(np.int32)
    mesh = zbuffer.Mesh(v, f)
    assert np.shares_memory(mesh.vertices, v)  # no needless copy of positions
    # Faces are the core's indices, read without the GIL: the mesh owns them.
    assert not np.shares_memory(mesh.faces, f)
    f[0, 0] = 10**6
    assert mesh.faces[0, 0] != 10**6
    with pytest.raises(ValueError):
        mesh.vertices[0, 0] = 1.0
    with pytest.raises(ValueError):
        mesh.faces[0, 0] = 1


def test_vertex_normals_point_outwards():
    v, f = scenes.uv_sphere(radius=2.0)
    mesh = zbuffer.Mesh(v, f)
    np.testing.assert_allclose(np.linalg.norm(mesh.vertex_normals, axis=1), 1.0)
    assert (np.einsum("ij,ij->i", mesh.vertex_normals, v) > 0).all()


def test_pickled_meshes_and_arrays_render():
    # Unpickled arrays carry dtype objects of their own (equal to float64 and
    # int32, not the same objects): the core takes them, and refuses a
    # byte-swapped float64 with a message.
    import pickle

    mesh = scenes.instance_grid(scenes.default_scene(), (2, 2, 2)).prepare()
    cam = zbuffer.Camera.fit(mesh)
    ref = zbuffer.render(mesh, camera=cam, width=40, height=30, shading="smooth")
    copy = pickle.loads(pickle.dumps(mesh))
    assert copy.vertices.dtype is not np.dtype(np.float64)
    for algo in zbuffer.algorithms():
        res = zbuffer.render(copy, algo, cam, 40, 30, shading="smooth")
        np.testing.assert_array_equal(res.triangle_id, ref.triangle_id)
        np.testing.assert_array_equal(res.image, ref.image)
    depth, ids = pickle.loads(pickle.dumps((np.empty((30, 40), np.float32),
                                            np.empty((30, 40), np.int32))))
    res = zbuffer.render(copy, camera=cam, width=40, height=30, out=(depth, ids))
    assert res.depth is depth
    np.testing.assert_array_equal(ids, ref.triangle_id)
    from zbuffer import _core
    with pytest.raises(TypeError, match="positions must have dtype float64"):
        _core.render(mesh.vertices.astype(">f8"), mesh.faces, np.eye(4), 8, 8)


def test_a_results_repr_is_one_line_not_its_arrays():
    res = zbuffer.render(scenes.default_scene(), algo="hiz", width=40, height=30,
                         shading="none", record_culls=True)
    text = repr(res)
    drawn = int((res.triangle_id >= 0).sum())
    assert text.startswith(f"<RenderResult 'hiz' 40x30, no image: {drawn:,} pixels drawn, ")
    assert text.endswith(", culls recorded>") and "\n" not in text and "array" not in text


@pytest.mark.parametrize("seed", range(6))
def test_unique_rows_is_numpys_unique_of_rows(seed):
    # Mesh.merged's _unique_rows: np.unique(axis=0)'s three arrays, bit for
    # bit, on rows with many repeats, rows equal but for a column, signed
    # zeros (-0.0 equals 0.0: the first occurrence is kept) and extra
    # (colour) columns.
    from zbuffer.mesh import _unique_rows as unique_rows

    rng = np.random.default_rng(seed)
    n, k = [(1, 3), (50, 3), (5000, 3), (5000, 6), (3000, 1), (4000, 3)][seed]
    key = rng.integers(-2, 3, size=(n, k)).astype(np.float64) * rng.choice([0.5, 1e-300, 1e300])
    key[rng.random((n, k)) < 0.2] *= -1.0  # -0.0 where a zero is negated
    key[rng.random(n) < 0.3] = rng.normal(size=k)
    expected = np.unique(key, axis=0, return_index=True, return_inverse=True)
    got = unique_rows(key)
    for e, g in zip(expected, got):
        np.testing.assert_array_equal(g, e.reshape(g.shape))
        assert g.dtype == e.dtype
    # the first occurrence's bits, signed zeros included
    np.testing.assert_array_equal(np.signbit(got[0]), np.signbit(expected[0]))
