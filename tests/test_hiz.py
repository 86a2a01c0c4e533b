"""The hierarchical Z-buffer: the Z-pyramid, and occlusion culling that
changes no bit of the output."""

import numpy as np
import pytest

import zbuffer
from zbuffer import scenes
from helpers import PYRAMID_ALGORITHMS, assert_same_counters, assert_same_visibility

HIERARCHICAL = PYRAMID_ALGORITHMS


N_HIDDEN, N_FRONT = 1500, 30
BATCH = 512  # triangles drawn together; the pyramid lags by at most one batch


def occluded_scene(seed=0, n_hidden=N_HIDDEN, n_front=N_FRONT, spread=0.15):
    """A big wall listed first, then many triangles well behind it, then a
    few in front of it (corners `spread` from their centres)."""
    wall_v, wall_f = scenes.grid((0.0, 0.0, 0.0), (3.0, 2.0), (6, 4))
    wall_v = wall_v[:, [0, 2, 1]]  # the grid lies in xz; stand it up facing +z
    wall_v[:, 2] = 1.0
    rng = np.random.default_rng(seed)
    behind = rng.uniform([-0.9, -0.5, -3.0], [0.9, 0.5, 0.3], (n_hidden, 1, 3))
    front = rng.uniform([-1.0, -0.6, 1.5], [1.0, 0.6, 2.0], (n_front, 1, 3))
    centres = np.concatenate([behind, front])
    soup = (centres + rng.normal(0, spread, (len(centres), 3, 3))).reshape(-1, 3)
    v = np.vstack([wall_v, soup])
    f = np.vstack([wall_f, len(wall_v) + np.arange(len(soup)).reshape(-1, 3)])
    return zbuffer.Mesh(v, f)


@pytest.mark.parametrize("algo", HIERARCHICAL)
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_occluded_triangles_are_culled_and_no_bit_changes(algo, projection):
    mesh = occluded_scene()
    cam = zbuffer.Camera.look_at((0.2, 0.1, 6.0), (0, 0, 0), fov_y=40, projection=projection,
                                 ortho_height=3.5, near=1.0, far=20.0)
    res = zbuffer.render(mesh, algo=algo, camera=cam, width=160, height=120, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=160, height=120, shading="none")
    plain = zbuffer.render(mesh, algo="zbuffer", camera=cam, width=160, height=120,
                           shading="none")
    assert_same_visibility(res, ref)
    assert_same_counters(res.stats, ref.stats)
    # The wall hides the triangles behind it: once the wall's batch is drawn
    # the triangle test culls most of them (not those sharing its batch, nor
    # those whose box touches an 8x8 cell reaching past the wall's edge) and
    # none of those in front; fewer pixels are tested than by the plain
    # Z-buffer.
    # (Tree algorithms cull most of them with their nodes instead.)
    culled = res.stats["culled_hidden"] + res.stats["culled_in_nodes"]
    assert 0.5 * (N_HIDDEN - BATCH) <= culled <= N_HIDDEN
    front_ids = np.arange(len(mesh.faces) - N_FRONT, len(mesh.faces))
    assert np.isin(front_ids, res.triangle_id).sum() > N_FRONT // 2
    assert res.stats["pixels_tested"] < plain.stats["pixels_tested"]
    assert res.stats["pyramid_cells_updated"] > 0


def test_a_prepared_mesh_is_drawn_front_first_so_its_back_is_culled():
    # A closed sphere's far half is hidden by its near half. Visited cell by
    # cell, nearest first (Mesh.prepare), hiz culls most of the far half
    # before setting it up; the plain Z-buffer's output is the same.
    mesh = zbuffer.Mesh(*scenes.uv_sphere(n_lat=48, n_lon=96))
    cam = zbuffer.Camera.look_at((0.3, 0.4, 3.0), (0, 0, 0), fov_y=40)
    mesh.prepare()
    res = zbuffer.render(mesh, algo="hiz", camera=cam, width=160, height=120, shading="none")
    ref = zbuffer.render(mesh, algo="zbuffer", camera=cam, width=160, height=120, shading="none")
    assert_same_visibility(res, ref)
    assert res.stats["culled_hidden"] > 0.3 * len(mesh.faces)


