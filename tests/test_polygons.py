"""Polygon faces drawn natively by the scanline algorithm (docs/rasterization.md,
"Polygons"), against the numpy reference, and against the triangulations the
other algorithms draw.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import zbuffer
from zbuffer import _core, reference
from zbuffer.polygons import triangulate_polygons
from helpers import (ALGORITHMS, POLYGON_ALGORITHMS, assert_same_counters,
                     assert_same_visibility, model_path, reference_for)
from test_properties import MVP, SIZE, SUB, grid_coord, triangles, to_arrays

SETTINGS = settings(max_examples=200, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def render_polygons_core(v, faces, sizes, indices, cull=False, algo="scanline"):
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    return _core.render(np.ascontiguousarray(v), np.ascontiguousarray(faces, dtype=np.int32),
                        MVP, SIZE, SIZE, algo, cull, None, offsets,
                        np.ascontiguousarray(indices, dtype=np.int32))


@st.composite
def polygon_scenes(draw, steep=False):
    """Star-shaped polygons (simple; convex when the radius is constant) on
    the fixed-point grid, each in a random plane, some wound each way. Steep
    planes leave [-1, 1] in z: those polygons cross the near or far plane."""
    sizes, points = [], []
    for _ in range(draw(st.integers(1, 4))):
        n = draw(st.integers(3, 11))
        cx = draw(st.integers(2 * SUB, (SIZE - 2) * SUB))
        cy = draw(st.integers(2 * SUB, (SIZE - 2) * SUB))
        convex = draw(st.booleans())
        r_max = draw(st.integers(SUB // 2, 9 * SUB))
        angles = sorted(set(draw(st.lists(st.integers(0, 359), min_size=n, max_size=n))))
        if len(angles) < 3:
            continue
        if draw(st.booleans()):
            angles = angles[::-1]
        # A random plane z = a + b x + c y, kept inside [-1, 1] over the image.
        a = draw(st.integers(-4, 4)) / 8.0
        slope = 8.0 if steep else 1.0
        b, c = (slope * draw(st.integers(-4, 4)) / (8.0 * SIZE * SUB) for _ in range(2))
        for deg in angles:
            r = r_max if convex else draw(st.integers(r_max // 4, r_max))
            x = cx + round(r * math.cos(math.radians(deg)))
            y = cy + round(r * math.sin(math.radians(deg)))
            points.append((x, y, a + b * x + c * y))
        sizes.append(len(angles))
    if not sizes:
        sizes, points = [3], [(0, 0, 0.0), (8 * SUB, 0, 0.0), (0, 8 * SUB, 0.0)]
    v = np.array([[grid_coord(x), grid_coord(y), z] for x, y, z in points], dtype=np.float64)
    sizes = np.array(sizes, dtype=np.int64)
    return v, sizes, np.arange(len(v), dtype=np.int64), points


def exact_triangulation(points, sizes, faces):
    """True if the triangles tile each polygon exactly in the snapped plane:
    each has the polygon's orientation, and their areas add up to its area."""
    start, tri = 0, 0
    for n in sizes:
        p = points[start:start + n]
        area = sum(p[k][0] * p[(k + 1) % n][1] - p[(k + 1) % n][0] * p[k][1] for k in range(n))
        total = 0
        for f in faces[tri:tri + n - 2]:
            (ax, ay, _), (bx, by, _), (cx, cy, _) = (points[i] for i in f)
            t = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
            if t == 0 or (t > 0) != (area > 0):
                return False
            total += t
        if total != area:
            return False
        start, tri = start + n, tri + n - 2
    return True


def render_both(v, sizes, indices, cull):
    """The polygons drawn by the core and by the reference: the same depth,
    ids and covered pixels (asserted); returns (ids, stats, reference stats)."""
    faces, _ = triangulate_polygons(v, sizes, indices)
    depth, ids, stats = render_polygons_core(v, faces, sizes, indices, cull)
    ref_depth, ref_ids, ref_stats = reference.render_polygons(v, faces, sizes, indices, MVP,
                                                              SIZE, SIZE, cull)
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(depth, ref_depth)
    assert stats["pixels_covered"] == ref_stats["pixels_covered"]
    return ids, stats, ref_stats


