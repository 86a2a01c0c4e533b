"""Bad input gets a clear Python exception naming the problem, never a crash."""

import re
import struct

import numpy as np
import pytest

import zbuffer
from zbuffer import _core, scenes

TRI = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])

V, F = scenes.box()
CAM = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0))


@pytest.fixture(params=["compiled", "reference"])
def render(request):
    """zbuffer.render and zbuffer.reference.render refuse the same input."""
    if request.param == "compiled":
        return zbuffer.render
    return zbuffer.reference.render


@pytest.mark.parametrize("vertices, faces, error, match", [
    (np.zeros((4, 2)), [[0, 1, 2]], ValueError, r"vertices must have shape \(N, 3\)"),
    (np.zeros(12), [[0, 1, 2]], ValueError, r"vertices must have shape"),
    (np.array([["a", "b", "c"]]), [[0, 0, 0]], TypeError, "vertices must be numbers"),
    (V, F.astype(float), TypeError, "faces must be integer"),
    (V, F.astype(bool), TypeError, "faces must be integer"),
    # timedelta64, which numpy counts among its integers, is not a number here
    (V, F.astype("m8[D]"), TypeError, "faces must be integer"),
    (V.astype("m8[s]"), F, TypeError, "vertices must be numbers"),
    (V, F[:, :2], ValueError, r"faces must have shape \(M, 3\)"),
    (V, np.vstack([F, [[0, 1, 8]]]), ValueError, r"face 12 has vertex index 8, outside \[0, 8\)"),
    (V, np.vstack([F, [[0, -1, 2]]]), ValueError, r"face 12 has vertex index -1"),
    (np.vstack([V, [[np.nan, 0, 0]]]), F, ValueError, "vertex 8 has a NaN or infinite"),
    (np.vstack([V, [[0, np.inf, 0]]]), F, ValueError, "vertex 8 has a NaN or infinite"),
])
def test_bad_mesh_arrays(render, vertices, faces, error, match):
    with pytest.raises(error, match=match):
        render((vertices, faces), camera=CAM, width=16, height=16)


