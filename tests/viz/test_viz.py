"""zbuffer.viz: every view produces a non-blank image offscreen."""

import io
import os

import numpy as np
import pytest

import zbuffer
from helpers import can_render_offscreen
from zbuffer import scenes

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

from zbuffer import viz  # noqa: E402  (after pyvista's offscreen switch)


RENDERS = can_render_offscreen()
if not RENDERS and os.environ.get("ZBUFFER_REQUIRE_VIZ"):  # CI: a skip would hide a failure
    raise RuntimeError("ZBUFFER_REQUIRE_VIZ is set but pyvista cannot render offscreen")

pytestmark = [pytest.mark.viz, pytest.mark.skipif(not RENDERS, reason="no offscreen OpenGL here")]


def not_blank(image: np.ndarray) -> bool:
    """More than a background: many distinct colours."""
    return len(np.unique(image.reshape(-1, image.shape[-1]), axis=0)) > 20


@pytest.fixture(scope="module")
def result():
    mesh = scenes.default_scene()
    return zbuffer.render(mesh, algo="hiz", camera=scenes.default_camera(4 / 3), width=160,
                          height=120)


def test_show_result_writes_a_picture(result, tmp_path):
    path = tmp_path / "result.png"
    image = result.show(screenshot=str(path), window_size=(600, 200))
    assert path.is_file() and image.shape[:2] == (200, 600)
    assert not_blank(image)


def test_pictures_show_their_own_colours(tmp_path):
    # Drawn unlit: pyvista's lights turned a white background into (200, 197, 189).
    res = zbuffer.render(scenes.default_scene(), width=40, height=30)
    res.image[:] = (10, 200, 90)
    shown = viz.show_result(res, screenshot=True, window_size=(600, 200))
    assert tuple(shown[100, 100]) == (10, 200, 90)  # the middle of the image's panel
    frame = zbuffer.viewer.Viewer(scenes.default_scene(), width=96, height=72)
    picture = viz_image(_view_screenshot(frame, tmp_path / "view.png"))
    np.testing.assert_array_equal(picture[36:, :, :3], frame.frame()[36:])  # (below the status)


def _view_screenshot(viewer, path):
    from zbuffer.viewer import run

    run(viewer, screenshot=str(path))
    return path


def test_no_window_where_none_can_open(monkeypatch):
    # No display, not offscreen, not a notebook: an error saying so, not
    # pyvista's warning and a plotter that shows nothing.
    monkeypatch.setattr(pv, "OFF_SCREEN", False)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    res = zbuffer.render(scenes.default_scene(), width=40, height=30)
    with pytest.raises(RuntimeError, match="no display to open a window on"):
        res.show()
    with pytest.raises(RuntimeError, match="no display to open a window on"):
        zbuffer.viewer.run(zbuffer.viewer.Viewer(scenes.default_scene(), width=40, height=30))
    # compare_algorithms says so before it renders anything
    rendered = []
    monkeypatch.setattr(zbuffer.api, "render", lambda *a, **k: rendered.append(k["algo"]))
    with pytest.raises(RuntimeError, match="no display to open a window on"):
        viz.compare_algorithms(scenes.default_scene(), width=40, height=30)
    assert rendered == []
    monkeypatch.setattr(pv, "OFF_SCREEN", True)  # pyvista told to draw offscreen: no error
    assert res.show() is not None


def test_show_result_without_image(tmp_path):
    res = zbuffer.render(scenes.default_scene(), width=80, height=60, shading="none")
    image = viz.show_result(res, screenshot=str(tmp_path / "r.png"), window_size=(400, 200))
    assert not_blank(image)


def test_screenshot_files(tmp_path):
    # What pyvista took before screenshots went through Pillow (a path with
    # no suffix gets .png, ~ is expanded, a file object gets a PNG), a
    # suffix in capitals too, and a suffix it cannot write refused before
    # anything is drawn, leaving no file.
    import io

    res = zbuffer.render(scenes.default_scene(), width=40, height=30)
    image = viz.show_result(res, screenshot=str(tmp_path / "plain"), window_size=(300, 100))
    np.testing.assert_array_equal(viz_image(tmp_path / "plain.png"), image)
    upper = viz.show_result(res, screenshot=str(tmp_path / "upper.PNG"), window_size=(300, 100))
    np.testing.assert_array_equal(viz_image(tmp_path / "upper.PNG"), upper)
    buffer = io.BytesIO()
    viz.show_result(res, screenshot=buffer, window_size=(300, 100))
    assert buffer.getvalue()[:4] == b"\x89PNG"
    for bad, match in [(tmp_path / "x.txt", r"'.*x.txt': the file name must end in .png"),
                       ("", "'' is not a file name"), (tmp_path, "'.*' is not a file name"),
                       (f"{tmp_path}/sub/", "'.*sub/' is not a file name"),
                       (tmp_path / "nope" / "x.png",
                        "'.*x.png': no folder '.*nope' to write it in")]:
        with pytest.raises(ValueError, match="screenshot " + match):
            viz.show_result(res, screenshot=bad)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plain.png", "upper.PNG"]
    # (a transparent background's RGBA as JPEG: Pillow cannot write RGBA JPEGs)
    with _transparent_background():
        rgba = viz.show_result(res, screenshot=str(tmp_path / "t.jpg"), window_size=(300, 100))
    assert rgba.shape[2] == 4 and viz_image(tmp_path / "t.jpg").shape[2] == 3


