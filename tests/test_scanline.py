"""The scanline algorithm: exact spans, its tables' statistics, and scenes
built to break edge stepping (horizontal edges, shared vertices, vertices on
pixel centres and row boundaries, sub-pixel slivers).

Every test compares with the numpy reference or with the plain Z-buffer.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import zbuffer
from test_properties import SIZE, SUB, grid_coord, render_core, render_reference

# A small pool of vertices whose y takes few values, so that many edges are
# horizontal and many triangles share vertices and edges. Positions are
# multiples of half a pixel (centres and row boundaries) or any sub-pixel.
half = st.integers(-2, 2 * SIZE + 2).map(lambda p: p * SUB // 2)
anywhere = st.integers(-SUB, (SIZE + 1) * SUB)
few_rows = st.lists(st.one_of(half, anywhere), min_size=1, max_size=4, unique=True)


@st.composite
def shared_vertex_scenes(draw):
    ys = draw(few_rows)
    n = draw(st.integers(3, 12))
    pool = [(draw(st.one_of(half, anywhere)), draw(st.sampled_from(ys)),
             draw(st.integers(-4, 4)) / 4.0) for _ in range(n)]
    faces = draw(st.lists(st.tuples(*[st.integers(0, n - 1)] * 3), min_size=1, max_size=40))
    v = np.array([[grid_coord(x), grid_coord(y), z] for x, y, z in pool], dtype=np.float64)
    return v, np.array(faces, dtype=np.int32).reshape(-1, 3)


SETTINGS = settings(max_examples=300, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(scene=shared_vertex_scenes(), cull=st.booleans())
def test_horizontal_edges_and_shared_vertices_equal_reference(scene, cull):
    v, f = scene
    depth, ids, stats = render_core(v, f, "scanline", cull)
    ref_depth, ref_ids, ref_stats = render_reference(v, f, cull)
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(depth, ref_depth)
    # Exact spans: the pixels covered are the reference's (which tests whole
    # boxes), and the scanline tests no pixel it does not cover.
    assert stats["pixels_covered"] == ref_stats["pixels_covered"]
    assert stats["pixels_tested"] == stats["pixels_covered"]
    assert stats["rasterized"] == ref_stats["rasterized"]


@SETTINGS
@given(scene=shared_vertex_scenes())
def test_scanline_equals_zbuffer_on_shared_vertex_scenes(scene):
    v, f = scene
    a = render_core(v, f, "scanline")
    b = render_core(v, f, "zbuffer")
    np.testing.assert_array_equal(a[1], b[1])
    np.testing.assert_array_equal(a[0], b[0])
    assert a[2]["pixels_covered"] == b[2]["pixels_covered"]


@pytest.mark.parametrize("ny", [1, 2, 7])
def test_slivers_thinner_than_a_pixel(ny):
    # Long triangles a fraction of a pixel tall, on and between rows of
    # centres, both windings: spans of 0 or 1 rows with long x ranges.
    tris = []
    for k in range(12):
        y = 3 * SUB + k * SUB // ny + k
        x0, x1 = k * 7, SIZE * SUB - k * 5
        h = 1 + (k * 37) % (SUB // 2)
        a, b, c = (x0, y, 0.25), (x1, y + h, -0.5), (x1 - 300, y + 2 * h, 0.5)
        tris.append((a, b, c) if k % 2 else (a, c, b))
    v = np.array([[grid_coord(x), grid_coord(y), z] for t in tris for x, y, z in t])
    f = np.arange(len(v), dtype=np.int32).reshape(-1, 3)
    depth, ids, stats = render_core(v, f, "scanline")
    ref_depth, ref_ids, ref_stats = render_reference(v, f)
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(depth, ref_depth)
    assert (ids >= 0).any()
    assert stats["pixels_tested"] == stats["pixels_covered"] == ref_stats["pixels_covered"]


def test_statistics_of_the_tables(procedural_scenes):
    mesh = procedural_scenes["soup"]
    w, h = 160, 120
    res = zbuffer.render(mesh, algo="scanline", width=w, height=h, shading="none")
    ref = zbuffer.render(mesh, algo="zbuffer", width=w, height=h, shading="none")
    s = res.stats
    assert s["pixels_covered"] == ref.stats["pixels_covered"]
    assert s["pixels_tested"] == s["pixels_covered"]
    assert 0 < s["polygons_inserted"] <= s["rasterized"]
    # Each inserted triangle has a left and a right edge at least, at most
    # three edges (a horizontal bottom edge on a row of centres counts too).
    assert 2 * s["polygons_inserted"] <= s["edges_inserted"] <= 3 * s["polygons_inserted"]
    assert s["scanline_rows"] == h
    assert 0 < s["active_polygons_mean"] <= s["active_polygons_max"] <= s["polygons_inserted"]
    assert 0 < s["active_edges_mean"] <= s["active_edges_max"] <= s["edges_inserted"]
    # A span per (triangle, row) crossed, at most: spans are never split.
    assert 0 < s["spans_drawn"] <= s["active_polygons_mean"] * s["scanline_rows"] + 1e-9
    assert s["pixels_written"] <= s["pixels_covered"]


@pytest.mark.parametrize("size", [(64, 48), (1000, 30), (33, 700)])
def test_depth_storage_is_one_row(procedural_scenes, size):
    w, h = size
    mesh = procedural_scenes["default"]
    scan = zbuffer.render(mesh, algo="scanline", width=w, height=h, shading="none")
    plain = zbuffer.render(mesh, algo="zbuffer", width=w, height=h, shading="none")
    assert scan.stats["depth_storage_bytes"] == 4 * w
    assert plain.stats["depth_storage_bytes"] == 4 * w * h
    np.testing.assert_array_equal(scan.triangle_id, plain.triangle_id)
    np.testing.assert_array_equal(scan.depth, plain.depth)


def test_meshes_beyond_the_scanline_limit_are_refused_before_preparing():
    # Its tables take up to ~550 bytes a triangle: more than 2**24 triangles
    # are refused, by the package before it prepares (sorts and copies) the
    # mesh, which a second render would do, and by the core.
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    F = np.tile(np.array([[0, 1, 2]], np.int32), (zbuffer._core.MAX_SCANLINE_TRIANGLES + 1, 1))
    mesh = zbuffer.Mesh(V, F)
    for _ in range(2):
        with pytest.raises(ValueError, match=r"algo='scanline' draws at most 2\*\*24 "
                                             r"\(16,777,216\) triangles"):
            zbuffer.render(mesh, algo="scanline", width=8, height=8)
    assert mesh._visit is None  # not prepared