@pytest.mark.parametrize("where", ["first", "middle", "last"])
def test_compiled_core_checks_large_meshes_without_the_gil(where):
    # Over 65,536 indices, coordinates or face ids the checks run without
    # the GIL (render_common.h): the same errors, naming the same face or vertex.
    n = 70_000
    rng = np.random.default_rng(5)
    vertices = rng.random((n, 3))
    faces = rng.integers(0, n, (n, 3)).astype(np.int32)
    k = {"first": 0, "middle": n // 2, "last": n - 1}[where]
    mvp = CAM.resolve(vertices).mvp(16, 16)
    bad = faces.copy()
    bad[k, 2] = n
    with pytest.raises(ValueError, match=f"face {k} has vertex index {n}, outside"):
        _core.render(vertices, bad, mvp, 16, 16)
    ids = _core.render(vertices, faces, mvp, 16, 16)[1]
    shade_args = (np.zeros(4), np.zeros(3), 0.2, 0.8, np.zeros(3, np.uint8), np.ones(3, np.float32))
    with pytest.raises(ValueError, match=f"face {k} has vertex index {n}, outside"):
        _core.shade(ids, vertices, bad, mvp, *shade_args)
    nan = vertices.copy()
    nan[k, 1] = np.inf
    with pytest.raises(ValueError, match=f"vertex {k} has a NaN or infinite coordinate"):
        _core.render(nan, faces, mvp, 16, 16)
    ids = np.arange(n, dtype=np.int32)
    ids[k] = -7
    with pytest.raises(ValueError, match=f"face_ids must be >= 0, got -7 at {k}"):
        _core.render(vertices, faces, mvp, 16, 16, face_ids=ids)


def test_compiled_core_checks_on_its_own():
    # The private binding is safe to call directly: the same checks in C++.
    mvp = CAM.resolve(V).mvp(16, 16)
    bad = np.ascontiguousarray(np.vstack([F, [[0, 1, 99]]]), dtype=np.int32)
    with pytest.raises(ValueError, match="face 12 has vertex index 99"):
        _core.render(V, bad, mvp, 16, 16)
    nan = np.vstack([V, [[np.nan, 0, 0]]])
    with pytest.raises(ValueError, match="vertex 8 has a NaN"):
        _core.render(nan, F.astype(np.int32), mvp, 16, 16)
    with pytest.raises(TypeError, match="faces must have dtype int32, got int64"):
        _core.render(V, F.astype(np.int64), mvp, 16, 16)
    with pytest.raises(ValueError, match="C-contiguous"):
        _core.render(np.asfortranarray(V), F.astype(np.int32), mvp, 16, 16)
    with pytest.raises(ValueError, match="mvp must have shape"):
        _core.render(V, F.astype(np.int32), mvp[:3], 16, 16)
    with pytest.raises(ValueError, match="NaN or infinite entry"):
        _core.render(V, F.astype(np.int32), mvp * np.nan, 16, 16)
    with pytest.raises(ValueError, match="too large"):
        _core.render(V, F.astype(np.int32), mvp, 40000, 16)
    ids = _core.render(V, F.astype(np.int32), mvp, 16, 16)[1]
    shade_args = (np.zeros(4), np.zeros(3), 0.2, 0.8, np.zeros(3, np.uint8), np.ones(3, np.float32))
    _core.shade(ids, V, F.astype(np.int32), mvp, *shade_args)  # fine
    with pytest.raises(ValueError, match="NaN or infinite entry"):
        _core.shade(ids, V, F.astype(np.int32), mvp * np.nan, *shade_args)
    with pytest.raises(ValueError, match="face 12 has vertex index 99"):
        _core.shade(ids, V, bad, mvp, *shade_args)
    faces = F.astype(np.int32)
    start, centre = np.array([0, 6, 12], np.int32), np.zeros((2, 3))
    with pytest.raises(ValueError, match="give both cell_start and cell_centre"):
        _core.render(V, faces, mvp, 16, 16, "hiz", cell_start=start)
    with pytest.raises(ValueError, match="cell_start must run from 0 to the number of faces"):
        _core.render(V, faces, mvp, 16, 16, "hiz", cell_start=start[:2], cell_centre=centre[:1])
    with pytest.raises(ValueError, match="cell_start must increase, got 6 then 6 at 1"):
        _core.render(V, faces, mvp, 16, 16, "hiz", cell_start=np.array([0, 6, 6, 12], np.int32),
                     cell_centre=np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"one row per cell \(2\), got 3"):
        _core.render(V, faces, mvp, 16, 16, "hiz", cell_start=start, cell_centre=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="cell_centre must be finite"):
        _core.render(V, faces, mvp, 16, 16, "hiz", cell_start=start, cell_centre=centre + np.nan)
    shade = lambda ids: _core.shade(ids, V, F.astype(np.int32), np.eye(4), np.zeros(4),
                                    np.zeros(3), 0.2, 0.8, np.zeros(3, np.uint8),
                                    np.zeros(3, np.float32))
    # One bad id anywhere among good ones: one past the last face, below -1,
    # and the int32 extremes.
    for bad in [len(F), -2, np.iinfo(np.int32).min, np.iinfo(np.int32).max]:
        ids = np.full((5, 7), -1, np.int32)
        ids[1:3, 2:5] = len(F) - 1
        ids[4, 6] = bad
        with pytest.raises(ValueError, match="ids outside"):
            shade(ids)
        # A render's triangles_in vouches for its ids only where it is at
        # most the faces shaded (a Scene's tree over more faces than its
        # mesh has now: checked after all).
        with pytest.raises(ValueError, match="ids outside"):
            _core.shade(ids, V, F.astype(np.int32), np.eye(4), np.zeros(4), np.zeros(3), 0.2,
                        0.8, np.zeros(3, np.uint8), np.zeros(3, np.float32),
                        ids_below=len(F) + 1)
    ids[4, 6] = 0
    assert shade(ids).shape == (5, 7, 3)
    # Sides as render() limits them; an empty image shades to an empty one.
    with pytest.raises(ValueError, match="image 40000x1 is too large"):
        shade(np.full((1, 40000), -1, np.int32))
    assert shade(np.zeros((0, 7), np.int32)).shape == (0, 7, 3)


@pytest.mark.parametrize("width, height, error, match", [
    (0, 10, ValueError, "must be positive"),
    (10, -3, ValueError, "must be positive"),
    (40000, 10, ValueError, "too large"),
    (30000, 30000, ValueError, "too large"),
    (10.5, 10, TypeError, "width must be an int"),
    (10, "10", TypeError, "height must be an int"),
])
def test_bad_image_size(render, width, height, error, match):
    with pytest.raises(error, match=match):
        render((V, F), camera=CAM, width=width, height=height)


@pytest.mark.parametrize("kwargs, match", [
    (dict(eye=(0, 0, 0), target=(0, 0, 0)), "eye and target are the same"),
    (dict(eye=(0, 0, 3), target=(0, 0, 0), up=(0, 0, 1)), "up is parallel"),
    (dict(eye=(0, 0, 3), up=(0, 0, 0)), "up is the zero vector"),
    (dict(eye=(0, 0, 3), near=0.0), "near must be > 0"),
    (dict(eye=(0, 0, 3), near=1e-320), "near must be at least"),
    (dict(eye=(0, 0, 3), near=10**400, far=10**401), "near must be a finite number"),
    (dict(eye=(0, 0, 3), near=-1.0), "near must be > 0"),
    (dict(eye=(0, 0, 3), near=5.0, far=2.0), "near must be smaller than far"),
    (dict(eye=(0, 0, 3), near=2.0, far=2.0), "near must be smaller than far"),
    (dict(eye=(0, 0, 3), projection="orthographic", near=3.0, far=-1.0), "near must be smaller"),
    (dict(eye=(0, 0, 3), fov_y=0), r"fov_y must be in \(0, 180\)"),
    (dict(eye=(0, 0, 3), fov_y=180), r"fov_y must be in \(0, 180\)"),
    (dict(eye=(0, 0, np.nan)), "eye must be finite"),
    (dict(eye=(0, 0)), "eye must be 3 numbers"),
    (dict(eye=(0, 0, 3), projection="fisheye"), "unknown projection 'fisheye'; valid values"),
    (dict(eye=(0, 0, 3), projection="orthographic", ortho_height=0.0), "ortho_height must be positive"),
])
def test_degenerate_camera(kwargs, match):
    with pytest.raises(ValueError, match=match):
        zbuffer.Camera.look_at(**kwargs)


def test_unknown_algorithm_lists_the_valid_names():
    with pytest.raises(ValueError, match=r"unknown algorithm 'painter'; valid values are 'zbuffer'"):
        zbuffer.render((V, F), algo="painter")
    with pytest.raises(ValueError, match="unknown algorithm"):
        _core.render(V, F.astype(np.int32), np.eye(4), 8, 8, "painter")


def test_a_camera_in_algos_place_says_where_it_goes():
    # render(mesh, cam) -- Scene.render takes the camera first, render the algorithm
    cam = zbuffer.Camera.look_at(eye=(0, 0, 3), target=(0, 0, 0))
    with pytest.raises(TypeError, match=r"got a Camera: pass it as camera=\.\.\."):
        zbuffer.render((V, F), cam)
    with pytest.raises(TypeError, match=r"algo must be an algorithm name \(a str\), got int"):
        zbuffer.Scene((V, F)).render(cam, 3)


def test_bad_options(render):
    with pytest.raises(ValueError, match="unknown shading 'phong'"):
        render((V, F), shading="phong")
    with pytest.raises(TypeError, match="shading must be one of 'flat', 'smooth', 'none', got None"):
        render((V, F), shading=None)
    with pytest.raises(ValueError, match="light_dir must not be the zero vector"):
        render((V, F), light_dir=(0, 0, 0))
    with pytest.raises(ValueError, match="ambient must be a finite number"):
        render((V, F), ambient=-1)
    with pytest.raises(ValueError, match="background must be 3 numbers"):
        render((V, F), background=(1, 2))
    with pytest.raises(ValueError, match="integer color must lie in 0-255"):
        render((V, F), color=(300, 0, 0))
    with pytest.raises(TypeError, match="camera must be a zbuffer.Camera"):
        render((V, F), camera="front")
    # Colours' alpha is dropped, but checked like the rest (as integers' is).
    rgba = np.full((len(V), 4), 0.5)
    zbuffer.Mesh(V, F, vertex_colors=rgba)  # fine
    rgba[3, 3] = 7.0
    with pytest.raises(ValueError, match=r"float vertex_colors must lie in \[0, 1\]"):
        zbuffer.Mesh(V, F, vertex_colors=rgba)
    with pytest.raises(TypeError, match="vertex_colors must be integers"):
        zbuffer.Mesh(V, F, vertex_colors=np.zeros((len(V), 3), "m8[s]"))
    with pytest.raises(TypeError, match="cannot render a dict"):
        render({"vertices": V})


def test_empty_meshes_render_an_empty_image(render):
    for mesh in [(np.zeros((0, 3)), np.zeros((0, 3), int)), (V, np.zeros((0, 3), int)),
                 zbuffer.Mesh([], [])]:
        res = render(mesh, width=12, height=10)
        assert res.depth.shape == (10, 12)
        assert np.isinf(res.depth).all() and (res.triangle_id == -1).all()
        assert (res.image == 255).all()


def test_unreadable_and_malformed_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such mesh file"):
        zbuffer.load(tmp_path / "missing.obj")
    with pytest.raises(FileNotFoundError, match="no such mesh file"):
        zbuffer.render(str(tmp_path / "missing.obj"))
    bad = tmp_path / "bad.obj"
    bad.write_text("v 1 2\nf 1 2 3\n")
    with pytest.raises(ValueError, match="could not read a mesh from"):
        zbuffer.load(bad)
    unknown = tmp_path / "mesh.xyzzy"
    unknown.write_text("hello")
    with pytest.raises(ValueError, match="could not read a mesh from .*unknown file suffix "
                                         "'.xyzzy' \\(zbuffer reads .obj, .off and .ply"):
        zbuffer.load(unknown)
    # (the path as given: trimesh's message had it lower-cased)
    (tmp_path / "Mixed").mkdir()
    (tmp_path / "Mixed" / "Mesh").write_text("v 0 0 0\n")
    with pytest.raises(ValueError, match=r"from '.*/Mixed/Mesh': no file suffix"):
        zbuffer.load(tmp_path / "Mixed" / "Mesh")
    huge = tmp_path / "huge_index.obj"
    huge.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 100000000000000000000\n")
    with pytest.raises(ValueError, match="line 4: bad face record"):
        zbuffer.load(huge)
    # trimesh's failures named with their type (a fuzzing round: a broken
    # glTF's FileNotFoundError named a buffer, an AssertionError said nothing)
    broken = tmp_path / "broken.gltf"
    broken.write_text('{"asset":')
    with pytest.raises(ValueError, match=r"could not read a mesh from .*broken.gltf.: "
                                         r"trimesh's reader failed \(\w+"):
        zbuffer.load(broken)
    binary = tmp_path / "garbage.stl"
    binary.write_bytes(bytes(range(256)) * 3)
    with pytest.raises(ValueError, match=r"could not read a mesh from .*garbage.stl.: no vertices"):
        zbuffer.load(binary)


def ascii_ply(vertices: int, elements: bytes = b"", body: bytes = b"") -> bytes:
    """An ASCII PLY file: `vertices` float x, y, z vertices, then the header
    lines `elements` (other elements and their properties), then `body`."""
    return (b"ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
            b"property float z\n" % vertices + elements + b"end_header\n" + body)


@pytest.mark.parametrize("name, content", [
    ("empty.stl", b"solid empty\nendsolid empty\n"),
    ("empty_binary.stl", b"\0" * 84),
    ("empty.ply", ascii_ply(0, b"element face 0\nproperty list uchar int vertex_indices\n")),
    ("points.ply", ascii_ply(3, body=b"0 0 0\n1 0 0\n0 1 0\n")),
    ("empty.off", b"OFF\n0 0 0\n"),
    ("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\np 1 2 3\n"),
    ("empty_scene.obj", b"# Blender\nmtllib empty.mtl\no Empty\n"),
    ("bom.obj", b"\xef\xbb\xbf# nothing here\n"),
])
def test_files_that_say_they_hold_no_faces_render_empty(tmp_path, name, content):
    path = tmp_path / name
    path.write_bytes(content)
    res = zbuffer.render(path, width=8, height=6)
    assert len(zbuffer.load(path).faces) == 0
    assert (res.triangle_id == -1).all() and np.isinf(res.depth).all()


@pytest.mark.parametrize("name, content", [
    # A binary STL whose 80-byte header starts with "solid" (as many
    # exporters write it), cut short: its triangles do not come through.
    ("cut.stl", b"solid part".ljust(80) + struct.pack("<I", 2) + bytes(70)),
    ("garbage.stl", b"solid x\nthis is garbage\n"),
    ("counted.stl", bytes(80) + struct.pack("<I", 3)),
    # Faces stored as another element (old Stanford scans: tristrips).
    ("strips.ply", ascii_ply(3, b"element tristrips 1\nproperty list int int vertex_indices\n",
                             b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")),
    # ASCII PLY cut short (trimesh reads it as a smaller mesh), also after a BOM.
    ("cut_vertices.ply", ascii_ply(3, b"element face 1\nproperty list uchar int vertex_indices\n",
                                   b"0 0 0\n1 0 0\n")),
    ("cut_bom.ply", b"\xef\xbb\xbf" + ascii_ply(
        3, b"element face 2\nproperty list uchar int vertex_indices\n",
        b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")),
    ("cut_faces.ply", ascii_ply(3, b"element face 2\nproperty list uchar int vertex_indices\n",
                                b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")),
    ("notoff.off", b"NOTOFF\n0 0 0\n"),
    ("short.off", b"OFF\n0 0\n"),
    ("picture.obj", b"\x89PNG\r\n\x1a\nIHDR garbage\n"),
])
def test_files_whose_faces_do_not_come_through_are_refused(tmp_path, name, content):
    # trimesh (or the OBJ reader) finds nothing in them, yet nothing in the
    # file says it is empty: malformed, not an empty mesh.
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(ValueError, match="could not read a mesh from"):
        zbuffer.load(path)


def test_huge_coordinates_cannot_be_framed_automatically():
    huge = ([[0, 0, 0], [1e300, 0, 0], [0, 1e300, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="too large to frame automatically.*; pass a camera$"):
        zbuffer.render(huge, width=4, height=4)
    # A camera whose clip planes are left to be fitted: the message names
    # what to set (it said "pass a camera" to a call that passed one).
    for camera, unset in [(zbuffer.Camera.look_at((0, 0, 3)), "near and far"),
                          (zbuffer.Camera.look_at((0, 0, 3), near=0.1), "far instead of leaving it"),
                          (zbuffer.Camera.look_at((0, 0, 3), projection="orthographic"),
                           "near, far and ortho_height")]:
        with pytest.raises(ValueError, match=f"too large to frame .*; give the camera {unset}"):
            zbuffer.render(huge, camera=camera, width=4, height=4)
        with pytest.raises(ValueError, match=f"give the camera {unset}"):
            camera.resolve(zbuffer.Mesh(*huge))
    # Given them, it renders (faces whose clip coordinates overflow are
    # counted as invalid, as docs/api.md says).
    camera = zbuffer.Camera.look_at((0, 0, 3), near=0.1, far=10)
    assert zbuffer.render(huge, camera=camera, width=4, height=4).stats["triangles_in"] == 1


def test_tiny_clip_w_counts_as_behind_the_eye():
    # A projection with a subnormal near plane (Camera refuses it; a raw
    # matrix need not) puts a vertex just in front of the eye at w ~ 1e-315,
    # where 1 / w overflows. Below MIN_CLIP_W such a vertex counts as behind
    # the eye: C++ and reference agree, nothing crashes.
    n, f, t = 1e-320, 10.0, 1.0 / np.tan(np.radians(22.5))
    mvp = np.array([[t, 0, 0, 0], [0, t, 0, 0],
                    [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)], [0, 0, -1, 0]])
    points = np.array([[0, 0, -1e-315]] + [[0.4, -0.4 + 0.05 * k, -1] for k in range(17)]
                      + [[-0.5, -0.5, -2], [0.5, -0.5, -2], [0, 0.5, -2]])
    faces = np.array([[0, k, k + 1] for k in range(1, 17)] + [[18, 19, 20]], np.int32)
    depth, ids, stats = _core.render(points, faces, mvp, 64, 64)
    tris, ref_stats = zbuffer.reference.vertex_stage(points, faces, mvp, 64, 64)
    ref_depth, ref_ids, _ = zbuffer.reference.rasterize(tris, 64, 64)
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(depth, ref_depth)
    assert stats["clipped_away"] == 16 == ref_stats["clipped_away"]
    assert (ids == 16).any()  # the ordinary triangle behind them is drawn


def test_coordinates_that_overflow_the_transform_are_skipped():
    # Finite positions whose transform overflows to inf: the triangle is
    # dropped (counted), the others are drawn, C++ and reference agree.
    v = np.vstack([V, [[1e308, 1e308, 1e308]]])
    f = np.vstack([F, [[0, 1, 8]]])
    cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0), near=0.1, far=10)
    res = zbuffer.render((v, f), camera=cam, width=16, height=16, shading="none")
    ref = zbuffer.reference.render((v, f), camera=cam, width=16, height=16, shading="none")
    assert res.stats["culled_invalid"] == 1 == ref.stats["culled_invalid"]
    np.testing.assert_array_equal(res.triangle_id, ref.triangle_id)
    assert res.mask.any()


@pytest.mark.parametrize("call, error, message", [
    (lambda: zbuffer.Camera.fit(TRI, fov_y=0), ValueError, "fov_y must be in (0, 180)"),
    (lambda: zbuffer.Camera.fit(TRI, margin=0), ValueError, "margin must be positive"),
    (lambda: zbuffer.Camera.fit(TRI, margin=float("nan")), ValueError, "margin must be positive"),
    (lambda: zbuffer.Camera.fit(TRI, margin=-1), ValueError, "margin must be positive"),
    (lambda: zbuffer.Camera.fit(np.zeros(3)), ValueError, "vertices must have shape (N, 3)"),
    (lambda: zbuffer.Camera.look_at((0, 0, 1), near=1, far=2).mvp(10, 0), ValueError,
     "width and height must be positive"),
    (lambda: zbuffer.Camera.look_at((0, 0, 1), fov_y="x"), TypeError, "fov_y must be a number"),
    (lambda: zbuffer.Camera.fit(TRI, fov_y="45"), TypeError, "fov_y must be a number"),
    (lambda: zbuffer.Camera.fit(TRI, fov_y=180), ValueError, "fov_y must be in (0, 180)"),
    (lambda: zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, light_dir="abc"), TypeError,
     "light_dir must be 3 numbers"),
    (lambda: zbuffer.render((TRI * 1e-170, [[0, 1, 2]]), width=8, height=8), ValueError,
     "too small for double precision"),
    # Python ints beyond float range, bools as lengths, NaN vertices to frame
    (lambda: zbuffer.Camera.look_at((10**400, 0, 3)), ValueError, "eye must be finite"),
    (lambda: zbuffer.Camera.look_at((0, 0, 3), projection="orthographic", ortho_height=10**400),
     ValueError, "ortho_height must be positive and finite"),
    (lambda: zbuffer.Camera.look_at((0, 0, 3), projection="orthographic", ortho_height=True),
     TypeError, "ortho_height must be a number"),
    (lambda: zbuffer.Camera.fit(TRI, margin=10**400), ValueError, "margin must be positive"),
    (lambda: zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, light_dir=(10**400, 0, 0)),
     ValueError, "light_dir must be 3 finite numbers"),
    (lambda: zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, diffuse=10**400),
     ValueError, "diffuse must be a finite number"),
    (lambda: zbuffer.Camera.fit(np.array([[0, 0, 0], [np.nan, 0, 0], [1, 1, 1]])), ValueError,
     "vertex 1 has a NaN or infinite coordinate"),
])
def test_camera_and_light_arguments_are_checked(call, error, message):
    with pytest.raises(error, match=re.escape(message)):
        call()


def test_lengths_that_overflow_or_underflow_a_plain_norm_still_work():
    # np.linalg.norm of (1e200, 0, 0) is inf and of (1e-200, 0, 0) zero.
    far = zbuffer.Camera.look_at((1e200, 0, 0), (0, 0, 0))
    assert np.isfinite(far.view_matrix()).all()
    lit = {}
    for scale in (1.0, 1e200, 1e-200):
        res = zbuffer.render((TRI, [[0, 1, 2]]), width=16, height=16,
                             light_dir=(-scale, -scale, -scale))
        lit[scale] = res.image[res.mask].tolist()
    assert lit[1e200] == lit[1.0] == lit[1e-200]


def test_odd_inputs_get_clear_messages(tmp_path):
    with pytest.raises(TypeError, match="cull_backfaces must be a bool"):
        zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, cull_backfaces="no")
    with pytest.raises(TypeError, match="cull_backfaces must be a bool"):
        zbuffer.reference.render((TRI, [[0, 1, 2]]), width=8, height=8, cull_backfaces=1)
    with pytest.raises(TypeError, match="polygons must be a bool"):
        zbuffer.reference.render((TRI, [[0, 1, 2]]), width=8, height=8, polygons="no")
    with pytest.raises(TypeError, match="width must be an integer"):
        cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0))
        cam.resolve(zbuffer.Mesh(TRI, [[0, 1, 2]])).mvp(True, 1)
    for shading in ("none", "flat"):  # checked whether or not the frame is shaded
        for value in (True, "0.2", None, np.array(0.2), np.array([0.2, 0.3])):
            with pytest.raises(TypeError, match="ambient must be a number"):
                zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, shading=shading, ambient=value)
            with pytest.raises(TypeError, match="diffuse must be a number"):
                zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, shading=shading, diffuse=value)
        with pytest.raises(ValueError, match="diffuse must be a finite number >= 0"):
            zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, shading=shading, diffuse=-0.5)
        # beyond float32, the compiled passes' weights were inf: back-lit
        # pixels came out black (inf * 0), where the reference gave the ambient
        for name in ("ambient", "diffuse"):
            message = rf"{name} must be a finite number >= 0 \(at most 3.403e\+38\)"
            with pytest.raises(ValueError, match=message):
                zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, shading=shading,
                               **{name: 1e39})
    for light in ((True, False, True), [1, 2, "3"], "abc"):  # bools and strings are not numbers
        with pytest.raises(TypeError, match="light_dir must be 3 numbers"):
            zbuffer.render((TRI, [[0, 1, 2]]), width=8, height=8, light_dir=light)
    with pytest.raises(TypeError, match="eye must be 3 numbers, got 5"):
        zbuffer.Camera.look_at(5)
    for up in ((True, False, False), (0, True, 0), [0.5, np.True_, 0]):  # numpy: (0, 1, 0)
        with pytest.raises(TypeError, match="up must be 3 numbers"):
            zbuffer.Camera.look_at((0, 0, 3), up=up)
    for fit in (dict(aspect=5e-324), dict(fov_y=5.7e-322, aspect=0.1)):  # the angle underflows
        with pytest.raises(ValueError, match="the narrower field of view is 0"):
            zbuffer.Camera.fit(TRI, **fit)
    for name in ("aspect", "margin"):
        for value in ("1", np.array(1.5), True):
            with pytest.raises(TypeError, match=f"{name} must be a number"):
                zbuffer.Camera.fit(TRI, **{name: value})
    cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0))
    with pytest.raises(ValueError, match="width / height is too large"):
        cam.mvp(10**400, 1)
    for fov in (5e-324, 10**400, 180, 0, -1):  # (5e-324 degrees: 0 in radians)
        with pytest.raises(ValueError, match="fov_y must be in"):
            zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0), fov_y=fov)
        with pytest.raises(ValueError, match="fov_y must be in"):
            zbuffer.Camera.fit(TRI, fov_y=fov)
    with pytest.raises(ValueError, match="faces must be a rectangular array"):
        zbuffer.Mesh(TRI, [[0, 1, 2], [0, 1]])
    with pytest.raises(ValueError, match="is not a mesh file"):
        zbuffer.load(tmp_path)
    with pytest.raises(TypeError, match="merge_vertices must be a bool"):
        zbuffer.load(tmp_path / "any.ply", merge_vertices="no")
    from zbuffer.viz import most_culling_cells
    with pytest.raises(ValueError, match="n must be at least 0, got -1"):
        most_culling_cells(np.ones((2, 2), np.int64), -1)
    with pytest.raises(TypeError, match="n must be an integer, got 5.0"):
        most_culling_cells(np.ones((2, 2), np.int64), 5.0)
    with pytest.raises(TypeError, match=r"one level of RenderResult.culls \(res.culls\[k\]\)"):
        most_culling_cells([np.ones((2, 2), np.int64), np.ones((1, 1), np.int64)], 5)
    with pytest.raises(ValueError, match=r"one level's \(h, w\) array, got shape \(2, 2, 2\)"):
        most_culling_cells(np.ones((2, 2, 2), np.int64), 5)
    with pytest.raises(ValueError, match="n must be in 1 .. "):
        scenes.tessellated_square(0)
    with pytest.raises(ValueError, match="n_lat must be in 2 .. "):
        scenes.uv_sphere(n_lat=1)
    with pytest.raises(ValueError, match="needs a mesh with vertices"):
        scenes.instance_grid((np.zeros((0, 3)), np.zeros((0, 3), int)), (2, 2, 2))
    with pytest.raises(TypeError, match="n must be an integer"):
        scenes.tessellated_square(True)
    # Every count is checked and bounded, every size finite (a fuzzing round:
    # empty parts, numpy's messages, NaN vertices, and a loop without end).
    for make, match in [(lambda: scenes.torus(n_major=0), "n_major must be in 3 .. "),
                        (lambda: scenes.grid(n=(-1, 5)), r"n\[0\] must be in 1 .. "),
                        (lambda: scenes.random_soup(-5), "n must be in 1 .. "),
                        (lambda: scenes.fan(2), "n must be in 3 .. "),
                        (lambda: scenes.overlapping_boxes(10**9), "n must be in 1 .. 67108864"),
                        (lambda: scenes.tessellated_square(10**5), "would make 20,000,000,000 tri"),
                        (lambda: scenes.uv_sphere(radius=np.nan), "radius must be finite"),
                        (lambda: scenes.tessellated_square(4, jitter=np.nan), "jitter must be finite"),
                        (lambda: scenes.tessellated_square(4, jitter=0.5), r"jitter must be in \[0, 0.5\)"),
                        (lambda: scenes.box(center=(1, 2)), "center must be 3 numbers"),
                        (lambda: scenes.instance_grid(scenes.fan(), (1, 1, 2), spacing=np.inf),
                         "spacing must be finite")]:
        with pytest.raises(ValueError, match=match):
            make()
    with pytest.raises(TypeError, match="size must be 3 numbers, got 'a'"):
        scenes.box(size="a")
    # (as Camera's arguments: no bools, no timedelta64, no int beyond float)
    for make, error, match in [(lambda: scenes.uv_sphere(radius=True), TypeError,
                                "radius must be a number, got True"),
                               (lambda: scenes.box(center=(True, False, True)), TypeError,
                                "center must be 3 numbers"),
                               (lambda: scenes.fan(tilt=np.timedelta64(3)), TypeError,
                                "tilt must be a number"),
                               (lambda: scenes.uv_sphere(radius=10**400), ValueError,
                                "radius must be finite")]:
        with pytest.raises(error, match=match):
            make()
    with pytest.raises(TypeError, match="fov_y must be a number"):
        zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0), fov_y=np.timedelta64(45))
    # one number stands for a box's three
    np.testing.assert_array_equal(scenes.box(size=2.0)[0], scenes.box(size=(2, 2, 2))[0])
    with pytest.raises(TypeError, match="n must be 2 positive integers, got 5"):
        scenes.grid(n=5)
    # (numpy integers and 0-d integer arrays are integers)
    assert len(scenes.tessellated_square(np.array(2)).faces) == 8
    assert len(scenes.uv_sphere(n_lat=np.int64(2), n_lon=np.array(3))[1]) == 6
    assert most_culling_cells(np.ones((2, 2), np.int64), np.array(1)).shape == (1, 2)
    obj = tmp_path / "bom.obj"  # an OBJ file starting with a byte order mark
    obj.write_bytes("\ufeffv 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\n".encode("utf-8"))
    mesh = zbuffer.load(bytes(obj))
    np.testing.assert_array_equal(mesh.vertices[mesh.faces[0]], TRI)


