"""Camera matrices follow the OpenGL conventions."""

import numpy as np
import pytest

import zbuffer
from zbuffer import scenes


def apply(m, p):
    h = m @ np.append(p, 1.0)
    return h[:3] / h[3]


def test_view_matrix_puts_the_eye_at_the_origin_looking_down_minus_z():
    cam = zbuffer.Camera.look_at((1, 2, 3), (4, 0, -1), up=(0, 1, 0))
    v = cam.view_matrix()
    np.testing.assert_allclose(apply(v, (1, 2, 3)), 0, atol=1e-12)
    target = apply(v, (4, 0, -1))
    assert target[2] < 0
    np.testing.assert_allclose(target[:2], 0, atol=1e-12)
    np.testing.assert_allclose(v[:3, :3] @ v[:3, :3].T, np.eye(3), atol=1e-12)  # rigid
    assert np.linalg.det(v[:3, :3]) > 0  # right-handed


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_projection_maps_near_and_far_to_minus_one_and_one(projection):
    cam = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), near=0.5, far=20.0,
                                 projection=projection, ortho_height=2.0)
    p = cam.projection_matrix(1.5)
    assert apply(p, (0, 0, -0.5))[2] == pytest.approx(-1.0)
    assert apply(p, (0, 0, -20.0))[2] == pytest.approx(1.0)
    if projection == "orthographic":
        assert apply(p, (1.5, 1.0, -3.0))[:2] == pytest.approx([1.0, 1.0])
    else:  # 45 degrees: the top of the frustum at distance d is at d tan(22.5)
        top = 4.0 * np.tan(np.radians(22.5))
        assert apply(p, (0, top, -4.0))[1] == pytest.approx(1.0)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("size", [(64, 48), (48, 64)])
def test_fit_frames_the_whole_mesh(projection, size):
    mesh = scenes.default_scene()
    w, h = size
    res = zbuffer.render(mesh, width=w, height=h, shading="none", camera=zbuffer.Camera.fit(
        mesh, direction=(1, 1, 1), projection=projection, aspect=w / h))
    assert res.mask.any()
    # Nothing touches the border: the bounding sphere fits inside the image.
    border = np.concatenate([res.mask[0], res.mask[-1], res.mask[:, 0], res.mask[:, -1]])
    assert not border.any()
    assert res.stats["clipped"] == 0 and res.stats["culled_frustum"] == 0


def test_resolve_fits_near_and_far_around_the_mesh():
    mesh = scenes.default_scene()
    cam = zbuffer.Camera.look_at((0, 0, 10), (0, 0, 0)).resolve(mesh)
    c, r = mesh.bounding_sphere
    assert 0 < cam.near <= 10 - c[2] - r
    assert cam.far >= 10 - c[2] + r
    inside = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1)).resolve(mesh)
    assert 0 < inside.near < inside.far
    fixed = zbuffer.Camera.look_at((0, 0, 10), near=1.0, far=2.0).resolve(mesh)
    assert (fixed.near, fixed.far) == (1.0, 2.0)


def test_default_camera_frames_the_mesh_from_plus_z():
    v, f = scenes.box((5, 5, 5), (1, 1, 1))
    res = zbuffer.render((v, f), width=32, height=32, shading="none")
    assert np.array_equal(res.camera.target, (5.0, 5.0, 5.0))
    assert res.camera.eye[2] > 5 and res.mask.any()


def test_eye_depth_is_the_distance_along_the_view_axis():
    v = np.array([[-1, -1, -4], [1, -1, -4], [0, 1, -4]], float)  # plane z = -4
    for projection in ["perspective", "orthographic"]:
        cam = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), near=0.5, far=10.0,
                                     projection=projection, ortho_height=4.0)
        res = zbuffer.render((v, [[0, 1, 2]]), camera=cam, width=32, height=32, shading="none")
        d = res.eye_depth()
        np.testing.assert_allclose(d[res.mask], 4.0, rtol=1e-5)
        assert np.isinf(d[~res.mask]).all()
    # far / near past 2^53: drawn pixels at depth 1.0 are at far, not +inf
    # (a fuzzing round: the old form cancelled to a division by 0)
    # (and near and far both tiny: near * far is subnormal)
    v = np.array([[-10, -10, -50], [10, -10, -50], [0, 10, -50]], float)
    for near, far, scale in ((1e-15, 100.0, 1.0), (1e-12, 100.0, 1.0), (1e-290, 1e-25, 1e-27),
                             (1e-290, 1e100, 1e-290 / 25)):
        cam = zbuffer.Camera.look_at((0, 0, 0), (0, 0, -1), near=near, far=far)
        res = zbuffer.render((v * scale, [[0, 1, 2]]), camera=cam, width=8, height=8,
                             shading="none")
        d = res.eye_depth()[res.mask]
        assert res.mask.any() and np.isfinite(d).all() and (d <= far).all()
        assert (d[res.depth[res.mask] == 1.0] == far).all()
        # (near / far subnormal: the distances, not 0 -- the triangle lies
        # 50 scale from the eye, so within float32 depth's precision of it)
        if far / near > 1e300:
            assert np.allclose(d, 50 * scale, rtol=1e-3)


def test_mesh_remembers_resolved_cameras_per_camera():
    mesh = scenes.default_scene()
    other = scenes.overlapping_boxes(3, seed=4)
    cams = [zbuffer.Camera.look_at(eye=(0.0, 1.0, z), target=(0, 0, 0)) for z in (3.0, 5.0)]
    first = mesh.resolved_camera(cams[0])
    assert first == cams[0].resolve(mesh) and first.near is not None
    # The same camera (an equal one too) gets the same resolved camera back;
    # another camera or another mesh gets its own.
    assert mesh.resolved_camera(zbuffer.Camera.look_at(eye=(0.0, 1.0, 3.0), target=(0, 0, 0))) \
        is first
    assert mesh.resolved_camera(cams[1]) == cams[1].resolve(mesh) != first
    assert other.resolved_camera(cams[0]) == cams[0].resolve(other) != first
    # Bounded: many cameras do not pile up.
    for k in range(200):
        mesh.resolved_camera(zbuffer.Camera.look_at(eye=(0.0, 1.0, 3.0 + k), target=(0, 0, 0)))
    assert len(mesh.__dict__["_resolved_cameras"]) <= 64


