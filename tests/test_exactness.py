"""Every registered algorithm equals the numpy reference, bit for bit."""

import numpy as np
import pytest

import zbuffer
from zbuffer.scene import OCTREE_RULES
from helpers import (ALGORITHMS, TRIANGLE_COUNTERS, assert_same_counters,
                      assert_same_visibility, counters_add_up)

SCENES = ["default", "boxes", "interpenetrating", "coplanar", "fan", "soup", "square"]


def cameras(mesh, aspect):
    yield "persp", zbuffer.Camera.fit(mesh, direction=(0.3, 0.4, 1.0), aspect=aspect)
    yield "ortho", zbuffer.Camera.fit(mesh, direction=(-0.5, 0.2, 1.0), aspect=aspect,
                                      projection="orthographic")
    # Close up: big triangles, some leaving the image.
    c, r = mesh.bounding_sphere
    yield "close", zbuffer.Camera.look_at(c + np.array([0.2, 0.3, 1.1]) * r, c, fov_y=70)


@pytest.mark.parametrize("algo", ALGORITHMS)
@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("cull", [False, True], ids=["cull_off", "cull_on"])
def test_algorithm_equals_reference(procedural_scenes, algo, scene, cull):
    mesh = procedural_scenes[scene]
    width, height = 96, 72
    for name, cam in cameras(mesh, width / height):
        res = zbuffer.render(mesh, algo=algo, camera=cam, width=width, height=height,
                             cull_backfaces=cull, shading="none")
        ref = zbuffer.reference.render(mesh, camera=cam, width=width, height=height,
                                       cull_backfaces=cull, shading="none")
        assert_same_visibility(res, ref)
        assert res.mask.any(), f"{scene}/{name} drew nothing: the test would prove nothing"
        assert_same_counters(res.stats, ref.stats)


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_large_triangles_equal_reference(procedural_scenes, algo):
    # Boxes 64 pixels wide or more, and triangles reaching far outside the
    # image, are drawn by exact spans (docs/rasterization.md, 3.6).
    width, height = 320, 240
    for scene in ("boxes", "interpenetrating", "coplanar"):
        mesh = procedural_scenes[scene]
        for name, cam in cameras(mesh, width / height):
            res = zbuffer.render(mesh, algo=algo, camera=cam, width=width, height=height,
                                 shading="none")
            ref = zbuffer.reference.render(mesh, camera=cam, width=width, height=height,
                                           shading="none")
            assert_same_visibility(res, ref)
            assert_same_counters(res.stats, ref.stats)
            if algo == "zbuffer":  # spans test fewer pixels than the boxes hold
                assert res.stats["pixels_tested"] < ref.stats["pixels_tested"], f"{scene}/{name}"


def test_pixel_counters_match_reference_for_plain_zbuffer(procedural_scenes):
    # The plain Z-buffer tests every pixel of each triangle's box, as the
    # reference counts them, where boxes are under 64 pixels wide and their
    # edge values under 2^30 (all of them in this scene at 120x90); other
    # boxes it walks by exact spans, testing only their covered pixels
    # (docs/rasterization.md, 3.6).
    mesh = procedural_scenes["default"]
    res = zbuffer.render(mesh, algo="zbuffer", width=120, height=90, shading="none")
    ref = zbuffer.reference.render(mesh, width=120, height=90, shading="none")
    assert res.stats["pixels_tested"] == ref.stats["pixels_tested"]
    assert res.stats["pixels_covered"] == ref.stats["pixels_covered"]
    assert 0 < res.stats["pixels_written"] <= res.stats["pixels_covered"]

    res = zbuffer.render(mesh, algo="zbuffer", width=800, height=600, shading="none")
    ref = zbuffer.reference.render(mesh, width=800, height=600, shading="none")
    assert res.stats["pixels_covered"] == ref.stats["pixels_covered"]
    assert res.stats["pixels_covered"] <= res.stats["pixels_tested"] < ref.stats["pixels_tested"]


