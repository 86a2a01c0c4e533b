"""Rendering into the caller's arrays (``out=``): the same bits as new arrays,
the same array objects back, and clear errors for arrays that cannot be
written into."""

import numpy as np
import pytest

import zbuffer
from zbuffer import _core, scenes

ALGOS = zbuffer.algorithms()
W, H = 96, 64


def mesh_and_camera():
    mesh = scenes.default_scene()
    return mesh, zbuffer.Camera.fit(mesh, aspect=W / H)


def stale(width=W, height=H):
    """Arrays holding values no render leaves (so that a pixel the render
    failed to write shows)."""
    return (np.full((height, width), 0.25, np.float32), np.full((height, width), 7, np.int32),
            np.full((height, width, 3), 9, np.uint8))


@pytest.mark.parametrize("algo", ALGOS)
@pytest.mark.parametrize("shading", ["none", "flat", "smooth"])
def test_rendering_into_arrays_gives_the_same_bits(algo, shading):
    mesh, cam = mesh_and_camera()
    fresh = zbuffer.render(mesh, algo, cam, W, H, shading=shading)
    depth, ids, image = stale()
    res = zbuffer.render(mesh, algo, cam, W, H, shading=shading, out=(depth, ids, image))
    assert res.depth is depth and res.triangle_id is ids
    np.testing.assert_array_equal(depth, fresh.depth)
    np.testing.assert_array_equal(ids, fresh.triangle_id)
    if shading == "none":
        assert res.image is None and (image == 9).all()  # not shaded, not touched
    else:
        assert res.image is image
        np.testing.assert_array_equal(image, fresh.image)


@pytest.mark.parametrize("algo", ALGOS)
def test_a_result_is_reused_frame_after_frame(algo):
    mesh, _ = mesh_and_camera()
    scene = zbuffer.Scene(mesh)
    cameras = [zbuffer.Camera.look_at((3 * np.sin(a), 0.5, 3 * np.cos(a)), (0, 0, 0), fov_y=40)
               for a in np.linspace(0, 2.5, 4)]
    res = first = None
    for cam in cameras:
        fresh = zbuffer.render(mesh, algo, cam, W, H)
        res = scene.render(cam, algo, W, H, out=res)
        first = res if first is None else first
        assert res.depth is first.depth and res.image is first.image
        np.testing.assert_array_equal(res.depth, fresh.depth)
        np.testing.assert_array_equal(res.triangle_id, fresh.triangle_id)
        np.testing.assert_array_equal(res.image, fresh.image)


def test_polygons_and_temporal_frames_render_into_arrays(tmp_path):
    # The scanline's native polygons (a concave pentagon), and a tree's
    # temporal frames.
    path = tmp_path / "concave.obj"
    path.write_text("v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 0.5 0\nv 0 2 0\nf 1 2 3 4 5\n")
    mesh = zbuffer.load(path)
    assert mesh.polygon_sizes is not None
    cam = zbuffer.Camera.fit(mesh, aspect=W / H)
    fresh = zbuffer.render(mesh, "scanline", cam, W, H, shading="none")
    depth, ids, _ = stale()
    zbuffer.render(mesh, "scanline", cam, W, H, shading="none", out=(depth, ids))
    np.testing.assert_array_equal(ids, fresh.triangle_id)

    grid = scenes.instance_grid(scenes.default_scene(), (2, 2, 3))
    scene = zbuffer.Scene(grid)
    cam = zbuffer.Camera.fit(grid, aspect=W / H)
    depth, ids, _ = stale()
    for _ in range(2):
        res = scene.render(cam, "hiz_octree", W, H, shading="none", temporal=True,
                           out=(depth, ids))
        np.testing.assert_array_equal(ids, zbuffer.reference.render(grid, cam, W, H).triangle_id)
        assert res.triangle_id is ids