@SETTINGS
@given(scene=polygon_scenes(), cull=st.booleans())
def test_random_polygons_equal_reference(scene, cull):
    v, sizes, indices, points = scene
    ids, stats, ref_stats = render_both(v, sizes, indices, cull)
    assert stats["pixels_tested"] == stats["pixels_covered"]  # exact spans
    for key in ("triangles_in", "culled_backface", "culled_degenerate", "rasterized",
                "clipped", "clip_pieces", "culled_frustum"):
        assert stats[key] == ref_stats[key], key
    # A polygon's pixels carry its first triangle's id, unless a vertex of
    # it lies outside the near or far plane (steep planes; a plane at the
    # image's edge) and it was drawn as its triangles (docs/rasterization.md,
    # 3.7) -- whether or not any of them needed clipping.
    if np.all(np.abs(v[:, 2]) <= 1.0):  # the identity MVP: z is NDC z
        first = np.concatenate([[0], np.cumsum(sizes - 2)[:-1]])
        assert set(np.unique(ids)) <= set(first.tolist()) | {-1}


@SETTINGS
@given(scene=polygon_scenes(steep=True), cull=st.booleans())
def test_polygons_crossing_near_and_far_planes_equal_reference(scene, cull):
    # Such polygons are drawn as their (clipped) triangles, the others natively.
    v, sizes, indices, _ = scene
    _, stats, ref_stats = render_both(v, sizes, indices, cull)
    assert_same_counters(stats, ref_stats)


def test_steep_polygon_scenes_do_cross_the_clip_planes():
    # The test above is only worth its name if clipping happens in it.
    from hypothesis import find

    find(polygon_scenes(steep=True),
         lambda scene: render_polygons_core(
             scene[0], triangulate_polygons(*scene[:3])[0], scene[1], scene[2])[2]["clipped"] > 0,
         settings=settings(max_examples=500, database=None))