def test_depth_range_and_empty_pixels(procedural_scenes):
    res = zbuffer.render(procedural_scenes["default"], width=64, height=48, shading="none")
    drawn = res.triangle_id >= 0
    assert drawn.any() and (~drawn).any()
    assert np.all(np.isinf(res.depth[~drawn]))
    assert np.all((res.depth[drawn] >= 0.0) & (res.depth[drawn] <= 1.0))
    assert res.depth.dtype == np.float32 and res.triangle_id.dtype == np.int32
    assert res.triangle_id.max() < len(procedural_scenes["default"].faces)


def test_visiting_cells_partition_the_faces_and_hold_their_centroids():
    mesh = zbuffer.scenes.random_soup(6000, seed=5, scale=0.1)
    visit = mesh.prepare().faces_for_render()
    start, centre = visit.cell_start, visit.cell_centre
    assert start[0] == 0 and start[-1] == len(mesh.faces) and np.all(np.diff(start) > 0)
    assert 8 < len(centre) <= 512 and centre.shape == (len(start) - 1, 3)
    # Each face's centroid lies in its cell: a cube 1/8 of the mesh's side
    # around the centre (up to a grid step of rounding).
    side = (mesh.vertices.max(0) - mesh.vertices.min(0)).max()
    centroid = visit.vertices[visit.faces].mean(axis=1)
    cell = np.repeat(np.arange(len(centre)), np.diff(start))
    assert np.all(np.abs(centroid - centre[cell]) <= side / 16 + 2 * side / 1024)


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_cache_friendly_visiting_order_changes_no_bit(algo):
    # Large meshes are visited in a spatial order from their second render
    # on (Mesh.prepare); depth and ids must not change, and still name the
    # caller's faces.
    mesh = zbuffer.scenes.random_soup(6000, seed=4, scale=0.15)
    cam = zbuffer.Camera.fit(mesh, direction=(0.2, 0.3, 1.0), aspect=1.25)
    first = zbuffer.render(mesh, algo=algo, camera=cam, width=100, height=80, shading="none")
    assert mesh._visit is None
    mesh.prepare()
    visit = mesh.faces_for_render()
    faces, ids = visit.faces, visit.ids
    assert ids is not None and not np.array_equal(ids, np.arange(len(ids)))
    assert np.array_equal(np.sort(ids), np.arange(len(ids)))  # a permutation
    # The same triangles, their vertices renumbered in the order of first use.
    assert visit.vertices is not mesh.vertices
    np.testing.assert_array_equal(visit.vertices[faces], mesh.vertices[mesh.faces[ids]])
    _, first_use = np.unique(faces.ravel(), return_index=True)
    np.testing.assert_array_equal(np.argsort(first_use, kind="stable"), np.arange(len(first_use)))
    again = zbuffer.render(mesh, algo=algo, camera=cam, width=100, height=80, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=100, height=80, shading="none")
    assert_same_visibility(first, ref)
    assert_same_visibility(again, ref)
    for key in TRIANGLE_COUNTERS:
        assert again.stats[key] == first.stats[key], key
    # (How many the occlusion tests of triangles and of tree nodes cull
    # depends on the order -- the pyramid a node is tested against is that of
    # the batches before it, which the order makes up; the counters still add
    # up to the triangles in.)
    assert counters_add_up(first.stats) and counters_add_up(again.stats)


def test_first_use_order_is_a_permutation_that_keeps_the_triangles():
    # Unused vertices follow the used ones in their old order; bad faces are
    # refused like everywhere else.
    v = np.arange(18, dtype=np.float64).reshape(6, 3)
    f = np.array([[4, 1, 4], [1, 5, 0]], np.int32)
    faces, order = zbuffer._core.first_use_order(f, len(v))
    np.testing.assert_array_equal(order, [4, 1, 5, 0, 2, 3])
    np.testing.assert_array_equal(faces, [[0, 1, 0], [1, 2, 3]])
    np.testing.assert_array_equal(v[order][faces], v[f])
    with pytest.raises(ValueError, match="outside"):
        zbuffer._core.first_use_order(np.array([[0, 1, 6]], np.int32), len(v))
    with pytest.raises(ValueError, match="n_vertices"):
        zbuffer._core.first_use_order(f, -1)


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_mesh_whose_bounds_round_short_equals_reference(algo):
    # x from -3 to 0.3: -3 + (0.3 - -3) < 0.3, the per-frame trees' vertex
    # grid once left such meshes' last vertices without a cell, and culled
    # their nodes as outside the view (a blank image).
    vertices = np.array([[-3.0, 0, 0], [0.3, 0, 0], [0.3, 1, 0]])
    faces = np.array([[0, 1, 2]])
    cam = zbuffer.Camera.look_at((0.2, 0.5, 2), (0.2, 0.5, 0), fov_y=20)
    res = zbuffer.render((vertices, faces), algo=algo, camera=cam, width=64, height=64,
                         shading="none")
    ref = zbuffer.reference.render((vertices, faces), camera=cam, width=64, height=64,
                                   shading="none")
    assert ref.mask.sum() > 1000
    assert_same_visibility(res, ref)


