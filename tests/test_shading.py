"""The shading pass: the Lambert formula, colours, and the numpy twin."""

import math

import numpy as np
import pytest

import zbuffer
from zbuffer import scenes


def square(z=0.0):
    v = np.array([[-1, -1, z], [1, -1, z], [1, 1, z], [-1, 1, z]], float)
    return v, np.array([[0, 1, 2], [0, 2, 3]])


@pytest.mark.parametrize("angle", [0.0, 30.0, 60.0, 89.0])
@pytest.mark.parametrize("shading", ["flat", "smooth"])
def test_flat_face_has_the_lambert_colour(angle, shading):
    # Square facing +z, seen from +z; light tilted by `angle` from the normal.
    v, f = square()
    cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0), fov_y=30)
    a = math.radians(angle)
    light = (math.sin(a), 0.0, -math.cos(a))  # direction the light travels
    ambient, diffuse, albedo = 0.15, 0.7, (0.9, 0.5, 0.2)
    res = zbuffer.render((v, f), camera=cam, width=40, height=40, shading=shading,
                         light_dir=light, ambient=ambient, diffuse=diffuse, color=albedo)
    intensity = ambient + diffuse * math.cos(a)
    expected = [math.floor(min(1.0, c * intensity) * 255.0 + 0.5) for c in np.float32(albedo)]
    centre = res.image[20, 20]
    assert list(centre) == expected
    assert (res.image[res.mask] == centre).all()  # a flat face is one colour


def test_back_faces_are_lit_from_the_viewers_side():
    v, f = square()
    f = f[:, ::-1]  # wound clockwise: we see the back
    cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0), fov_y=30)
    res = zbuffer.render((v, f), camera=cam, width=20, height=20, ambient=0.0, diffuse=1.0,
                         color=(1.0, 1.0, 1.0))
    assert (res.image[10, 10] == 255).all()


def test_background_and_no_image_for_shading_none():
    v, f = square()
    cam = zbuffer.Camera.look_at((0, 0, 30), (0, 0, 0), fov_y=10)
    res = zbuffer.render((v, f), camera=cam, width=50, height=50, background=(10, 20, 30))
    assert (res.image[0, 0] == [10, 20, 30]).all()
    assert zbuffer.render((v, f), width=8, height=8, shading="none").image is None


def test_face_and_vertex_colours_are_used():
    v, f = square()
    cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0), fov_y=30)
    face = zbuffer.Mesh(v, f, face_colors=[[255, 0, 0], [0, 0, 255]])
    res = zbuffer.render(face, camera=cam, width=40, height=40, ambient=1.0, diffuse=0.0)
    colours = {tuple(c) for c in res.image[res.mask]}
    assert colours == {(255, 0, 0), (0, 0, 255)}
    vert = zbuffer.Mesh(v, f, vertex_colors=[[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [1.0, 1.0, 1.0]])
    res = zbuffer.render(vert, camera=cam, width=40, height=40, ambient=1.0, diffuse=0.0)
    assert len({tuple(c) for c in res.image[res.mask]}) > 100  # interpolated


def test_vertex_colours_are_interpolated_perspective_correctly():
    # Red grows linearly with world x across a square seen at a steep angle:
    # each pixel's red must match the x where its view ray meets the plane.
    v, f = square()
    red = (v[:, 0] + 1.0) / 2.0
    mesh = zbuffer.Mesh(v, f, vertex_colors=np.stack([red, 0 * red, 0 * red], 1))
    cam = zbuffer.Camera.look_at((2.5, 0.4, 1.2), (0, 0, 0), fov_y=60)
    w = h = 48
    res = zbuffer.render(mesh, camera=cam, width=w, height=h, ambient=1.0, diffuse=0.0)
    inv = np.linalg.inv(res.mvp)
    checked = 0
    for j, i in zip(*np.nonzero(res.mask)):
        ndc = [(i + 0.5) / w * 2 - 1, 1 - (j + 0.5) / h * 2]
        a = inv @ [*ndc, -1, 1]
        b = inv @ [*ndc, 1, 1]
        a, b = a[:3] / a[3], b[:3] / b[3]
        t = a[2] / (a[2] - b[2])
        x = a[0] + t * (b[0] - a[0])
        expected = math.floor(min(1.0, max(0.0, (x + 1) / 2)) * 255 + 0.5)
        assert abs(int(res.image[j, i, 0]) - expected) <= 1
        checked += 1
    assert checked > 300
    # Affine (screen-space) interpolation would be off by far more somewhere.


@pytest.mark.parametrize("shading", ["flat", "smooth"])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_compiled_shading_matches_numpy_shading(shading, projection):
    mesh = scenes.default_scene()
    cam = zbuffer.Camera.fit(mesh, direction=(0.4, 0.6, 1.0), aspect=4 / 3,
                             projection=projection)
    res = zbuffer.render(mesh, camera=cam, width=80, height=60, shading=shading)
    ref = zbuffer.reference.render(mesh, camera=cam, width=80, height=60, shading=shading)
    diff = np.abs(res.image.astype(int) - ref.image.astype(int))
    assert diff.max() <= 1


@pytest.mark.parametrize("source", ["uniform", "vertex", "face"])
@pytest.mark.parametrize("shading", ["flat", "smooth"])
def test_compiled_shading_matches_numpy_from_inside_a_closed_mesh(source, shading):
    # Every face seen from behind, faces reaching behind the camera, and
    # (at 64 x 48, with 1,280 faces) the faces found in the image rather
    # than all of them.
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=3)
    rng = np.random.default_rng(7)
    colours = {"vertex": {"vertex_colors": rng.random((len(sphere.vertices), 3))},
               "face": {"face_colors": rng.random((len(sphere.faces), 3))}}
    mesh = zbuffer.Mesh(sphere.vertices, sphere.faces, **colours.get(source, {}))
    for size in [(64, 48), (160, 120)]:
        cam = zbuffer.Camera.look_at((0.1, 0.2, 0.3), (0.5, -0.2, -1.0), fov_y=80,
                                     near=0.01, far=3.0)
        res = zbuffer.render(mesh, camera=cam, width=size[0], height=size[1], shading=shading)
        ref = zbuffer.reference.render(mesh, camera=cam, width=size[0], height=size[1],
                                       shading=shading)
        assert res.mask.all()
        assert np.abs(res.image.astype(int) - ref.image.astype(int)).max() <= 1


