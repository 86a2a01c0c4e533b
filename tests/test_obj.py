"""zbuffer's OBJ reader: relative indices, polygons as written, exact triangulation."""

import numpy as np
import pytest

import zbuffer
from zbuffer.obj import read_obj
from zbuffer.polygons import triangulate_polygons
from helpers import model_path


def write(tmp_path, text, name="mesh.obj"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_relative_indices_count_from_the_vertices_defined_so_far(tmp_path):
    # Two quads in separate groups, the second written with negative indices.
    absolute = """o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4
o b\nv 2 0 0\nv 3 0 0\nv 3 1 0\nv 2 1 0\nf 5/1/1 6/2/1 7/3/1 8/4/1\n"""
    relative = """o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1
g b\nusemtl red\nv 2 0 0\nv 3 0 0\nv 3 1 0\nv 2 1 0\nf -4/-4/-1 -3//-1 -2 -1\n"""
    a = read_obj(write(tmp_path, absolute, "a.obj"))
    r = read_obj(write(tmp_path, relative, "r.obj"))
    np.testing.assert_array_equal(a.polygon_indices, r.polygon_indices)
    np.testing.assert_array_equal(a.polygon_indices, np.arange(8))
    assert list(r.polygon_sizes) == [4, 4]


@pytest.mark.models
def test_cornell_box_with_relative_indices_and_groups():
    mesh = zbuffer.load(model_path("cornell_box_original.obj"))
    assert len(mesh.faces) == 36 and len(mesh.vertices) == 72
    # Every quad's two triangles use four distinct corners of one face
    # record, none from another record (what a wrong relative index gives).
    for k in range(18):
        tris = mesh.faces[mesh.face_polygon == k]
        assert len(tris) == 2 and len(np.unique(tris)) == 4
    res = zbuffer.render(mesh, width=64, height=64, shading="none")
    assert res.mask.mean() > 0.3
    # Floor, ceiling, back and side walls, both boxes: many polygons show.
    assert len(np.unique(mesh.face_polygon[res.triangle_id[res.mask]])) >= 10


def test_vertex_colours_and_continuation_lines(tmp_path):
    text = "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 \\\n 0 0 0 1\n# comment \\\nf 1 2 3\n"
    data = read_obj(write(tmp_path, text))
    np.testing.assert_array_equal(data.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(data.vertex_colors, np.eye(3))
    mesh = zbuffer.load(write(tmp_path, text, "c.obj"))
    assert mesh.vertex_colors is not None and len(mesh.faces) == 1


def test_indented_records_and_trailing_comments(tmp_path):
    # Records indented by spaces or tabs count (an indented v shifts what
    # relative indices name); a comment may end a record, and a backslash
    # inside a comment continues nothing.
    text = ("  v 5 5 5  # not used\n\tv 0 0 0\nv 1 0 0 # x axis\n v 0 1 0\n"
            "   f -3 -2 -1   # the only face \\\nf 1 1 1\n")
    data = read_obj(write(tmp_path, text))
    np.testing.assert_array_equal(data.vertices, [[5, 5, 5], [0, 0, 0], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(data.polygon_indices, [1, 2, 3, 0, 0, 0])
    assert list(data.polygon_sizes) == [3, 3]
    # A comment after a continuation's backslash, and white space after one.
    data = read_obj(write(tmp_path, "v 0 0 0\nv 1 0 0\nv 0 1 \\ # z next\n0\nf 1 2 \\  \n3\n",
                          "k.obj"))
    np.testing.assert_array_equal(data.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert list(data.polygon_indices) == [0, 1, 2]
    mesh = zbuffer.load(write(tmp_path, "v 0 0 0\nv 1 0 0\nv 0 1 0\n  f 1 2 3\n", "i.obj"))
    assert len(mesh.faces) == 1
    assert zbuffer.render(mesh, width=16, height=16, shading="none").mask.any()


@pytest.mark.parametrize("text, message", [
    ("v 0 0\nf 1 1 1\n", "line 1: a vertex needs 3 coordinates"),
    ("v 0 0 0\nv 1 0 0\nf 1 2\n", "line 3: a face needs at least 3 corners"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "line 4: bad face record"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "line 4: bad face record"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "line 4: face 0 refers to vertex 4"),
    ("v 0 0 0\nv 1 0 0\nf -1 -2 -3\n", "line 3: face 0 refers to vertex 0"),
    ("v 0 0 0\nv 1 0 0\n# two\n\nv 0 1 0\nf 1 2 3\nv 0 \\\n zero 0\n",
     "line 7: a vertex coordinate is not a number, got 'zero'"),
    ("# page\x0c\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "line 5: face 0 refers to vertex 9"),
    ("v 0 0 0\r\nv 1 0 0\r\nv inf 1 0\r\nf 1 2 3\r\n",
     r"line 3: a vertex coordinate is NaN or infinite, got \[inf, 1.0, 0.0\]"),
    ("v 0 0 0 300 0 0\nv 1 0 0 0 0 0\nv 0 1 0 0 0 0\nf 1 2 3\n",
     r"line 1: a vertex colour must lie in \[0, 1\], or in 0-255 with every colour of the "
     r"file a whole number, got \[300.0, 0.0, 0.0\]"),
    # a fraction above 1: not read as 0-255 (which would darken every colour)
    ("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 1.0000001 0 0\nf 1 2 3\n",
     r"line 3: a vertex colour must lie in \[0, 1\], or .* got \[1.0000001, 0.0, 0.0\]"),
    ("v 1_0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "line 1: a number may hold only ASCII"),
    ("v 0 0 0\nv 1 0 0\nv 0 \u0661 0\nf 1 2 3\n", "line 3: a number may hold only ASCII"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1_0\n", "line 4: a number may hold only ASCII"),
])
def test_malformed_records_name_the_problem(tmp_path, text, message):
    with pytest.raises(ValueError, match=message):
        zbuffer.load(write(tmp_path, text))


def polygon_area_normal(p):
    q = np.roll(p, -1, axis=0)
    return 0.5 * np.cross(p, q).sum(axis=0)


def star(n, seed, concave=True):
    """A simple star-shaped polygon of n corners in a random plane."""
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0, 2 * np.pi, n))
    radii = rng.uniform(0.2, 1.0, n) if concave else np.ones(n)
    flat = np.stack([radii * np.cos(angles), radii * np.sin(angles), np.zeros(n)], -1)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return flat @ q.T + rng.normal(size=3)


@pytest.mark.parametrize("seed", range(20))
def test_triangulation_covers_the_polygon_exactly(seed):
    # Concave polygons: the triangles' vector areas add up to the polygon's
    # (no overlap, no gap, same winding), and every triangle lies inside it.
    n = 5 + seed % 9
    p = star(n, seed)
    faces, owner = triangulate_polygons(p, np.array([n]), np.arange(n))
    assert len(faces) == n - 2 and (owner == 0).all()
    tri = p[faces]
    tri_areas = 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    target = polygon_area_normal(p)
    np.testing.assert_allclose(tri_areas.sum(axis=0), target, atol=1e-12)
    # Same winding: each triangle's normal points along the polygon's.
    assert (tri_areas @ target > 0).all()
    np.testing.assert_allclose(np.linalg.norm(tri_areas, axis=1).sum(), np.linalg.norm(target))


@pytest.mark.parametrize("seed", range(6))
def test_triangulation_does_not_depend_on_the_scale(seed):
    # The same triangles for the same polygons scaled by 1e-300 .. 1e300
    # (concave ones passed for convex, and became fans that cover area
    # outside them, below ~1e-80 and above ~1e154: a fuzzer's find). Five
    # polygons of each size at once, one triangle among them.
    sizes = np.array([3] + [5 + seed % 9] * 5)
    p = np.concatenate([star(3, seed, concave=False)] +
                       [star(int(n), seed + 7 * k) for k, n in enumerate(sizes[1:])])
    expected, _ = triangulate_polygons(p, sizes, np.arange(len(p)))
    for scale in [1e-300, 1e-100, 1e-80, 1e80, 1e155, 1e300]:
        faces, _ = triangulate_polygons(p * scale, sizes, np.arange(len(p)))
        np.testing.assert_array_equal(faces, expected)


@pytest.mark.parametrize("turns", [2, 9])
def test_triangulation_of_a_long_spiral_covers_it_exactly(turns):
    # A thin spiral band (many reflex corners, ears far apart along the
    # outline): triangles tile it with no overlap or gap, each wound as the
    # polygon is.
    k = np.arange(40 * turns)
    inner = np.stack([(1 + .05 * k) * np.cos(.15 * k), (1 + .05 * k) * np.sin(.15 * k)], 1)
    outer = np.stack([(1.2 + .05 * k) * np.cos(.15 * k), (1.2 + .05 * k) * np.sin(.15 * k)], 1)
    ring = np.concatenate([inner, outer[::-1]])
    ring = np.roll(ring, len(ring) // 4, axis=0)
    p = np.column_stack([ring, np.zeros(len(ring))])
    n = len(p)
    faces, _ = triangulate_polygons(p, np.array([n]), np.arange(n))
    assert len(faces) == n - 2
    tri = p[faces]
    tri_areas = 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    target = polygon_area_normal(p)
    assert (tri_areas @ target > 0).all()
    np.testing.assert_allclose(np.linalg.norm(tri_areas, axis=1).sum(), np.linalg.norm(target),
                               rtol=1e-12)


def quads_2d(seed, count=4000):
    """Quads in 2D that exercise every branch of ear clipping: random
    corners (darts, bowties, convex ones), corners on a small integer grid
    (collinear and repeated corners, a corner on an edge), and a few with
    NaN, infinite and huge coordinates."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(count, 4, 2))
    q[: count // 2] = rng.integers(-2, 3, size=(count // 2, 4, 2))
    q[-30:-20, rng.integers(4)] = np.nan
    q[-20:-10, rng.integers(4), rng.integers(2)] = np.inf
    q[-10:] *= 1e200
    return q


@pytest.mark.parametrize("seed", range(4))
def test_quads_are_ear_clipped_all_at_once_as_one_at_a_time(seed):
    # _ear_clip_quads, the vectorised ear clipping of many quads (concave
    # quads are common), cuts every quad into the triangles _ear_clip cuts
    # it into, the fan of self-intersecting and degenerate ones included.
    from zbuffer.polygons import _ear_clip, _ear_clip_quads

    q = quads_2d(seed)
    with np.errstate(all="ignore"):  # inf - inf in the last rows
        expected = np.array([_ear_clip(quad) for quad in q])
        np.testing.assert_array_equal(_ear_clip_quads(q), expected)
    # Each branch was taken: an ear at each corner, and no ear at all.
    firsts = {tuple(t[0]) for t in expected}
    assert {(3, 0, 1), (0, 1, 2), (1, 2, 3), (2, 3, 0)} <= firsts


def test_concave_polygons_are_clipped_in_the_plane_of_their_largest_normal_component():
    # triangulate_polygons projects all concave polygons of a size at once
    # (and clips quads at once): the triangles are those of the projection
    # written out for one polygon -- the normal's largest component dropped,
    # the plane mirrored where that component is negative -- and _ear_clip
    # (convex ones, a few of the stars, are fans).
    from zbuffer.polygons import _ear_clip, _newell_normals

    rng = np.random.default_rng(11)
    dart = np.array([[0, 0, 0], [2, 1, 0], [0, 2, 0], [0.5, 1, 0]])
    polygons = []
    for k in range(90):
        n = [4, 5, 6][k % 3]
        if n == 4:
            rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            p = np.roll(dart, rng.integers(4), axis=0) @ rot.T
        else:
            p = star(n, 100 + k)
        polygons.append(p[::-1] if k % 2 else p)  # both windings
    sizes = np.array([len(p) for p in polygons])
    points = np.concatenate(polygons)
    faces, _ = triangulate_polygons(points, sizes, np.arange(len(points)))
    expected, start = [], 0
    concave = 0
    for p in polygons:
        nrm = _newell_normals(p)
        turns = np.cross(p - np.roll(p, 1, axis=0), np.roll(p, -1, axis=0) - p)
        if (turns @ nrm >= 0.0).all():
            k = np.arange(1, len(p) - 1)
            expected.append(np.stack([np.zeros_like(k), k, k + 1], 1) + start)
            start += len(p)
            continue
        concave += 1
        axis = int(np.argmax(np.abs(nrm)))
        p2 = p[:, [(axis + 1) % 3, (axis + 2) % 3]]
        if nrm[axis] < 0.0:
            p2 = p2[:, ::-1]
        expected.append(np.array(_ear_clip(p2)) + start)
        start += len(p)
    assert concave >= 60
    np.testing.assert_array_equal(faces, np.concatenate(expected))


def test_concave_quads_among_other_polygons_keep_their_polygons_order():
    # Darts in random planes among triangles, convex quads and concave
    # pentagons: each polygon's triangles come in its place, and a dart is
    # cut along its inner diagonal (a fan from a convex corner would cover
    # area outside it).
    rng = np.random.default_rng(5)
    dart = np.array([[0, 0, 0], [2, 1, 0], [0, 2, 0], [0.5, 1, 0]])
    sizes, points = [], []
    for k in range(60):
        n = [3, 4, 4, 5][k % 4]
        if n == 4 and k % 8 == 1:
            p = star(4, k, concave=False)
        elif n == 4:
            rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            p = np.roll(dart, rng.integers(4), axis=0) @ rot.T + rng.normal(size=3)
        else:
            p = star(n, k, concave=n == 5)
        sizes.append(n)
        points.append(p)
    p = np.concatenate(points)
    sizes = np.array(sizes)
    faces, owner = triangulate_polygons(p, sizes, np.arange(len(p)))
    np.testing.assert_array_equal(owner, np.repeat(np.arange(len(sizes)), sizes - 2))
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    for j, n in enumerate(sizes):
        mine = faces[owner == j]
        alone, _ = triangulate_polygons(points[j], np.array([n]), np.arange(n))
        np.testing.assert_array_equal(mine, alone + starts[j])
        tri = p[mine]
        areas = 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        np.testing.assert_allclose(np.linalg.norm(areas, axis=1).sum(),
                                   np.linalg.norm(polygon_area_normal(points[j])), rtol=1e-12)


@pytest.mark.models
def test_concave_plane_is_not_triangulated_as_a_fan():
    mesh = zbuffer.load(model_path("concave_plane.obj"))
    p = mesh.vertices
    tri = p[mesh.faces]
    areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    polygon = np.linalg.norm(polygon_area_normal(p))
    assert areas.sum() == pytest.approx(polygon)  # a fan from vertex 1 covers more
    fan = np.stack([np.zeros(6, int), np.arange(1, 7), np.arange(2, 8)], 1)
    fan_tri = p[fan]
    fan_area = 0.5 * np.linalg.norm(np.cross(fan_tri[:, 1] - fan_tri[:, 0],
                                             fan_tri[:, 2] - fan_tri[:, 0]), axis=1).sum()
    assert fan_area > polygon * 1.01


def test_vertex_colours_written_0_255_and_records_of_mixed_lengths(tmp_path):
    path = tmp_path / "a.obj"
    path.write_text("v 0 0 0 255 0 0\nv 1 0 0 0 255 0\nv 0 1 0 0 0 51\nf 1 2 3\n")
    np.testing.assert_allclose(read_obj(str(path)).vertex_colors,
                               [[1, 0, 0], [0, 1, 0], [0, 0, 0.2]])
    # whole numbers written with a point are bytes too; 0 and 1 alone are
    # fractions, as are values with fractional parts
    path.write_text("v 0 0 0 255.0 0 0\nv 1 0 0 0 255 0\nv 0 1 0 0 0 5.1e1\nf 1 2 3\n")
    np.testing.assert_allclose(read_obj(str(path)).vertex_colors,
                               [[1, 0, 0], [0, 1, 0], [0, 0, 0.2]])
    path.write_text("v 0 0 0 1 0 0\nv 1 0 0 0 1.0 0\nv 0 1 0 0 0.5 1\nf 1 2 3\n")
    np.testing.assert_array_equal(read_obj(str(path)).vertex_colors,
                                  [[1, 0, 0], [0, 1, 0], [0, 0.5, 1]])
    # x y z, x y z r g b, x y z w: the positions, and no colours (not every
    # record has them)
    path.write_text("v 0 0 0\nv 1 2 3 0.5 0.5 0.5\nv 4 5 6 1\nv 7 8 9\nf 1 2 3\nf 2 3 4\n")
    data = read_obj(str(path))
    np.testing.assert_array_equal(data.vertices, [[0, 0, 0], [1, 2, 3], [4, 5, 6], [7, 8, 9]])
    assert data.vertex_colors is None


def test_concave_polygons_beyond_the_ear_clipping_limit_are_refused(tmp_path):
    # A star: every other corner reflex. Convex polygons of any size are fans
    # (linear time); a concave one over MAX_CONCAVE_CORNERS would take
    # minutes to ear clip, so it is refused, by name, without trying.
    from zbuffer.polygons import MAX_CONCAVE_CORNERS

    def star(n):
        a = 2 * np.pi * np.arange(n) / n
        r = np.where(np.arange(n) % 2 == 0, 1.0, 0.9)
        return np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros(n)])

    n = MAX_CONCAVE_CORNERS + 2
    with pytest.raises(ValueError, match=f"polygon 0 has {n:,} corners and is not convex"):
        triangulate_polygons(star(n), np.array([n]), np.arange(n))
    circle = star(n)[:, :2] / np.linalg.norm(star(n)[:, :2], axis=1, keepdims=True)
    faces, _ = triangulate_polygons(np.column_stack([circle, np.zeros(n)]), np.array([n]),
                                    np.arange(n))
    assert len(faces) == n - 2  # convex: a fan, however many corners
    path = tmp_path / "star.obj"
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in star(n))
                    + "f " + " ".join(str(k + 1) for k in range(n)) + "\n")
    with pytest.raises(ValueError, match="not convex"):
        zbuffer.load(path)