def _equal_everywhere(mesh, cam, width, height):
    """Every algorithm, per frame and in a Scene (every octree rule, and a
    temporal frame after one from another camera), against the reference."""
    ref = zbuffer.reference.render(mesh, camera=cam, width=width, height=height, shading="none")
    assert ref.mask.any()
    for algo in ALGORITHMS:
        res = zbuffer.render(mesh, algo=algo, camera=cam, width=width, height=height,
                             shading="none")
        assert_same_visibility(res, ref)
    for rule in OCTREE_RULES:
        scene = zbuffer.Scene(mesh, leaf_size=1, octree_rule=rule)
        for algo in ("hiz_octree", "hiz_bvh"):
            for temporal in (False, True):
                res = scene.render(cam, algo=algo, width=width, height=height, shading="none",
                                   temporal=temporal)
                assert_same_visibility(res, ref)


@pytest.mark.parametrize("case", ["extent overflows", "extent underflows"])
def test_meshes_without_a_usable_vertex_grid_equal_reference(case):
    # The per-frame trees' vertex grid has no cells to speak of when the
    # vertices' extent overflows (far unused vertices) or 1024 / extent does:
    # its boxes must then be unbounded, not collapsed onto a corner.
    if case == "extent overflows":
        vertices = [[-1, -1, 0], [1, -1, 0], [0, 1, 0], [-9e307, 0, 0], [9e307, 0, 0]]
        cam = zbuffer.Camera.look_at((0, 0, 5), (0, 0, 0), near=0.1, far=100)
    else:
        s = 1e-306
        vertices = [[-3 * s, -3 * s, 0], [s, -s, 0], [0, s, 0]]
        cam = zbuffer.Camera.look_at((0, 0, 5), (0, 0, 0), near=0.1, far=100,
                                     projection="orthographic", ortho_height=2 * s)
    mesh = zbuffer.Mesh(np.array(vertices, float), np.array([[0, 1, 2]]))
    _equal_everywhere(mesh, cam, 64, 48)


def test_large_world_coordinates_seen_from_close_by_equal_reference():
    # At 1e8 from the origin, seen from 0.013 away, the transform's rounding
    # (its translation cancels most of the products) exceeds a fixed depth
    # margin: a tree node's box computed farther than a vertex inside it, and
    # was culled behind a coplanar square the triangle wins on its id.
    o, d, near = 1e8, 0.01289504628799809, 0.0006078342736311142
    direction = np.array([7.448270749902667e-06, 1.3239481828362716e-06, -1.0])
    eye = np.array([o, o, o + d])
    cam = zbuffer.Camera.look_at(tuple(eye), tuple(eye + direction * d), near=near, far=d * 10)
    tri = [[100000000.0012949, 99999999.99870346, o], [100000000.0040879, 99999999.99831153, o],
           [100000000.0029279, 99999999.99943565, o]]
    r = 0.13
    square = [[o - r, o - r, o], [o + r, o - r, o], [o + r, o + r, o], [o - r, o + r, o]]
    faces = [[0, 1, 2]] + [[3, 4, 5], [3, 5, 6]] * 130  # enough to flush a batch
    mesh = zbuffer.Mesh(np.array(tri + square), np.array(faces))
    _equal_everywhere(mesh, cam, 32, 32)