def test_a_triangle_touching_the_pyramids_depth_is_not_culled():
    # Strictly farther, or drawn: a wall of 3,200 triangles at depth 0.5
    # (identity MVP) is drawn first -- more than a batch, so the pyramid
    # holds it -- then T, whose nearest depth is the wall's exactly (its top
    # edge lies in the wall, 20 pixel centres on it) and whose id, 0, wins
    # those ties; then U, wholly behind the wall. A test culling at equal
    # depths would cull T (and lose its 20 pixels) as it culls U.
    from zbuffer import _core, reference

    size, n = 64, 40
    xs = np.linspace(-1, 1, n + 1)
    gx, gy = np.meshgrid(xs, xs)
    wall_v = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1)
    at = lambda i, j: i * (n + 1) + j  # noqa: E731
    wall_f = np.array([f for i in range(n) for j in range(n)
                       for f in ([at(i, j), at(i, j + 1), at(i + 1, j + 1)],
                                 [at(i, j), at(i + 1, j + 1), at(i + 1, j)])])
    ndc = lambda px, py, z: [px / (size / 2) - 1, 1 - py / (size / 2), z]  # noqa: E731
    t = [ndc(10.5, 20.5, 0.0), ndc(30.5, 20.5, 0.0), ndc(20.5, 40.5, 0.5)]
    u = [ndc(40.5, 40.5, 0.2), ndc(50.5, 40.5, 0.2), ndc(45.5, 50.5, 0.3)]
    v = np.vstack([wall_v, t, u])
    k = len(wall_v)
    faces = np.vstack([wall_f, [[k, k + 1, k + 2], [k + 3, k + 4, k + 5]]]).astype(np.int32)
    ids = np.concatenate([np.arange(2, len(wall_f) + 2), [0, 1]]).astype(np.int32)  # visit order
    by_id = faces[np.argsort(ids)]
    tris, _ = reference.vertex_stage(v, by_id, np.eye(4), size, size, False)
    ref_depth, ref_ids, _ = reference.rasterize(tris, size, size)
    assert (ref_ids == 0).sum() == 20 and not (ref_ids == 1).any()
    for algo in HIERARCHICAL:
        depth, tri_ids, stats = _core.render(v, faces, np.eye(4), size, size, algo, False, ids)
        np.testing.assert_array_equal(tri_ids, ref_ids, err_msg=algo)
        np.testing.assert_array_equal(depth, ref_depth, err_msg=algo)
        if algo == "hiz":  # (visited in this order: the tests ran)
            assert stats["culled_hidden"] == 1


