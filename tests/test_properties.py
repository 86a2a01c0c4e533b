"""Property tests on the fixed-point grid.

World coordinates are chosen so that an orthographic identity projection puts
every vertex exactly on a sub-pixel position: ties, edges through pixel
centres, horizontal and vertical edges and degenerate triangles come up often.
The compiled algorithms and the numpy reference are driven with the same
model-view-projection matrix, below the Camera layer.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from zbuffer import _core, reference
from zbuffer.scene import OCTREE_RULES
from helpers import ALGORITHMS, PYRAMID_ALGORITHMS, counters_add_up

SIZE = 16  # image is SIZE x SIZE pixels
SUB = 256  # sub-pixel steps per pixel
# Identity MVP: x_win = (x + 1) * SIZE/2, so x = k / (SIZE/2 * SUB) - 1 lands on
# fixed-point coordinate k exactly. z is kept in [-1, 1] on a coarse grid.
MVP = np.eye(4)


def grid_coord(k):
    return k / (SIZE / 2 * SUB) - 1.0


# Coordinates: mostly on pixel centres or whole/half pixels, sometimes anywhere
# on the sub-pixel grid, a little outside the image too.
coarse = st.integers(-2, 2 * SIZE + 2).map(lambda p: p * SUB // 2)
fine = st.integers(-SUB, (SIZE + 1) * SUB)
coord = st.one_of(coarse, coarse, fine)
depth = st.integers(-4, 4).map(lambda k: k / 4.0)
vertex = st.tuples(coord, coord, depth)
# Up to 40 triangles: the compiled core assembles and sets up faces 16 at a
# time with vector instructions and the remainder one by one; both must run.
triangles = st.lists(st.tuples(vertex, vertex, vertex), min_size=1, max_size=40)


def to_arrays(tris):
    v = np.array([[grid_coord(x), grid_coord(y), z] for t in tris for (x, y, z) in t],
                 dtype=np.float64).reshape(-1, 3)
    f = np.arange(len(v), dtype=np.int32).reshape(-1, 3)
    return v, f


def render_core(v, f, algo, cull=False):
    return _core.render(np.ascontiguousarray(v), np.ascontiguousarray(f, dtype=np.int32),
                        MVP, SIZE, SIZE, algo, cull)


def render_reference(v, f, cull=False):
    tris, stats = reference.vertex_stage(v, f, MVP, SIZE, SIZE, cull)
    depth, ids, pix = reference.rasterize(tris, SIZE, SIZE)
    stats.update(pix)
    return depth, ids, stats


PROPERTY_SETTINGS = settings(max_examples=150, deadline=None,
                             suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.parametrize("algo", ALGORITHMS)
@PROPERTY_SETTINGS
@given(tris=triangles, cull=st.booleans())
def test_equals_reference_on_grid(algo, tris, cull):
    v, f = to_arrays(tris)
    depth, ids, stats = render_core(v, f, algo, cull)
    ref_depth, ref_ids, ref_stats = render_reference(v, f, cull)
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(depth, ref_depth)
    assert counters_add_up(stats)
    assert stats["rasterized"] + stats["culled_hidden"] == ref_stats["rasterized"]


@pytest.mark.parametrize("algo", ALGORITHMS)
@PROPERTY_SETTINGS
@given(tris=triangles, data=st.data())
def test_permuting_triangles_changes_no_bit(algo, tris, data):
    v, f = to_arrays(tris)
    perm = np.array(data.draw(st.permutations(range(len(f)))), dtype=np.int64)
    depth, ids, _ = render_core(v, f, algo)
    depth_p, ids_p, _ = render_core(v, f[perm], algo)
    # Depth is a pure minimum: no visiting order changes it.
    np.testing.assert_array_equal(depth_p, depth)
    # Face k of the permuted mesh is face perm[k] of the original. Where the
    # nearest face is unique the same face wins; on an exact tie the smallest
    # id wins, and ids differ between the two numberings, so compare those
    # pixels with the order-free reference of the permuted mesh instead.
    _, ref_ids_p, _ = render_reference(v, f[perm])
    np.testing.assert_array_equal(ids_p, ref_ids_p)
    mapped = np.where(ids_p >= 0, perm[np.maximum(ids_p, 0)], -1)
    differs = mapped != ids
    if differs.any():
        # Only tie pixels may differ: there the original winner, drawn alone,
        # reaches the same depth.
        for j, i in zip(*np.nonzero(differs)):
            alone_depth, _, _ = render_core(v, f[[ids[j, i]]], algo)
            assert alone_depth[j, i] == depth[j, i]


@pytest.mark.parametrize("algo", ALGORITHMS)
@PROPERTY_SETTINGS
@given(tri=st.tuples(vertex, vertex, vertex), copies=st.integers(2, 4), data=st.data())
def test_exact_ties_go_to_smallest_id(algo, tri, copies, data):
    # Copies of one triangle, drawn in face order but with ids shuffled
    # (face k has id ids[k]): they cover the same pixels at the same depth,
    # and id 0 must win each of them whichever face is drawn first.
    v, f = to_arrays([tri] * copies)
    ids = np.array(data.draw(st.permutations(range(copies))), dtype=np.int32)
    assume(render_reference(v, f)[1].max() >= 0)  # (a triangle covering pixel centres)
    depth, got, stats = _core.render(np.ascontiguousarray(v), np.ascontiguousarray(f, np.int32),
                                     MVP, SIZE, SIZE, algo, False, ids)
    assert set(np.unique(got)) == {-1, 0} or set(np.unique(got)) == {0}
    assert stats["pixels_covered"] == copies * int((got == 0).sum())  # none culled: ties


@pytest.mark.parametrize("algo", ALGORITHMS)
@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 7), cuts=st.data())
def test_tessellated_square_covered_exactly_once(algo, n, cuts):
    # A square with corners on the sub-pixel grid, cut into a grid of
    # triangles at arbitrary sub-pixel positions, both diagonal directions.
    lo = cuts.draw(st.integers(-SUB, 4 * SUB))
    hi = cuts.draw(st.integers(lo + SUB, (SIZE + 1) * SUB))
    inner = sorted(cuts.draw(st.lists(st.integers(lo + 1, hi - 1), min_size=n - 1,
                                      max_size=n - 1, unique=True)))
    xs = [lo] + inner + [hi]
    ys = [lo] + sorted(cuts.draw(st.lists(st.integers(lo + 1, hi - 1), min_size=n - 1,
                                          max_size=n - 1, unique=True))) + [hi]
    flips = cuts.draw(st.lists(st.booleans(), min_size=n * n, max_size=n * n))
    tris = []
    for r in range(n):
        for c in range(n):
            a, b = (xs[c], ys[r], 0.0), (xs[c + 1], ys[r], 0.0)
            d, e = (xs[c], ys[r + 1], 0.0), (xs[c + 1], ys[r + 1], 0.0)
            tris += [(a, b, e), (a, e, d)] if flips[r * n + c] else [(a, b, d), (b, e, d)]
    v, f = to_arrays(tris)
    depth, ids, stats = render_core(v, f, algo)
    # Top-left rule: a centre on the square's left or top edge is inside, one
    # on its right or bottom edge is not. In x: lo <= c < hi.
    centres = np.arange(SIZE) * SUB + SUB // 2
    in_x = (centres >= lo) & (centres < hi)
    # Window y of grid value k is SIZE*SUB - k (NDC y up, rows down), so the
    # top edge is at SIZE*SUB - hi and the bottom one at SIZE*SUB - lo.
    in_y = (centres >= SIZE * SUB - hi) & (centres < SIZE * SUB - lo)
    inside = in_y[:, None] & in_x[None, :]
    np.testing.assert_array_equal(ids >= 0, inside)
    # Nothing covered twice (every algorithm draws every piece: at one depth
    # none is strictly behind another)
    assert stats["pixels_covered"] == int(inside.sum())


HIERARCHICAL = PYRAMID_ALGORITHMS
WALL_COPIES = 5  # of 512 triangles each: the pyramid holds the wall before the rest is tested


def wall(z):
    """512 triangles covering the image, corners on pixel corners, at NDC depth z."""
    n = 16
    k = np.arange(n + 1) * (SIZE * SUB // n)
    gx, gy = np.meshgrid(k, k)
    v = np.stack([grid_coord(gx.ravel()), grid_coord(gy.ravel()), np.full(gx.size, z)], 1)
    at = lambda i, j: i * (n + 1) + j  # noqa: E731
    f = [q for i in range(n) for j in range(n)
         for q in ([at(i, j), at(i, j + 1), at(i + 1, j + 1)],
                   [at(i, j), at(i + 1, j + 1), at(i + 1, j)])]
    return v, np.array(f, np.int32)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tris=triangles, wall_z=st.integers(-3, 3).map(lambda k: k / 4.0),
       seed=st.integers(0, 2**32 - 1))
def test_heavy_occlusion_and_exact_ties(tris, wall_z, seed):
    # A wall over the whole image, five times over (ties among its copies),
    # drawn first; then triangles in front of it, behind it and touching it
    # (depths on the same coarse grid: exact ties). Ids shuffled, so that
    # ties go either way. The hierarchical algorithms cull what is strictly
    # behind and nothing that wins a pixel.
    wv, wf = wall(wall_z)
    tv, tf = to_arrays(tris)
    v = np.vstack([wv, tv])
    v_faces = np.vstack([wf] * WALL_COPIES + [tf + len(wv)]).astype(np.int32)
    ids = np.random.default_rng(seed).permutation(len(v_faces)).astype(np.int32)
    by_id = np.empty_like(v_faces)
    by_id[ids] = v_faces
    ref_depth, ref_ids, _ = render_reference(v, by_id)
    behind = tf[(tv[:, 2].reshape(-1, 3) > wall_z).all(axis=1)] + len(wv)
    # (those covering a pixel centre: a box between centres is not tested)
    covering_behind = sum((render_reference(v, behind[[k]])[1] >= 0).any()
                          for k in range(len(behind)))
    for algo in HIERARCHICAL:
        depth, got, stats = _core.render(v, v_faces, MVP, SIZE, SIZE, algo, False, ids)
        np.testing.assert_array_equal(got, ref_ids, err_msg=algo)
        np.testing.assert_array_equal(depth, ref_depth, err_msg=algo)
        assert counters_add_up(stats)
        if algo == "hiz":  # (visited in the order given: the wall first)
            assert stats["culled_hidden"] >= covering_behind
    for tree in (*(_core.build_octree(v, by_id, 8, 10, rule) for rule in OCTREE_RULES),
                 _core.build_bvh(v, by_id, 8)):
        depth, got, stats = tree.render(MVP, SIZE, SIZE)
        np.testing.assert_array_equal(got, ref_ids)
        np.testing.assert_array_equal(depth, ref_depth)
        assert counters_add_up(stats)