def test_pyramid_views(result, tmp_path):
    flat = viz.show_pyramid(result, screenshot=str(tmp_path / "levels.png"))
    assert not_blank(flat)
    stack = viz.show_pyramid_stack(result, screenshot=str(tmp_path / "stack.png"),
                                   window_size=(400, 400))
    assert not_blank(stack)


def test_pyramid_view_greys_undrawn_cells(result):
    # +inf cells (a pixel under them not drawn) in their own grey, not in
    # black, which the colour scale's far end comes close to.
    picture = viz.show_pyramid(result, screenshot=True, levels=[2], window_size=(400, 300))
    grey = (picture[..., :3] == 200).all(axis=-1).sum()
    assert grey > 0.1 * picture.shape[0] * picture.shape[1]


def test_views_refuse_what_they_cannot_show(result):
    levels = len(result.pyramid())
    for bad in ([], [0, levels], [-1], [0.5], [True]):
        with pytest.raises(ValueError, match="levels: "):
            viz.show_pyramid(result, screenshot=True, levels=bad)
    with pytest.raises(ValueError, match="at least one algorithm"):
        viz.compare_algorithms(scenes.default_scene(), algos=[], screenshot=True)
    with pytest.raises(ValueError, match="algos names 'hiz' more than once"):
        viz.compare_algorithms(scenes.default_scene(), algos=["hiz", "zbuffer", "hiz"],
                               screenshot=True)
    with pytest.raises(ValueError, match="no pyramid levels to show"):
        viz.show_pyramid_stack([], screenshot=True)


def test_pyramid_view_outlines_the_cells_that_culled_most(tmp_path):
    mesh = scenes.default_scene()  # its torus hides part of what is behind it
    res = zbuffer.render(mesh, algo="hiz", width=128, height=96, shading="none",
                         record_culls=True)
    assert sum(int(c.sum()) for c in res.culls) > 0
    red = lambda img: ((img[..., 0] > 200) & (img[..., 1] < 60) & (img[..., 2] < 60)).sum()  # noqa: E731
    plain = viz.show_pyramid(res, screenshot=True, levels=[3, 4])
    marked = viz.show_pyramid(res, screenshot=str(tmp_path / "culls.png"), levels=[3, 4],
                              highlight_culls=3)
    assert red(marked) > red(plain) + 20
    with pytest.raises(ValueError, match="record_culls=True"):
        viz.show_pyramid(zbuffer.render(mesh, algo="hiz", width=32, height=32),
                         screenshot=True, highlight_culls=True)


def test_compare_algorithms_shows_zero_differences(tmp_path):
    # (record_culls goes to the algorithms with a Z-pyramid only)
    results = viz.compare_algorithms(scenes.default_scene(), width=96, height=72,
                                     screenshot=str(tmp_path / "cmp.png"), record_culls=True)
    assert list(results) == zbuffer.algorithms()
    assert {name for name, res in results.items() if res.culls is not None} == \
        {"hiz", "hiz_octree", "hiz_bvh"}
    first = next(iter(results.values()))
    for res in results.values():
        np.testing.assert_array_equal(res.depth, first.depth)
    assert (tmp_path / "cmp.png").is_file()
    # One name is one algorithm, not its letters.
    assert list(viz.compare_algorithms(scenes.default_scene(), width=32, height=24,
                                       algos="zbuffer", screenshot=True)) == ["zbuffer"]


def test_repr_png_for_notebooks(result):
    from PIL import Image

    png = result._repr_png_()
    assert png.startswith(b"\x89PNG")
    assert Image.open(io.BytesIO(png)).size == (160, 120)
    none = zbuffer.render(scenes.default_scene(), width=40, height=30, shading="none")
    assert Image.open(io.BytesIO(none._repr_png_())).size == (40, 30)