def test_pyramid_levels_hold_the_max_of_their_children():
    mesh = scenes.default_scene()
    res = zbuffer.render(mesh, width=101, height=77, shading="none")
    levels = res.pyramid()
    assert levels[0] is res.depth or np.array_equal(levels[0], res.depth)
    assert levels[-1].shape == (1, 1)
    for below, level in zip(levels, levels[1:]):
        h, w = below.shape
        assert level.shape == ((h + 1) // 2, (w + 1) // 2)
        padded = np.full((2 * level.shape[0], 2 * level.shape[1]), -np.inf, np.float32)
        padded[:h, :w] = below
        expected = padded.reshape(level.shape[0], 2, level.shape[1], 2).max(axis=(1, 3))
        np.testing.assert_array_equal(level, expected)
    assert np.isinf(levels[-1][0, 0])  # the background is never written
    for level in levels:
        assert level.max() == res.depth.max()


def test_pyramid_levels_reject_bad_input():
    with pytest.raises(TypeError, match="depth must have dtype float32"):
        zbuffer._core.pyramid_levels(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="depth must have shape"):
        zbuffer._core.pyramid_levels(np.zeros(4, np.float32))
    with pytest.raises(ValueError, match="depth must not be empty"):
        zbuffer._core.pyramid_levels(np.zeros((0, 4), np.float32))
    # Sides as render() limits them (the core indexes levels in int).
    with pytest.raises(ValueError, match="image 40000x1 is too large"):
        zbuffer._core.pyramid_levels(np.zeros((1, 40000), np.float32))


@pytest.mark.parametrize("algo", HIERARCHICAL)
@pytest.mark.parametrize("built_once", [False, True])
def test_recorded_culls_lie_under_drawn_cells_and_change_nothing(algo, built_once):
    mesh = occluded_scene(seed=3)
    cam = zbuffer.Camera.look_at((0.2, 0.1, 6.0), (0, 0, 0), fov_y=40, near=1.0, far=20.0)
    if built_once:
        scene = zbuffer.Scene(mesh)
        render = lambda **kw: scene.render(cam, algo, 160, 120, shading="none", **kw)  # noqa: E731
    else:
        render = lambda **kw: zbuffer.render(mesh, algo, cam, 160, 120, shading="none", **kw)  # noqa: E731
    plain, res = render(), render(record_culls=True)
    assert plain.culls is None
    assert_same_visibility(res, plain)
    counters = {k for k, v in plain.stats.items() if isinstance(v, int)}
    assert {k: res.stats[k] for k in counters} == {k: plain.stats[k] for k in counters}
    pyramid = res.pyramid()
    assert [c.shape for c in res.culls] == [p.shape for p in pyramid]
    assert all(c.dtype == np.int64 and c.min() >= 0 for c in res.culls)
    # A test culls only against cells that hold a drawn depth (+inf never
    # culls, and depths only decrease): every counted cell is finite at the end.
    for counts, level in zip(res.culls, pyramid):
        assert np.isfinite(level[counts > 0]).all()
    # Each culled triangle counts in the 1 to 9 cells its test read; a node
    # culled whole counts its (at least one) triangles in up to 16 x 16 cells.
    total = sum(int(c.sum()) for c in res.culls)
    hidden, nodes = res.stats["culled_hidden"], res.stats["nodes_hidden"]
    assert hidden + nodes > 0
    assert hidden + nodes <= total
    if algo == "hiz":
        assert total <= 9 * hidden
    else:
        assert total <= 9 * hidden + 256 * res.stats["culled_in_nodes"]


@pytest.mark.parametrize("algo", zbuffer.algorithms())
def test_the_registry_says_which_algorithms_cull_against_a_pyramid(algo):
    # Behind a wall listed first, an algorithm with a Z-pyramid culls
    # triangles; one without culls none.
    res = zbuffer.render(occluded_scene(), algo, width=64, height=48, shading="none")
    assert (res.stats["culled_hidden"] + res.stats["culled_in_nodes"] > 0) == \
        (algo in HIERARCHICAL)


@pytest.mark.parametrize("algo", [a for a in zbuffer.algorithms() if a not in HIERARCHICAL])
def test_record_culls_needs_a_pyramid(algo):
    mesh = occluded_scene()
    with pytest.raises(ValueError, match="no Z-pyramid"):
        zbuffer.render(mesh, algo, width=32, height=32, record_culls=True)
    with pytest.raises(TypeError, match="record_culls must be a bool"):
        zbuffer.render(mesh, "hiz", width=32, height=32, record_culls="yes")


def test_most_culling_cells_orders_by_count():
    from zbuffer.viz import most_culling_cells

    counts = np.array([[0, 5, 1], [7, 0, 5]], dtype=np.int64)
    assert most_culling_cells(counts, 3).tolist() == [[1, 0], [0, 1], [1, 2]]
    assert most_culling_cells(counts, 10).tolist() == [[1, 0], [0, 1], [1, 2], [0, 2]]
    assert most_culling_cells(np.zeros((2, 2), np.int64), 4).shape == (0, 2)


@pytest.mark.parametrize("algo", HIERARCHICAL)
def test_tiny_images_cull_and_change_no_bit(algo):
    # Images a few pixels across, where the pyramid has few levels (or none
    # above 8 x 8 cells), behind a wall that fills the view, with triangles
    # large enough to cover pixel centres.
    mesh = occluded_scene(seed=1, n_hidden=3000, n_front=0, spread=0.6)
    cam = zbuffer.Camera.look_at((0.0, 0.0, 3.0), (0, 0, 0), fov_y=40, near=1.0, far=20.0)
    culled = 0
    for width, height in [(1, 1), (2, 3), (4, 4), (9, 6)]:
        res = zbuffer.render(mesh, algo=algo, camera=cam, width=width, height=height,
                             shading="none")
        ref = zbuffer.reference.render(mesh, camera=cam, width=width, height=height,
                                       shading="none")
        assert_same_visibility(res, ref)
        culled += res.stats["culled_hidden"]
    assert culled > 0