def planes_sharing_cache_sets(width, height, apart):
    """A depth and an id plane in one block, the id plane starting `apart`
    bytes past a multiple of 4 KiB from the depth plane's start: at widths
    that are multiples of 1024 the core then draws the ids into a scratch
    plane of its own and copies them over (algorithms.h, PlacedIds)."""
    n = width * height * 4
    block = np.empty(2 * n + 3 * 4096, np.uint8)
    start = -block.ctypes.data % 4096
    ids_at = start + n + 4096 - n % 4096 + apart
    depth = block[start:start + n].view(np.float32).reshape(height, width)
    ids = block[ids_at:ids_at + n].view(np.int32).reshape(height, width)
    depth.fill(0.25)
    ids.fill(7)
    return depth, ids


def every_render(mesh, cam, w, h, shading):
    """Functions render(out) for every algorithm through zbuffer.render, the
    Scene's two trees, and two temporal frames of its octree."""
    scene = zbuffer.Scene(mesh)
    renders = [lambda out, a=a: zbuffer.render(mesh, a, cam, w, h, shading=shading, out=out)
               for a in ALGOS]
    renders += [lambda out, a=a: scene.render(cam, a, w, h, shading=shading, out=out)
                for a in ("hiz_octree", "hiz_bvh")]
    renders += [lambda out: scene.render(cam, "hiz_octree", w, h, shading=shading, out=out,
                                         temporal=True)] * 2
    return renders


@pytest.mark.parametrize("apart", [0, 64, 4032, 2048])
def test_planes_sharing_cache_sets_get_the_same_bits(apart):
    # Every algorithm, the Scene's trees (temporal frames too), each into
    # planes whose rows share L1 cache sets (apart 0, 64, 4032) and into
    # planes that do not.
    mesh = scenes.instance_grid(scenes.default_scene(), (2, 2, 2))
    w, h = 1024, 40
    cam = zbuffer.Camera.fit(mesh, aspect=w / h)
    ref = zbuffer.reference.render(mesh, cam, w, h)
    for render in every_render(mesh, cam, w, h, "none"):
        depth, ids = planes_sharing_cache_sets(w, h, apart)
        res = render((depth, ids))
        assert res.depth is depth and res.triangle_id is ids
        np.testing.assert_array_equal(depth, ref.depth)
        np.testing.assert_array_equal(ids, ref.triangle_id)


@pytest.mark.parametrize("w", [1024, 1536, 1000, 512])
def test_planes_are_padded_where_rows_would_alias(w):
    # At widths that are multiples of 512 from 1024 up the planes' rows are
    # 16 pixels longer than the image (types.h, padded_pitch); every
    # algorithm's pixels, the shading and the pyramid are those of
    # contiguous planes.
    mesh = scenes.instance_grid(scenes.default_scene(), (2, 2, 2))
    h = 24
    cam = zbuffer.Camera.fit(mesh, aspect=w / h)
    ref = zbuffer.reference.render(mesh, cam, w, h)
    pitch = w + 16 if w >= 1024 and w % 512 == 0 else w
    for algo in ALGOS:
        for shading in ("none", "flat", "smooth"):
            res = zbuffer.render(mesh, algo, cam, w, h, shading=shading)
            assert res.depth.strides == res.triangle_id.strides == (4 * pitch, 4)
            np.testing.assert_array_equal(res.depth, ref.depth)
            np.testing.assert_array_equal(res.triangle_id, ref.triangle_id)
            if shading != "none":
                depth, ids, image = stale(w, h)
                flat = zbuffer.render(mesh, algo, cam, w, h, shading=shading,
                                      out=(depth, ids, image))
                np.testing.assert_array_equal(res.image, flat.image)
    padded = zbuffer.render(mesh, "hiz", cam, w, h, shading="none")
    levels = padded.pyramid()
    assert levels[0] is padded.depth
    theirs = _core.pyramid_levels(np.ascontiguousarray(padded.depth))
    assert len(levels) == len(theirs)
    for mine, other in zip(levels, theirs):
        np.testing.assert_array_equal(mine, other)