# Coordinates on pixel centres and pixel boundaries (multiples of half a
# pixel), and sometimes anywhere on the sub-pixel grid.
half_pixel = st.integers(-2, 2 * SIZE + 2).map(lambda p: p * SUB // 2)
grid = st.one_of(half_pixel, half_pixel, st.integers(-SUB, (SIZE + 1) * SUB))


@st.composite
def staircases(draw):
    """A histogram-shaped rectilinear polygon: horizontal edges on rows of
    centres, vertices on centres, concave corners; either winding."""
    xs = sorted(set(draw(st.lists(grid, min_size=2, max_size=7))))
    if len(xs) < 2:
        xs = [0, 4 * SUB]
    y0 = draw(grid)
    tops = [y0 + draw(st.integers(1, 3 * SIZE)) * SUB // 2 for _ in xs[1:]]
    pts = [(xs[0], y0), (xs[-1], y0)]
    for k in range(len(xs) - 1, 0, -1):
        pts += [(xs[k], tops[k - 1]), (xs[k - 1], tops[k - 1])]
    if draw(st.booleans()):
        pts = pts[::-1]
    z = draw(st.integers(-3, 3)) / 4.0
    v = np.array([[grid_coord(x), grid_coord(y), z] for x, y in pts], dtype=np.float64)
    return v, np.array([len(pts)]), np.arange(len(pts), dtype=np.int64), \
        [(x, y, z) for x, y in pts]


@SETTINGS
@given(scene=staircases())
def test_staircases_on_the_pixel_grid(scene):
    # Horizontal edges through rows of centres and vertices on centres:
    # the cases where even-odd must reproduce the top-left rule exactly.
    v, sizes, indices, points = scene
    faces, _ = triangulate_polygons(v, sizes, indices)
    depth, ids, stats = render_polygons_core(v, faces, sizes, indices)
    ref_depth, ref_ids, ref_stats = reference.render_polygons(v, faces, sizes, indices, MVP,
                                                              SIZE, SIZE)
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(depth, ref_depth)
    assert stats["pixels_covered"] == ref_stats["pixels_covered"]
    if exact_triangulation(points, sizes, faces):
        _, tri_ids, _ = _core.render(v, np.ascontiguousarray(faces, dtype=np.int32), MVP,
                                     SIZE, SIZE, "zbuffer", False)
        np.testing.assert_array_equal(ids >= 0, tri_ids >= 0)


@SETTINGS
@given(scene=polygon_scenes())
def test_polygon_coverage_equals_its_triangulation(scene):
    # A simple planar polygon covers exactly the pixel centres its exact
    # triangulation covers (top-left rule = even-odd with half-open rows).
    v, sizes, indices, points = scene
    faces, _ = triangulate_polygons(v, sizes, indices)
    if not exact_triangulation(points, sizes, faces):
        return  # (rounding to the grid made a polygon self-touching)
    first = np.concatenate([[0], np.cumsum(sizes - 2)])
    for p in range(len(sizes)):  # one polygon at a time: depth may differ
        sel = slice(int(first[p]), int(first[p + 1]))
        idx = indices[int(np.sum(sizes[:p])):int(np.sum(sizes[:p + 1]))]
        _, ids, _ = render_polygons_core(v, faces[sel], sizes[p:p + 1], idx)
        _, tri_ids, _ = _core.render(v, np.ascontiguousarray(faces[sel], dtype=np.int32), MVP,
                                     SIZE, SIZE, "zbuffer", False)
        np.testing.assert_array_equal(ids >= 0, tri_ids >= 0)


@SETTINGS
@given(tris=triangles, cull=st.booleans())
def test_triangles_as_polygons_equal_the_triangle_path(tris, cull):
    # Three-corner polygons: even-odd coverage, fan-triangle depth and the
    # first-triangle id are the triangle rules, bit for bit.
    v, f = to_arrays(tris)
    sizes = np.full(len(f), 3, np.int64)
    depth, ids, stats = render_polygons_core(v, f, sizes, f.reshape(-1), cull)
    ref_depth, ref_ids, ref_stats = reference.render_polygons(v, f, sizes, f.reshape(-1), MVP,
                                                              SIZE, SIZE, cull)
    tri_depth, tri_ids, tri_stats = _core.render(v, f, MVP, SIZE, SIZE, "zbuffer", cull)
    np.testing.assert_array_equal(ids, tri_ids)
    np.testing.assert_array_equal(depth, tri_depth)
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(depth, ref_depth)
    assert stats["pixels_covered"] == tri_stats["pixels_covered"] == ref_stats["pixels_covered"]


# The adversarial files of issue 3.
ADVERSARIAL = [
    "concave_plane.obj", "four_rectangles.obj", "star_triangles.obj", "simple_planes2.obj",
    "steep_quads.obj", "cube.obj", "six_boxes.obj", "desk.obj", "flowers.obj",
    "quadknot.obj", "rabbit_ngons.obj", "polygonfaces.obj", "negative_indices.obj",
]


@pytest.mark.models
@pytest.mark.parametrize("algo", ALGORITHMS)
@pytest.mark.parametrize("name", ADVERSARIAL)
def test_adversarial_models_equal_reference(algo, name):
    mesh = zbuffer.load(model_path(name))
    w, h = 96, 72
    drawn = 0
    for direction, projection, cull in [((0.3, 0.2, 1.0), "perspective", False),
                                        ((-1.0, 0.5, -0.4), "orthographic", True),
                                        ((0.0, 0.0, 1.0), "perspective", False)]:
        cam = zbuffer.Camera.fit(mesh, direction=direction, aspect=w / h, projection=projection)
        res = zbuffer.render(mesh, algo=algo, camera=cam, width=w, height=h, shading="none",
                             cull_backfaces=cull)
        ref = reference_for(algo, mesh, camera=cam, width=w, height=h, shading="none",
                            cull_backfaces=cull)
        assert_same_visibility(res, ref)
        assert_same_counters(res.stats, ref.stats)
        drawn += int(res.mask.sum())
    assert drawn > 0


def polygon_shading_differences(mesh, size=64):
    """Largest difference (levels of 255) between the scanline's shaded
    image of a polygon mesh and the reference's, over smooth shading and
    per-vertex colours, from two directions."""
    worst = 0
    for direction in [(0.3, 0.2, 1.0), (-0.6, 0.4, 0.7)]:
        cam = zbuffer.Camera.fit(mesh, direction=direction, aspect=1.0)
        for shading in ["smooth", "flat"]:
            res = zbuffer.render(mesh, algo="scanline", camera=cam, width=size, height=size,
                                 shading=shading)
            ref = zbuffer.reference.render(mesh, camera=cam, width=size, height=size,
                                           shading=shading, polygons=True)
            assert_same_visibility(res, ref)
            worst = max(worst, int(np.abs(res.image.astype(int) - ref.image.astype(int)).max()))
    return worst


def test_smooth_shading_of_native_polygons_clamps_like_the_reference(tmp_path):
    # Every pixel of a polygon drawn natively carries its first triangle's
    # id, also where it lies outside that triangle: interpolation must clamp
    # there as the reference does (the vector passes extrapolated, up to
    # 36 levels off on these two bent quads). With per-vertex colours too.
    text = "v -1 -1 0 1 0 0\nv 0 -1 0.6 0 1 0\nv 1 -1 0 0 0 1\n" \
           "v -1 1 0 1 1 0\nv 0 1 0.6 0 1 1\nv 1 1 0 1 0 1\nf 1 2 5 4\nf 2 3 6 5\n"
    (tmp_path / "bent_quads.obj").write_text(text)
    mesh = zbuffer.load(tmp_path / "bent_quads.obj")
    assert mesh.polygon_sizes is not None and mesh.vertex_colors is not None
    assert polygon_shading_differences(mesh) <= 1
    plain = zbuffer.Mesh(mesh.vertices, mesh.faces, polygons=(mesh.polygon_sizes,
                                                             mesh.polygon_indices))
    assert polygon_shading_differences(plain) <= 1


@pytest.mark.models
@pytest.mark.parametrize("name", ["rabbit_ngons.obj", "flowers.obj", "quadknot.obj", "cube.obj"])
def test_smooth_shading_of_polygon_models_equals_reference(name):
    assert polygon_shading_differences(zbuffer.load(model_path(name))) <= 1


@pytest.mark.models
@pytest.mark.parametrize("name", ["concave_plane.obj", "four_rectangles.obj", "cube.obj",
                                  "six_boxes.obj"])
def test_planar_polygons_cover_what_their_triangulation_covers(name):
    # Planar simple polygons: the scanline's even-odd coverage equals the
    # ear-clipped triangulation's that the other algorithms draw.
    mesh = zbuffer.load(model_path(name))
    assert mesh.polygon_sizes is not None
    for direction in [(0.3, 0.2, 1.0), (0.0, 0.0, 1.0), (-0.7, 0.1, 0.5)]:
        cam = zbuffer.Camera.fit(mesh, direction=direction, aspect=1.0)
        scan = zbuffer.render(mesh, algo="scanline", camera=cam, width=80, height=80,
                              shading="none")
        plain = zbuffer.render(mesh, algo="zbuffer", camera=cam, width=80, height=80,
                               shading="none")
        np.testing.assert_array_equal(scan.mask, plain.mask)
        assert scan.mask.any()


def test_concave_polygon_is_not_drawn_as_a_fan():
    # An L-shaped hexagon whose fan from corner 0 would cover the notch.
    sq = [(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)]
    rot = sq[1:] + sq[:1]  # corner 0 at (4, 0): its fan crosses the notch
    v = np.array([[x / 4.0 - 0.5, y / 4.0 - 0.5, 0.0] for x, y in rot])
    sizes, idx = np.array([6]), np.arange(6)
    faces, _ = triangulate_polygons(v, sizes, idx)
    mesh = zbuffer.Mesh(v, faces, polygons=(sizes, idx))
    cam = zbuffer.Camera.look_at((0, 0, 2), (0, 0, 0), projection="orthographic", ortho_height=1.2)
    scan = zbuffer.render(mesh, algo="scanline", camera=cam, width=48, height=48, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=48, height=48, shading="none",
                                   polygons=True)
    assert_same_visibility(scan, ref)
    fan = np.array([[0, k, k + 1] for k in range(1, 5)])
    fan_render = zbuffer.render((v, fan), algo="zbuffer", camera=cam, width=48, height=48,
                                shading="none")
    plain = zbuffer.render(mesh, algo="zbuffer", camera=cam, width=48, height=48, shading="none")
    np.testing.assert_array_equal(scan.mask, plain.mask)
    assert (fan_render.mask & ~scan.mask).any()  # the fan covers the notch; we do not


def test_polygon_input_is_checked():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    zbuffer.Mesh(v, faces, polygons=([4], [0, 1, 2, 3]))  # fine
    with pytest.raises(ValueError, match="triangles"):
        zbuffer.Mesh(v, faces, polygons=([3], [0, 1, 2]))
    with pytest.raises(ValueError, match="fewer than 3"):
        zbuffer.Mesh(v, faces[:0], polygons=([2], [0, 1]))
    with pytest.raises(ValueError, match="outside"):
        zbuffer.Mesh(v, faces, polygons=([4], [0, 1, 2, 9]))
    with pytest.raises(ValueError, match="add up"):
        zbuffer.Mesh(v, faces, polygons=([3, 3], [0, 1, 2, 0, 2]))
    with pytest.raises(ValueError, match="more than the 3 polygon indices"):
        zbuffer.Mesh(v, faces, polygons=([4], [0, 1, 2]))
    f32 = faces.astype(np.int32)
    offsets, idx = np.array([0, 4], np.int64), np.array([0, 1, 2, 3], np.int32)
    with pytest.raises(ValueError, match="draws triangles only"):
        _core.render(v, f32, MVP, 8, 8, "zbuffer", False, None, offsets, idx)
    with pytest.raises(ValueError, match="both"):
        _core.render(v, f32, MVP, 8, 8, "scanline", False, None, offsets, None)
    with pytest.raises(ValueError, match="from 0"):
        _core.render(v, f32, MVP, 8, 8, "scanline", False, None, np.array([1, 4], np.int64), idx)
    with pytest.raises(ValueError, match="outside"):
        _core.render(v, f32, MVP, 8, 8, "scanline", False, None, offsets,
                     np.array([0, 1, 2, 7], np.int32))
    with pytest.raises(TypeError):
        _core.render(v, f32, MVP, 8, 8, "scanline", False, None, offsets, idx.astype(np.int64))


def test_merged_keeps_the_polygons(tmp_path):
    # Two quads, the second repeating two of the first's positions as
    # vertices of its own: merged shares them, and keeps the polygons (it
    # dropped them: scanline then drew the triangulation).
    path = tmp_path / "quads.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 1 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\n"
                    "f 1 2 3 4\nf 5 6 7 8\n")
    mesh = zbuffer.load(path)
    merged = mesh.merged()
    assert len(merged.vertices) == 6 and merged.polygon_sizes is not None
    np.testing.assert_array_equal(merged.face_polygon, mesh.face_polygon)
    np.testing.assert_array_equal(merged.vertices[merged.polygon_indices],
                                  mesh.vertices[mesh.polygon_indices])
    for algo in ("scanline", "zbuffer"):
        a = zbuffer.render(mesh, algo=algo, width=32, height=16, shading="none")
        b = zbuffer.render(merged, algo=algo, width=32, height=16, shading="none")
        np.testing.assert_array_equal(a.triangle_id, b.triangle_id)
        np.testing.assert_array_equal(a.depth, b.depth)


def test_polygon_sizes_that_would_wrap_are_refused():
    """Sizes whose int64 sums wrap around to the right totals (a fuzzer's
    find: they were accepted, and the scanline read far outside the
    indices) are refused by Mesh, and wild offsets by the core."""
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    faces = np.array([[0, 1, 2], [0, 2, 3]] * 3)
    a, k = 2**32 + 3, 12
    sizes = np.array([a, 2**63 - 1, 2**63 - 1 - a + k + 2], np.int64)
    assert sizes.sum() == k and (sizes - 2).sum() == len(faces)  # (wrapped)
    with pytest.raises(ValueError, match="more than the 12 polygon indices"):
        zbuffer.Mesh(v, faces, polygons=(sizes, np.arange(k) % 4))
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    assert offsets[0] == 0 and offsets[-1] == k and len(offsets) == 4
    idx = (np.arange(k) % 4).astype(np.int32)
    for algo in ("scanline",):
        with pytest.raises(ValueError, match=r"polygon_offsets\[1\] = 4294967299 is outside"):
            _core.render(v, faces.astype(np.int32), MVP, 8, 8, algo, False, None, offsets, idx)
    with pytest.raises(ValueError, match=r"polygon_offsets\[2\] = 2 is outside \[4,"):
        _core.render(v, faces[:4].astype(np.int32), MVP, 8, 8, "scanline", False, None,
                     np.array([0, 4, 2, 8], np.int64), idx[:8])


def test_face_polygon_is_checked():
    # (a fuzzing round: floats were truncated, bools and negative or
    # inconsistent polygon numbers taken, strings met numpy's message)
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    polygons = ([4], [0, 1, 2, 3])
    assert zbuffer.Mesh(v, quad, face_polygon=[0, 0], polygons=polygons).face_polygon.tolist() == [0, 0]
    for value, error, match in [([0.5, 1.7], TypeError, "face_polygon must be integers"),
                                ([True, False], TypeError, "face_polygon must be integers"),
                                (["a", "b"], TypeError, "face_polygon must be integers"),
                                ([-5, 0], ValueError, "face_polygon must be polygon numbers >= 0"),
                                ([0], ValueError, r"face_polygon must have shape \(2,\)")]:
        with pytest.raises(error, match=match):
            zbuffer.Mesh(v, quad, face_polygon=value)
    with pytest.raises(ValueError, match="face_polygon must give each triangle its polygon"):
        zbuffer.Mesh(v, quad, face_polygon=[0, 1], polygons=polygons)


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_the_registry_says_which_algorithms_draw_polygons(algo):
    # A folded quad: drawn as a polygon it is flat (docs/rasterization.md,
    # 3.7), as its two triangles it is not, so the depths differ. An
    # algorithm draws it one way or the other exactly as the registry says.
    v = np.array([[-0.5, -0.5, 0.0], [0.5, -0.5, 0.3], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.3]])
    sizes, idx = np.array([4]), np.arange(4)
    faces, _ = triangulate_polygons(v, sizes, idx)
    mesh = zbuffer.Mesh(v, faces, polygons=(sizes, idx))
    cam = zbuffer.Camera.look_at((0.2, 0.3, 2), (0, 0, 0), fov_y=50)
    kw = dict(camera=cam, width=40, height=40, shading="none")
    as_polygon = zbuffer.reference.render(mesh, polygons=True, **kw)
    as_triangles = zbuffer.reference.render(mesh, polygons=False, **kw)
    assert not np.array_equal(as_polygon.depth, as_triangles.depth)
    res = zbuffer.render(mesh, algo=algo, **kw)
    assert_same_visibility(res, as_polygon if algo in POLYGON_ALGORITHMS else as_triangles)