def test_mvp_takes_whole_image_sizes_only():
    # A fractional size would cache a matrix of its own aspect ratio under
    # the whole size (64.99 x 48 under 64 x 48) for every later render.
    cam = zbuffer.Camera.look_at((0, 0, 3), near=1, far=10)
    with pytest.raises(TypeError, match="width must be an integer, got 64.99"):
        cam.mvp(64.99, 48.0)
    with pytest.raises(TypeError, match="height must be an integer, got '48'"):
        cam.mvp(64, "48")
    expected = zbuffer.Camera.look_at((0, 0, 3), near=1, far=10).mvp(64, 48)
    np.testing.assert_array_equal(cam.mvp(np.int64(64), np.int32(48)), expected)
    np.testing.assert_array_equal(cam.mvp(64, 48), expected)


def test_meshes_too_small_to_frame_say_so():
    # Fitted clip planes beyond double precision's reach: the error names the
    # mesh and what to do, not a near plane the caller never gave.
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]) * 1e-300
    with pytest.raises(ValueError, match="cannot be framed automatically"):
        zbuffer.render((v, np.array([[0, 1, 2]])), width=8, height=8)
    # A plane the caller gave is the trouble, not the mesh: Camera's own message.
    with pytest.raises(ValueError, match="near must be at least 1e-290"):
        zbuffer.render((v * 1e300, np.array([[0, 1, 2]])), width=8, height=8,
                       camera=zbuffer.Camera.look_at((0, 0, 3), far=1e-290))
    ortho = zbuffer.Camera.fit(v, projection="orthographic")
    assert zbuffer.render((v, np.array([[0, 1, 2]])), camera=ortho, width=8, height=8,
                          shading="none").mask.any()


def test_bounding_sphere_is_its_whole_array_definition():
    # bounding_sphere works column by column for speed; it must give the
    # bits of the plain (N, 3) formulas, from tiny to huge coordinates.
    from zbuffer.camera import bounding_sphere

    rng = np.random.default_rng(5)
    for k in range(200):
        scale = 10.0 ** int(rng.integers(-280, 140))
        v = rng.normal(size=(int(rng.integers(1, 300)), 3)) * scale + rng.normal(size=3)
        lo, hi = v.min(axis=0), v.max(axis=0)
        center = lo * 0.5 + hi * 0.5
        offset = v - center
        s = float(np.abs(offset).max())
        radius = s * float(np.sqrt(((offset / s) ** 2).sum(axis=1).max())) if s > 0 else 0.0
        got_center, got_radius = bounding_sphere(v)
        np.testing.assert_array_equal(got_center, center)
        if radius == 0.0:
            radius = max(1e-6, float(np.abs(center).max()) * 1e-6)
        assert got_radius == radius


def test_framing_ignores_vertices_no_face_uses():
    # (OBJ files with stray v records are common: the object would shrink.)
    v, f = scenes.box()
    stray = np.vstack([v, [[100.0, 0, 0]]])
    a = zbuffer.render((v, f), width=32, height=24, shading="none")
    b = zbuffer.render((stray, f), width=32, height=24, shading="none")
    assert a.camera == b.camera
    np.testing.assert_array_equal(a.triangle_id, b.triangle_id)


def test_far_is_fitted_beyond_a_near_given_alone():
    v, f = scenes.box()
    cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0), near=10.0).resolve(zbuffer.Mesh(v, f))
    assert cam.near == 10.0 and cam.far > 10.0


def test_auto_camera_checks_its_aspect():
    # (a fuzzing round: a list met the cache's "unhashable type", True was 1)
    mesh = scenes.fan(8)
    assert mesh.auto_camera(1.5) == zbuffer.Camera.fit(mesh, aspect=1.5).resolve(mesh)
    for aspect, error, match in [([1.0], TypeError, "aspect must be a number"),
                                 (True, TypeError, "aspect must be a number, got True"),
                                 (0, ValueError, "aspect must be positive and finite")]:
        with pytest.raises(error, match=match):
            mesh.auto_camera(aspect)


def test_projection_matrices_near_float_limits():
    # 2 far near overflowed for far near float's largest, though the entry
    # itself, 2 near far / (far - near), is about 2 near: computed in another
    # order there, the camera renders (as the reference does).
    mesh = scenes.default_scene()
    cam = zbuffer.Camera.look_at((0, 0, 5), (0, 0, 0), near=1e-3, far=1e308)
    assert np.isfinite(cam.projection_matrix(4 / 3)).all()
    res = zbuffer.render(mesh, camera=cam, width=64, height=48, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=64, height=48, shading="none")
    assert (res.triangle_id >= 0).any()
    np.testing.assert_array_equal(res.depth, ref.depth)
    np.testing.assert_array_equal(res.triangle_id, ref.triangle_id)
    # An entry truly beyond float range names the camera's numbers.
    tiny = zbuffer.Camera.look_at((0, 0, 5), (0, 0, 0), projection="orthographic", near=1.0,
                                  far=10.0, ortho_height=1e-320)
    with pytest.raises(ValueError, match=r"beyond float range \(near=1.0, far=10.0, "
                                         r"ortho_height=1e-320"):
        zbuffer.render(mesh, camera=tiny, width=64, height=48)