def test_shading_reads_the_rows_of_padded_ids_only():
    # The binding's id check and the pass read a row's pixels, not the
    # padding between rows (here holding ids no face has).
    mesh = scenes.default_scene()
    w, h = 1024, 8
    res = zbuffer.render(mesh, "zbuffer", None, w, h, shading="none")
    big = np.full((h, w + 16), 10**6, np.int32)
    ids = big[:, :w]
    ids[:] = res.triangle_id
    args = (mesh.vertices, mesh.faces, res.mvp, np.array([0.0, 0.0, 1.0, 0.0]),
            np.array([0.0, 0.0, -1.0]), 0.2, 0.8, np.array([255, 255, 255], np.uint8),
            np.array([0.8, 0.8, 0.8], np.float32))
    image = _core.shade(ids, *args)
    np.testing.assert_array_equal(image, _core.shade(np.ascontiguousarray(ids), *args))
    ids[3, 5] = 10**6
    with pytest.raises(ValueError, match="ids outside"):
        _core.shade(ids, *args)


def test_rendering_into_views_with_padded_rows():
    # Views of wider arrays (rows 37 pixels longer than the image, not a
    # multiple of 16): the same bits, and not a pixel of the rest of the
    # arrays written.
    mesh = scenes.instance_grid(scenes.default_scene(), (2, 2, 2))
    w, h, extra = 1024, 24, 37
    cam = zbuffer.Camera.fit(mesh, aspect=w / h)
    ref = zbuffer.reference.render(mesh, cam, w, h)
    fresh = zbuffer.render(mesh, "zbuffer", cam, w, h, shading="flat")
    for render in every_render(mesh, cam, w, h, "flat"):
        big_depth = np.full((h, w + extra), 0.25, np.float32)
        big_ids = np.full((h, w + extra), 7, np.int32)
        image = np.full((h, w, 3), 9, np.uint8)
        depth, ids = big_depth[:, :w], big_ids[:, :w]
        res = render((depth, ids, image))
        assert res.depth is depth and res.triangle_id is ids
        np.testing.assert_array_equal(depth, ref.depth)
        np.testing.assert_array_equal(ids, ref.triangle_id)
        np.testing.assert_array_equal(image, fresh.image)
        assert (big_depth[:, w:] == 0.25).all() and (big_ids[:, w:] == 7).all()