@pytest.mark.parametrize("source", ["uniform", "vertex", "face"])
@pytest.mark.parametrize("shading", ["flat", "smooth"])
def test_a_prepared_mesh_shades_to_the_same_bits(source, shading):
    # Once prepared, a mesh is shaded from its renumbered vertices (with
    # their normals and colours) and its faces renumbered to them
    # (Mesh.for_shading): the same image as from its own arrays. Faces and
    # vertices shuffled, so that the renumbering moves nearly everything.
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=4)  # 5,120 faces
    rng = np.random.default_rng(3)
    shuffle = rng.permutation(len(sphere.vertices))
    vertices = sphere.vertices[shuffle] * [1.0, 0.7, 1.3]
    faces = np.argsort(shuffle)[sphere.faces][rng.permutation(len(sphere.faces))]
    colours = {"vertex": {"vertex_colors": rng.random((len(vertices), 3))},
               "face": {"face_colors": rng.random((len(faces), 3))}}
    prepared = zbuffer.Mesh(vertices, faces, **colours.get(source, {})).prepare()
    shaded = prepared.for_shading(normals=True, vertex_colors=source == "vertex")
    assert shaded[0] is not prepared.vertices and not np.array_equal(shaded[1], prepared.faces)
    for size in [(64, 48), (200, 150)]:  # faces found in the image, and all of them
        own = zbuffer.Mesh(vertices, faces, **colours.get(source, {}))  # first render: unprepared
        cam = zbuffer.Camera.fit(own, direction=(0.3, 0.5, 1.0), aspect=4 / 3)
        a = zbuffer.render(own, camera=cam, width=size[0], height=size[1], shading=shading)
        b = zbuffer.render(prepared, camera=cam, width=size[0], height=size[1], shading=shading)
        np.testing.assert_array_equal(a.triangle_id, b.triangle_id)
        np.testing.assert_array_equal(a.image, b.image)