def test_projection_matrix_checks_its_aspect():
    # It divided by it: ZeroDivisionError for 0, a mirrored matrix for -1.
    camera = zbuffer.Camera.look_at((0, 0, 3), near=1, far=10)
    for bad in (0, -1.0, float("inf")):
        with pytest.raises(ValueError, match="aspect must be positive and finite"):
            camera.projection_matrix(bad)
    with pytest.raises(TypeError, match="aspect"):
        camera.projection_matrix("1")


def test_combine_checks_each_part_as_a_mesh():
    # Float faces were truncated, and a part's faces could use the next
    # part's vertices.
    tri = np.eye(3)
    with pytest.raises(TypeError, match=r"parts\[0\]: faces must be integer"):
        scenes.combine([(tri, [[0, 1.7, 2]])])
    with pytest.raises(ValueError, match=r"parts\[0\]: face 0 has vertex index 4, outside \[0, 3\)"):
        scenes.combine([(tri, [[0, 1, 4]]), (tri, [[0, 1, 2]])])


def test_results_compare_as_objects_and_no_faces_may_be_a_float_array():
    # == on a result compared its arrays ("truth value ... is ambiguous").
    a = zbuffer.render(scenes.default_scene(), width=16, height=12)
    b = zbuffer.render(scenes.default_scene(), width=16, height=12)
    assert a == a and a != b and a in [b, a]
    assert len(zbuffer.Mesh(np.eye(3), np.zeros((0, 3))).faces) == 0  # as with []


def test_a_count_of_cells_to_outline_must_be_a_number():
    from zbuffer import viz

    with pytest.raises(TypeError, match="highlight_culls must be a bool or a count"):
        viz._highlight_count("yes")
    with pytest.raises(ValueError, match="highlight_culls must be a bool or a count"):
        viz._highlight_count(-1)


def test_default_camera_names_an_aspect_no_image_has():
    # 1e-300 failed deep inside with "eye must be finite, got (nan, nan, nan)".
    for bad in (1e-300, 40000.0, 0.0):
        with pytest.raises(ValueError, match=r"aspect must lie in \[1/32768, 32768\]"):
            scenes.default_camera(bad)
    with pytest.raises(TypeError, match="aspect"):
        scenes.default_camera("wide")