def test_arrays_that_cannot_be_rendered_into_are_refused():
    mesh, cam = mesh_and_camera()
    depth, ids, image = stale()
    render = lambda out, **kw: zbuffer.render(mesh, "zbuffer", cam, W, H, out=out, **kw)
    with pytest.raises(TypeError, match="RenderResult or a tuple"):
        render([depth, ids])
    with pytest.raises(TypeError, match="RenderResult or a tuple"):
        render((depth,))
    with pytest.raises(TypeError, match="depth must be a numpy array"):
        render((depth.tolist(), ids))
    with pytest.raises(TypeError, match="depth must have dtype float32"):
        render((depth.astype(np.float64), ids))
    with pytest.raises(TypeError, match="triangle_id must have dtype int32"):
        render((depth, ids.astype(np.int64)))
    with pytest.raises(ValueError, match=r"depth has shape \(64, 95\)"):
        render((depth[:, 1:].copy(), ids))
    with pytest.raises(ValueError, match="image has shape"):
        render((depth, ids, image[..., :2].copy()))
    with pytest.raises(ValueError, match="C-contiguous or have contiguous, padded rows"):
        render((np.asfortranarray(depth), ids))
    wide = np.zeros((H, 2 * W), np.float32)
    with pytest.raises(ValueError, match="C-contiguous or have contiguous, padded rows"):
        render((wide[:, ::2], ids))  # pixels of a row not adjacent
    with pytest.raises(ValueError, match="image must be C-contiguous$"):
        render((depth, ids, np.zeros((H, 2 * W, 3), np.uint8)[:, :W]))
    with pytest.raises(ValueError, match="rows the same number of pixels apart, got 192 and 96"):
        render((wide[:, :W], ids))
    frozen = depth.copy()
    frozen.flags.writeable = False
    with pytest.raises(ValueError, match="writeable"):
        render((frozen, ids))
    with pytest.raises(ValueError, match="share memory"):
        render((depth, depth.view(np.int32)))
    # A result of another size
    small = zbuffer.render(mesh, "zbuffer", cam, W // 2, H // 2)
    with pytest.raises(ValueError, match="this render needs"):
        render(small)
    # Nothing was written by the refused calls.
    assert (depth == 0.25).all() and (ids == 7).all() and (image == 9).all()


def test_arrays_sharing_memory_with_the_mesh_are_refused():
    # The core reads the faces while it writes the ids: an id plane over the
    # faces' memory would feed it its own output.
    block = np.zeros(H * W + 3 * 2, np.int32)
    faces = block[:6].reshape(2, 3)
    faces[:] = [[0, 1, 2], [0, 2, 3]]
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    ids = block[: H * W].reshape(H, W)
    with pytest.raises(ValueError, match="out_ids shares memory with faces"):
        zbuffer._core.render(verts, faces, np.eye(4), W, H, out_depth=np.zeros((H, W), np.float32),
                             out_ids=ids)
    with pytest.raises(ValueError, match="give both out_depth and out_ids"):
        zbuffer._core.render(verts, faces, np.eye(4), W, H,
                             out_depth=np.zeros((H, W), np.float32))
    plane = np.zeros(4 * H * W, np.uint8)
    tid = plane.view(np.int32).reshape(H, W)
    with pytest.raises(ValueError, match="out shares memory with triangle_id"):
        zbuffer._core.shade(tid, verts, faces, np.eye(4), np.array([0, 0, 1, 0.0]),
                            np.array([0, 0, -1.0]), 0.2, 0.8, np.zeros(3, np.uint8),
                            np.ones(3, np.float32), out=plane[: 3 * H * W].reshape(H, W, 3))


def test_arrays_sharing_memory_with_the_mesh_object_are_refused():
    # The core may get copies (a prepared mesh's renumbered vertices, a
    # Scene's tree) while the shading pass reads the Mesh's own arrays,
    # which may be the caller's (float64 vertices and float32 colours are
    # kept without a copy): those are checked in Python, before any write.
    base = scenes.default_scene()
    n = len(base.vertices)
    block = np.zeros(3 * n + W * H, np.float64)
    block[: 3 * n] = base.vertices.ravel()
    mesh = zbuffer.Mesh(block[: 3 * n].reshape(n, 3), base.faces).prepare()
    over_vertices = block.view(np.float32)[: W * H].reshape(H, W)
    colours = np.full(3 * n + W * H, 0.5, np.float32)
    coloured = zbuffer.Mesh(base.vertices, base.faces, vertex_colors=colours[: 3 * n].reshape(n, 3))
    over_colours = colours[: W * H].reshape(H, W)
    ids = np.empty((H, W), np.int32)
    with pytest.raises(ValueError, match="depth shares memory with the mesh's vertices"):
        zbuffer.render(mesh, width=W, height=H, out=(over_vertices, ids))
    with pytest.raises(ValueError, match="depth shares memory with the mesh's vertices"):
        zbuffer.Scene(mesh).render(None, "hiz_bvh", W, H, out=(over_vertices, ids))
    with pytest.raises(ValueError, match="depth shares memory with the mesh's vertex_colors"):
        zbuffer.render(coloured, width=W, height=H, out=(over_colours, ids))
    np.testing.assert_array_equal(mesh.vertices, base.vertices)  # nothing written
    assert (colours == 0.5).all()


def test_interleaved_views_of_one_array_are_not_sharing_memory():
    # The left and right halves of one wider array have no element in
    # common (docs/api.md: views big[:, :W] of wider arrays): taken as
    # depth and ids of one render, or by two renders at once (a fuzzer's
    # find: both were refused as "sharing memory").
    mesh, cam = mesh_and_camera()
    fresh = zbuffer.render(mesh, camera=cam, width=W, height=H, shading="none")
    big = np.full((H, 2 * W), 0.5, np.float32)
    depth, ids = big[:, :W], big[:, W:].view(np.int32)
    res = zbuffer.render(mesh, camera=cam, width=W, height=H, shading="none", out=(depth, ids))
    np.testing.assert_array_equal(res.depth, fresh.depth)
    np.testing.assert_array_equal(res.triangle_id, fresh.triangle_id)
    assert res.depth.base is not None and np.shares_memory(res.depth, big)
    other = np.empty((H, 2 * W), np.int32)
    with zbuffer.api.claimed((big[:, :W], other[:, :W], None)):  # another render's halves
        again = zbuffer.render(mesh, camera=cam, width=W, height=H, shading="none",
                               out=(big[:, W:], other[:, W:]))
        np.testing.assert_array_equal(again.depth, fresh.depth)
        with pytest.raises(ValueError, match="another render is writing into these arrays"):
            zbuffer.render(mesh, camera=cam, width=W, height=H, shading="none",
                           out=(big[:, 1:W + 1], other[:, W:]))
    # The core's own check (the binding's), exact for planes with padded
    # rows: apart where no row of one meets a row of the other, whatever
    # their byte ranges.
    v = np.array([[0.0, 0, -2], [1, 0, -2], [0, 1, -2]])
    f = np.array([[0, 1, 2]], np.int32)
    mvp = np.eye(4)
    wide = np.zeros((H + 2, 3 * W), np.float32)
    # Rows W wide, 3 W apart, from element `at` of `wide`'s memory on.
    rows_from = lambda at: np.lib.stride_tricks.as_strided(  # noqa: E731
        wide.reshape(-1)[at:], (H, W), wide.strides)
    for depth, ids, apart in [
            (wide[:H, :W], wide[:H, W:2 * W], True),                # side by side
            (wide[:H, W:2 * W], wide[1:H + 1, :W], True),           # a row down, to the left
            (wide[:H, :W], wide[:H, W - 1:2 * W - 1], False),       # one column in common
            (wide[1:H + 1, :W], wide[:H, 2 * W:], True),            # row r's end, row r+1's start
            (wide[1:H + 1, :W], rows_from(2 * W + 1), False),       # ... one element past it
            (rows_from(2 * W + 1), wide[1:H + 1, :W], False)]:      # the same, the other way
        ids = ids.view(np.int32)
        assert np.shares_memory(depth, ids) == (not apart)
        if apart:
            _core.render(v, f, mvp, W, H, out_depth=depth, out_ids=ids)
        else:
            with pytest.raises(ValueError, match="out_depth shares memory with out_ids"):
                _core.render(v, f, mvp, W, H, out_depth=depth, out_ids=ids)


def test_arrays_another_render_is_writing_into_are_refused():
    # Two renders into one set of arrays at once: the second's shading would
    # read ids the first is writing (another mesh's, perhaps beyond its own
    # faces). The claim a render holds on its arrays makes the second fail.
    mesh, cam = mesh_and_camera()
    depth, ids, image = stale()
    with zbuffer.api.claimed((depth, ids, None)):
        with pytest.raises(ValueError, match="another render is writing into these arrays"):
            zbuffer.render(mesh, camera=cam, width=W, height=H, out=(depth, ids, image))
        with pytest.raises(ValueError, match="another render is writing into these arrays"):
            zbuffer.Scene(mesh).render(cam, "hiz_bvh", W, H, out=(depth[:, :],
                                                                  np.empty((H, W), np.int32)))
        zbuffer.render(mesh, camera=cam, width=W, height=H)  # new arrays: no conflict
    # Released after each render, refused or not, also one that fails after
    # claiming them: the arrays render again.
    with pytest.raises(TypeError, match="record_culls must be a bool"):
        zbuffer.render(mesh, camera=cam, width=W, height=H, out=(depth, ids), record_culls="x")
    with pytest.raises(ValueError, match="has no Z-pyramid"):  # raised by the core
        zbuffer.Scene(mesh).render(cam, "zbuffer", W, H, out=(depth, ids), record_culls=True)
    assert not zbuffer.api._CLAIMED
    zbuffer.render(mesh, camera=cam, width=W, height=H, out=(depth, ids, image))
    assert not zbuffer.api._CLAIMED
    # Threads rendering into arrays of their own run side by side.
    from helpers import run_in_threads

    def work():
        own = stale()
        for _ in range(5):
            zbuffer.render(mesh, camera=cam, width=W, height=H, out=own)

    errors = run_in_threads(work)
    assert not errors
