"""Clipping in homogeneous clip space: near, far and the guard band."""

import numpy as np
import pytest

import zbuffer
from zbuffer import scenes
from helpers import ALGORITHMS, assert_same_visibility, counters_add_up


def inside_out_box():
    v, f = scenes.box((0.0, 0.0, 0.0), (4.0, 3.0, 5.0))
    return zbuffer.Mesh(v, f)


@pytest.mark.parametrize("algo", ALGORITHMS)
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_camera_inside_a_closed_box_sees_every_wall(algo, projection):
    mesh = inside_out_box()
    cam = zbuffer.Camera.look_at((0.3, -0.2, 0.5), (1.0, 0.4, -2.0), fov_y=100,
                                 near=0.05, far=20.0, projection=projection,
                                 ortho_height=2.0)
    res = zbuffer.render(mesh, algo=algo, camera=cam, width=80, height=60, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=80, height=60, shading="none")
    assert_same_visibility(res, ref)
    assert (res.triangle_id >= 0).all(), "a hole in the walls around the camera"
    assert res.stats["clipped"] > 0
    assert counters_add_up(res.stats)


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_triangles_crossing_near_and_far_planes(algo):
    # Long triangles reaching from behind the camera to beyond the far plane.
    rng = np.random.default_rng(5)
    n = 40
    a = rng.uniform(-1, 1, (n, 3)) * [3, 3, 0] + [0, 0, 4.0]       # behind the eye
    b = rng.uniform(-1, 1, (n, 3)) * [3, 3, 0] + [0, 0, -30.0]     # beyond far
    c = rng.uniform(-1, 1, (n, 3)) * [2, 2, 2] + [0, 0, -5.0]      # in view
    v = np.stack([a, b, c], 1).reshape(-1, 3)
    mesh = zbuffer.Mesh(v, np.arange(3 * n).reshape(n, 3))
    cam = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=60, near=0.5, far=12.0)
    res = zbuffer.render(mesh, algo=algo, camera=cam, width=64, height=64, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=64, height=64, shading="none")
    assert_same_visibility(res, ref)
    assert res.stats["clipped"] == n
    assert res.stats["clip_pieces"] > n  # crossing both planes leaves quads or more
    assert res.mask.any()
    assert counters_add_up(res.stats)


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_huge_triangles_are_clipped_to_the_guard_band(algo):
    # A floor extending 1e6 units: far outside any guard band, seen from low.
    v = np.array([[-1e6, 0, -1e6], [1e6, 0, -1e6], [1e6, 0, 1e6], [-1e6, 0, 1e6]], float)
    mesh = zbuffer.Mesh(v, [[0, 1, 2], [0, 2, 3]])
    cam = zbuffer.Camera.look_at((0, 1, 0), (0, 0.5, -5), fov_y=60, near=0.1, far=1e7)
    res = zbuffer.render(mesh, algo=algo, camera=cam, width=64, height=48, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=64, height=48, shading="none")
    assert_same_visibility(res, ref)
    assert res.stats["clipped"] == 2
    # The lower part of the image is floor, without holes along the diagonal.
    assert (res.triangle_id[30:] >= 0).all()


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_geometry_behind_the_camera_is_culled(algo):
    v, f = scenes.box((0, 0, 5), (1, 1, 1))
    cam = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), near=0.1, far=100)
    res = zbuffer.render((v, f), algo=algo, camera=cam, width=32, height=32, shading="none")
    assert not res.mask.any()
    # Tree algorithms cull the whole box at its node.
    assert res.stats["culled_frustum"] + res.stats["culled_in_nodes"] == 12


def test_clipped_vertices_rounded_outside_the_guard_band_go_onto_it():
    # A fuzzer's find: at clip coordinates of about 1e21 and beyond, the
    # clipping intersections' rounding left vertices many guard bands
    # outside, past what fixed point holds: the core drew nothing where the
    # reference drew 448 pixels (the triangle's true coverage: 7 columns),
    # or garbage, and the reference itself cast out-of-range floats to int64.
    # Such vertices now go onto the guard-band plane (docs/rasterization.md,
    # 2.3), in both. Then random thin triangles of that kind, both
    # projections, in y and in x.
    cases = [(zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), projection="orthographic",
                                     ortho_height=2e-12, near=1, far=10),
              np.array([[8e-13, 1.9e9, -5.0], [5e-13, -1.5e9, -5.0], [9e-13, -1.4e9, -5.0]]))]
    rng = np.random.default_rng(3)
    for k in range(40):
        if k % 2:
            camera = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), projection="orthographic",
                                            ortho_height=2e-12, near=1, far=10)
            scale, across = 10 ** rng.uniform(18, 32), rng.uniform(-1, 1, 3) * 1e-12
        else:
            camera = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=1e-6, near=1, far=10)
            scale, across = 10 ** rng.uniform(12, 30), rng.uniform(-1, 1, 3) * 3e-8
        along = rng.uniform(0.5, 2, 3) * np.array([1, -1, -1]) * scale
        xy = (across, along) if k % 4 < 2 else (along, across)
        cases.append((camera, np.stack([*xy, rng.uniform(-6, -4, 3)], 1)))
    drawn = []
    for camera, v in cases:
        mesh = zbuffer.Mesh(v, [[0, 1, 2]])
        ref = zbuffer.reference.render(mesh, camera=camera, width=64, height=64, shading="none")
        drawn.append(int(ref.mask.sum()))
        for algo in ALGORITHMS:
            res = zbuffer.render(mesh, algo=algo, camera=camera, width=64, height=64,
                                 shading="none")
            assert_same_visibility(res, ref)
            assert counters_add_up(res.stats)
    assert drawn[0] == 448 and sum(d > 0 for d in drawn) > 30


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_coordinates_near_the_float_limit_are_clipped_away_alike(algo):
    # A triangle 3e308 wide crossing the guard band: its clip distances
    # overflow, and what clipping leaves is dropped by the core and the
    # reference alike -- which warned of the overflow (an error under the
    # tests' warning filter) before computing it without warnings.
    v = np.array([[-1.5e308, 0, -5], [1.5e308, 0, -5], [0, 1, -5]])
    cam = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=96, near=1, far=100)
    res = zbuffer.render((v, [[0, 1, 2]]), algo=algo, camera=cam, width=16, height=16,
                         shading="none")
    ref = zbuffer.reference.render((v, [[0, 1, 2]]), camera=cam, width=16, height=16,
                                   shading="none")
    assert_same_visibility(res, ref)
    assert res.stats["clipped"] == ref.stats["clipped"] == 1
    assert counters_add_up(res.stats)