def test_id_colours_are_stable_and_black_for_background():
    ids = np.array([[-1, 0, 1], [1, 2, -1]], np.int32)
    rgb = viz.id_colors(ids)
    assert (rgb[ids < 0] == 0).all()
    np.testing.assert_array_equal(rgb[0, 2], rgb[1, 0])
    assert not np.array_equal(rgb[0, 1], rgb[0, 2])


@pytest.mark.parametrize("algo", ["hiz_octree", "hiz_bvh"])
def test_tree_views(algo, tmp_path):
    mesh = scenes.instance_grid(scenes.default_scene(), (2, 2, 3))
    scene = zbuffer.Scene(mesh, leaf_size=64)
    cam = zbuffer.Camera.fit(mesh, direction=(0.3, 0.2, 1.0), aspect=4 / 3)
    res = scene.render(cam, algo=algo, width=160, height=120)
    nodes = scene.nodes(algo)
    grid = viz.tree_grid(scene, algo)
    assert grid.n_cells == len(nodes["depth"])  # one grid, one cell per node
    np.testing.assert_array_equal(grid.cell_data["fate"], nodes["fate"])
    level = viz.tree_grid(scene, algo, level=2)
    assert level.n_cells == (nodes["depth"] == 2).sum() > 0
    np.testing.assert_allclose(grid.bounds, [mesh.vertices[:, 0].min(), mesh.vertices[:, 0].max(),
                                             mesh.vertices[:, 1].min(), mesh.vertices[:, 1].max(),
                                             mesh.vertices[:, 2].min(), mesh.vertices[:, 2].max()])
    for color_by, lvl in [("fate", None), ("depth", 2)]:
        image = viz.show_tree(scene, algo, result=res, color_by=color_by, level=lvl,
                              screenshot=str(tmp_path / f"{color_by}.png"), window_size=(400, 300))
        assert not_blank(image)
    # Framed on the tree, not on the view volume around it: the drawn
    # nodes' green (lit: of varying shades) reaches over most of the
    # picture's height.
    rgb = viz.show_tree(scene, algo, result=res, screenshot=True,
                        window_size=(400, 300))[..., :3].astype(int)
    green = ((rgb[..., 1] > rgb[..., 0] + 40) & (rgb[..., 1] > rgb[..., 2] + 40)).any(axis=1)
    rows = np.flatnonzero(green)
    assert rows[-1] - rows[0] > 0.7 * rgb.shape[0]
    with pytest.raises(ValueError, match="unknown color_by 'size'; valid values are 'fate'"):
        viz.show_tree(scene, algo, color_by="size", screenshot=str(tmp_path / "x.png"))
    with pytest.raises(TypeError, match="color_by must be one of 'fate', 'depth', got None"):
        viz.show_tree(scene, algo, color_by=None, screenshot=str(tmp_path / "x.png"))


def test_frustum_corners_project_to_the_clip_cube():
    res = zbuffer.render(scenes.default_scene(), width=80, height=60, shading="none")
    pts = np.asarray(viz.frustum_grid(res).points)
    clip = np.hstack([pts, np.ones((8, 1))]) @ res.mvp.T
    np.testing.assert_allclose(np.abs(clip[:, :3] / clip[:, 3:]), 1.0, rtol=1e-9)



def test_zbuffer_view_screenshot(tmp_path, capsys):
    from zbuffer.cli import main

    path = tmp_path / "view.png"
    assert main(["view", "--size", "160x120", "--overlay", "tree", "--screenshot", str(path)]) == 0
    image = viz_image(path)
    assert image.shape[:2] == (120, 160) and not_blank(image)
    assert "hiz_octree" in capsys.readouterr().out
    assert main(["view", "--algo", "zbuffer", "--overlay", "tree", "--screenshot",
                 str(tmp_path / "x.png")]) == 2  # no tree to show: a clear error
    assert "needs a tree algorithm" in capsys.readouterr().err
    # A suffix in capitals, as the CLI's check lets through (pyvista refused
    # it, in a two-line error; a fuzzing round): the same picture.
    upper = tmp_path / "VIEW.PNG"
    assert main(["view", "--size", "160x120", "--overlay", "tree", "--screenshot", str(upper)]) == 0
    np.testing.assert_array_equal(viz_image(upper), image)


class _transparent_background:
    """pyvista's global theme with a transparent background, for a block."""

    def __enter__(self):
        self.was = pv.global_theme.transparent_background
        pv.global_theme.transparent_background = True

    def __exit__(self, *exc):
        pv.global_theme.transparent_background = self.was


def viz_image(path):
    import skimage.io

    return skimage.io.imread(path)