def test_vertex_normals_are_the_numpy_definitions_bits():
    # Mesh.vertex_normals (compiled) against reference.vertex_normals
    # (numpy): random meshes of every scale, faces repeating a corner,
    # unused vertices, no faces, and (when present) every shared model.
    from zbuffer import _core, reference

    rng = np.random.default_rng(11)
    meshes = []
    for k in range(60):
        n = int(rng.integers(1, 40))
        v = rng.normal(size=(n, 3)) * 10.0 ** int(rng.integers(-6, 6))
        if k % 10 == 9:  # scaled by powers of two inside (reference.vertex_normals)
            v *= 10.0 ** [-250, -150, -70, 70, 150, 250][k // 10]
        if k % 10 == 8:  # wholly subnormal: the compiled scale was once 2^1030 = inf
            v *= 1e-300 * 10.0 ** [-8, -10, -12, -14, -16, -20][k // 10]
        f = rng.integers(0, n, size=(int(rng.integers(0, 60)), 3))
        meshes.append(zbuffer.Mesh(v, f))
    meshes.append(zbuffer.Mesh(np.zeros((0, 3)), np.zeros((0, 3), int)))
    from helpers import MODELS
    meshes += [zbuffer.load(MODELS / name) for name in ("bunny_10k.obj", "beast_quads.obj")
               if (MODELS / name).is_file()]
    for mesh in meshes:
        normals = mesh.vertex_normals
        assert normals.dtype == np.float64 and normals.shape == mesh.vertices.shape
        assert not normals.flags.writeable
        np.testing.assert_array_equal(normals, reference.vertex_normals(mesh.vertices, mesh.faces))
    with pytest.raises(ValueError, match="face 0 has vertex index 3, outside"):
        _core.vertex_normals(np.zeros((3, 3)), np.array([[0, 1, 3]], np.int32))


@pytest.mark.parametrize("shading", ["flat", "smooth"])
def test_shading_at_extreme_scales(shading):
    """A mesh scaled by 1e-150 .. 1e100 shades as at scale 1 (within a
    level: the camera is fitted anew), compiled and numpy alike: squared
    normals used to underflow to 0 below ~1e-81 and overflow above ~1e77,
    leaving ambient light only (a fuzzer's find). Half of the faces of an
    icosphere (1,280 at 64 x 48: found in the image) and a single face."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=3)
    one = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]))
    for v, f in [(sphere.vertices, sphere.faces), one]:
        images = {}
        for scale in [1.0, 1e-150, 1e-100, 1e-80, 1e80, 1e100]:
            mesh = zbuffer.Mesh(v * scale, f)
            res = zbuffer.render(mesh, width=64, height=48, shading=shading)
            ref = zbuffer.reference.render(mesh, camera=res.camera, width=64, height=48,
                                           shading=shading)
            assert np.abs(res.image.astype(int) - ref.image.astype(int)).max() <= 1, scale
            images[scale] = res.image
            if scale != 1.0:
                same = (res.mask == (images[1.0] != 255).any(axis=2))
                assert same.mean() > 0.99
                lit = res.mask & same
                diff = np.abs(res.image.astype(int) - images[1.0].astype(int))[lit]
                assert diff.max() <= 1, scale
        assert images[1.0][(images[1.0] != 255).any(axis=2)].max() > 150  # lit, not ambient


def test_prepared_mesh_sees_vertex_colours_set_anew():
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=4)
    red = np.tile(np.float32([1, 0, 0]), (len(sphere.vertices), 1))
    blue = np.tile(np.float32([0, 0, 1]), (len(sphere.vertices), 1))
    mesh = zbuffer.Mesh(sphere.vertices, sphere.faces, vertex_colors=red).prepare()
    cam = zbuffer.Camera.fit(mesh)
    first = zbuffer.render(mesh, camera=cam, width=48, height=48, shading="smooth")
    mesh.vertex_colors = blue
    again = zbuffer.render(mesh, camera=cam, width=48, height=48, shading="smooth")
    fresh = zbuffer.render(zbuffer.Mesh(sphere.vertices, sphere.faces, vertex_colors=blue),
                           camera=cam, width=48, height=48, shading="smooth")
    assert not np.array_equal(first.image, fresh.image)
    np.testing.assert_array_equal(again.image, fresh.image)
    # set anew as the constructor takes them (uint8 met the core's "colors
    # must have dtype float32"; a wrong length, on a prepared mesh, an
    # IndexError: a fuzzing round), and never beside face colours
    green = np.tile(np.uint8([0, 255, 0]), (len(sphere.vertices), 1))
    mesh.vertex_colors = green
    again = zbuffer.render(mesh, camera=cam, width=48, height=48, shading="smooth")
    fresh = zbuffer.render(zbuffer.Mesh(sphere.vertices, sphere.faces, vertex_colors=green),
                           camera=cam, width=48, height=48, shading="smooth")
    drawn = again.image[again.mask]
    assert drawn[:, 1].max() > 0 and drawn[:, 2].max() == 0  # green, not blue
    np.testing.assert_array_equal(again.image, fresh.image)
    with pytest.raises(ValueError, match=r"vertex_colors must have shape \(2562, 3\)"):
        mesh.vertex_colors = np.zeros((3, 3), np.float32)
    with pytest.raises(ValueError, match="not both"):
        mesh.face_colors = np.zeros((len(mesh.faces), 3))
    mesh.vertex_colors = None
    mesh.face_colors = np.zeros((len(mesh.faces), 3))
    assert mesh.face_colors.dtype == np.float32


@pytest.mark.parametrize("shading", ["flat", "smooth"])
def test_meshes_without_faces_shade_to_the_background(shading):
    for mesh in (zbuffer.Mesh(np.random.default_rng(1).random((5, 3)), np.zeros((0, 3), int)),
                 zbuffer.Mesh(np.zeros((0, 3)), np.zeros((0, 3), int))):
        assert mesh.vertex_normals.dtype == np.float64
        assert mesh.vertex_normals.shape == mesh.vertices.shape
        res = zbuffer.render(mesh, camera=zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0)),
                             width=8, height=6, shading=shading, background=(1, 2, 3))
        assert (res.image == [1, 2, 3]).all()


@pytest.mark.models
@pytest.mark.parametrize("shading", ["flat", "smooth"])
@pytest.mark.parametrize("name", ["bunny_10k.obj", "spot.obj", "cow_6k.obj"])
def test_compiled_shading_matches_numpy_on_models(name, shading):
    from helpers import model_path

    mesh = zbuffer.load(model_path(name))
    c, r = mesh.bounding_sphere
    cameras = [
        zbuffer.Camera.fit(mesh, direction=(0.3, 0.5, 1.0), aspect=4 / 3),
        zbuffer.Camera.fit(mesh, direction=(-1.0, 0.2, -0.5), aspect=4 / 3,
                           projection="orthographic"),
        # Close up: triangles cross the near plane.
        zbuffer.Camera.look_at(c + np.array([0.1, 0.05, 0.8]) * r, c, fov_y=60,
                               near=0.3 * r, far=4 * r),
    ]
    for cam in cameras:
        res = zbuffer.render(mesh, camera=cam, width=160, height=120, shading=shading)
        ref = zbuffer.reference.render(mesh, camera=cam, width=160, height=120, shading=shading)
        assert (res.triangle_id == ref.triangle_id).all()
        assert res.mask.sum() > 1000
        assert np.abs(res.image.astype(int) - ref.image.astype(int)).max() <= 1


# Faces the vector passes must leave to the scalar way (shading.cpp,
# FaceShade::exact), found by fuzzing: each was 3-103 levels off before.
def _compiled_and_reference(mesh, **kw):
    res = zbuffer.render(mesh, **kw)
    ref = zbuffer.reference.render(mesh, **kw)
    assert (res.triangle_id == ref.triangle_id).all()
    assert res.mask.any()
    return np.abs(res.image.astype(int) - ref.image.astype(int)).max()


def test_smooth_normals_that_cancel_inside_a_face():
    # A long prism seen end-on: its cap's corner normals point 120 degrees
    # apart (plus a hair along the axis), so their interpolation nearly
    # vanishes at the cap's centre, not at a corner.
    length = 1e7
    a = np.pi / 2 + 2 * np.pi / 3 * np.arange(3)
    ring = np.stack([np.cos(a) - 0.19003322259136213, np.sin(a) - 0.09501661129568106], 1)
    v = np.concatenate([np.c_[ring, np.zeros(3)], np.c_[ring, -length * np.ones(3)]])
    f = [[0, 1, 2], [5, 4, 3]] + sum(([[k, (k + 1) % 3 + 3, (k + 1) % 3],
                                       [k, k + 3, (k + 1) % 3 + 3]] for k in range(3)), [])
    cam = zbuffer.Camera.look_at((0, 0, 10), (0, 0, 0), projection="orthographic",
                                 ortho_height=2.2, near=1, far=20 + length)
    assert _compiled_and_reference(zbuffer.Mesh(v, np.array(f)), camera=cam, width=301,
                                   height=301, shading="smooth", light_dir=(0, -1, 0)) <= 1


def test_per_vertex_colours_of_a_sliver_in_a_large_image():
    # At 4001 x 3000 the barycentrics of this sliver cancel in float32.
    v = np.array([[-0.7643333333333333, 0.8700000000000001, 0.2390996815555203],
                  [-0.764, 0.8800000000000001, 0.25537156747652884],
                  [-0.7643333333333333, 0.8800000000000001, 0.25493127539617166]])
    c = np.array([[0.5233516097068787, 0.15423649549484253, 0.7270265221595764],
                  [0.8050167560577393, 0.8387870788574219, 0.07313212007284164],
                  [0.20033268630504608, 0.18748556077480316, 0.8760732412338257]])
    cam = zbuffer.Camera(eye=(1.1175718915270252, 1.490095855369367, 3.725239638423418),
                         target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_y=45.0,
                         near=2.688825344472881, far=5.670042906229789)
    mesh = zbuffer.Mesh(v, np.array([[0, 1, 2]]), vertex_colors=c)
    assert _compiled_and_reference(mesh, camera=cam, width=4001, height=3000, shading="flat",
                                   light_dir=(0.3, -1, -0.5)) <= 1


def test_per_vertex_colours_of_faces_collinear_within_rounding():
    # Three corners on one line (the middle one a rounded point of it): the
    # snapped triangle still covers a pixel centre now and then, while the
    # barycentrics are rounding noise before the clamp. The numpy twin takes
    # the scalar pass's operations in its order, so the two agree there too
    # (before: 26 of 76 such faces up to 113 levels apart).
    rng = np.random.default_rng(1)
    cam = zbuffer.Camera.look_at((0.1, 0.2, 3), (0, 0, 0), fov_y=50)
    drawn = 0
    for _ in range(150):
        a, b = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
        v = np.array([a, a + rng.uniform(0.1, 0.9) * (b - a), b])
        mesh = zbuffer.Mesh(v, np.array([[0, 1, 2]]),
                            vertex_colors=rng.uniform(0, 1, (3, 3)).astype(np.float32))
        if not zbuffer.render(mesh, camera=cam, width=1024, height=1024, shading="none").mask.any():
            continue
        drawn += 1
        for shading in ["flat", "smooth"]:
            assert _compiled_and_reference(mesh, camera=cam, width=1024, height=1024,
                                           shading=shading) <= 1
    assert drawn >= 15


@pytest.mark.parametrize("shading", ["none", "flat", "smooth"])
def test_the_reference_calls_no_compiled_code(monkeypatch, tmp_path, shading):
    # zbuffer.reference is pure numpy: with every module's handle on the
    # compiled core replaced by one that refuses, it renders the same bits
    # (vertex colours, and polygon faces drawn natively, too). (The file is
    # loaded before: zbuffer.load reads most OBJ files with compiled code.)
    import sys

    class Refuse:
        def __getattr__(self, name):
            raise AssertionError(f"the reference called the compiled core: _core.{name}")

    v, f = scenes.uv_sphere(n_lat=8, n_lon=12)
    colours = np.random.default_rng(0).uniform(size=(len(v), 3))
    path = tmp_path / "polygons.obj"
    path.write_text("v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 0.5 0\nv 0 2 0\nv 3 0 0\n"
                    "f 1 2 3 4 5\nf 2 6 3\n")  # a concave pentagon and a triangle
    cam = zbuffer.Camera.look_at((0.2, 0.3, 3), (0, 0, 0))
    poly_cam = zbuffer.Camera.look_at((1.5, 1, 5), (1.5, 1, 0), fov_y=50)
    polygons = zbuffer.load(path)

    def renders():
        return (zbuffer.reference.render(zbuffer.Mesh(v, f, vertex_colors=colours), camera=cam,
                                         width=40, height=30, shading=shading),
                zbuffer.reference.render(polygons, camera=poly_cam, width=40,
                                         height=30, shading=shading, polygons=True))

    expected = renders()
    for name, module in list(sys.modules.items()):
        if (name == "zbuffer" or name.startswith("zbuffer.")) and hasattr(module, "_core"):
            monkeypatch.setattr(module, "_core", Refuse())
    monkeypatch.setitem(sys.modules, "zbuffer._core", Refuse())
    for res, exp in zip(renders(), expected):
        np.testing.assert_array_equal(res.triangle_id, exp.triangle_id)
        np.testing.assert_array_equal(res.depth, exp.depth)
        if shading != "none":
            np.testing.assert_array_equal(res.image, exp.image)


def test_color_overrides_the_mesh_colours_in_either_scale():
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    cam = zbuffer.Camera.look_at((0, 0, 6), (0, 0, 0), fov_y=30)
    kw = dict(camera=cam, width=20, height=20, ambient=1.0, diffuse=0.0)
    for colours in ({"face_colors": [[255, 0, 0], [255, 0, 0]]},
                    {"vertex_colors": np.tile([1.0, 0, 0], (4, 1))}):
        mesh = zbuffer.Mesh(v, f, **colours)
        for color in [(0, 0, 255), (0.0, 0.0, 1.0)]:
            res = zbuffer.render(mesh, color=color, **kw)
            assert (res.image[res.mask] == [0, 0, 255]).all()
    res = zbuffer.render((v, f), background=(0.0, 0.5, 1.0), **kw)
    assert (~res.mask).any() and (res.image[~res.mask] == [0, 128, 255]).all()
    assert (res.image[res.mask] == 204).all()  # the default albedo, 0.8 grey
