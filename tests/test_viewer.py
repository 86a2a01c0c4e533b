"""zbuffer.viewer: the state and frames of ``zbuffer view`` (no window)."""

import re

import numpy as np
import pytest

import zbuffer
from zbuffer import scenes
from zbuffer.viewer import Viewer


@pytest.fixture
def viewer():
    return Viewer(scenes.default_scene(), algo="hiz_octree", width=96, height=72)


def test_frames_are_zbuffers_renders_of_the_current_view(viewer):
    drawn_by = []
    for _ in range(len(zbuffer.algorithms())):
        picture = viewer.frame()
        expected = zbuffer.render(viewer.scene.mesh, algo="zbuffer", camera=viewer.camera(),
                                  width=96, height=72)
        np.testing.assert_array_equal(viewer.result.triangle_id, expected.triangle_id)
        np.testing.assert_array_equal(picture, expected.image)
        drawn_by.append(viewer.result.algo)
        viewer.next_algorithm()
    # Every registered algorithm drew a frame, in the registry's order from
    # the one it started with, and round again.
    names = zbuffer.algorithms()
    start = names.index("hiz_octree")
    assert drawn_by == names[start:] + names[:start]
    assert viewer.algo == "hiz_octree"


def test_drag_and_wheel_move_zbuffers_camera(viewer):
    before = np.array(viewer.camera().eye)
    viewer.rotate(30, 10)
    assert viewer.azimuth == 30 and viewer.elevation == 30
    moved = np.array(viewer.camera().eye)
    assert not np.allclose(moved, before)
    # The target stays put and so does the distance to it.
    np.testing.assert_allclose(np.linalg.norm(moved - viewer.target),
                               np.linalg.norm(before - viewer.target))
    viewer.rotate(0, 500)
    assert viewer.elevation == 89  # never over the pole
    d = viewer.distance
    viewer.zoom(0.5)
    assert viewer.distance == pytest.approx(d / 2)
    viewer.reset_view()
    np.testing.assert_allclose(viewer.camera().eye, before)


def test_overlays(viewer):
    viewer.frame()
    viewer.toggle("depth")
    depth = viewer.frame()
    drawn = viewer.result.mask
    assert (depth[~drawn] == 0).all() and (depth[drawn] > 0).all()  # black where nothing was drawn
    assert len(np.unique(depth[drawn][:, 0])) > 10                   # shades of grey
    viewer.toggle("depth")
    assert viewer.overlay == "none"
    viewer.toggle("pyramid")
    assert viewer.overlay == "pyramid" and viewer.pyramid_level == 1
    coarse = viewer.frame()
    assert coarse.shape == (72, 96, 3)
    # Level 1: every 2 x 2 block shows one value.
    assert (coarse[0:72:2, 0:96:2] == coarse[1:72:2, 1:96:2]).all()
    for _ in range(len(viewer.result.pyramid()) - 2):  # levels 2 .. last
        viewer.toggle("pyramid")
        assert viewer.overlay == "pyramid"
    viewer.toggle("pyramid")  # past the last level: off
    assert viewer.overlay == "none"
    plain = viewer.frame()
    viewer.toggle("tree")
    boxes = viewer.frame()
    assert viewer.overlay == "tree" and (boxes != plain).any()
    # Only the outlines change: most pixels are the image's.
    assert (boxes == plain).all(axis=-1).mean() > 0.5
    viewer.algo = "zbuffer"
    viewer.toggle("tree")  # off
    viewer.toggle("tree")  # no tree: stays off
    assert viewer.overlay == "none"


@pytest.mark.parametrize("width, height", [(1, 1), (1, 5), (3, 2)])
def test_pyramid_overlay_of_tiny_images(width, height):
    # A 1 x 1 image has one pyramid level: the overlay shows it, then goes off.
    viewer = Viewer(scenes.default_scene(), algo="zbuffer", width=width, height=height)
    levels = len(viewer.render().pyramid())
    shown = []
    viewer.toggle("pyramid")
    while viewer.overlay == "pyramid":
        assert viewer.frame().shape == (height, width, 3)
        shown.append(viewer.pyramid_level)
        viewer.toggle("pyramid")
    assert shown == (list(range(1, levels)) if levels > 1 else [0])


def test_shading_cycle_and_false_colour_ids(viewer):
    seen = set()
    for _ in range(3):
        viewer.next_shading()
        seen.add(viewer.shading)
        picture = viewer.frame()
        if viewer.shading == "none":
            np.testing.assert_array_equal(picture, zbuffer.viz.id_colors(viewer.result.triangle_id))
    assert seen == {"flat", "smooth", "none"}


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown algorithm 'fast'"):
        Viewer(scenes.default_scene(), algo="fast")
    with pytest.raises(ValueError, match="unknown shading .phong.; valid values are .flat."):
        Viewer(scenes.default_scene(), shading="phong")
    with pytest.raises(ValueError, match="unknown overlay 'normals'; valid values are 'depth'"):
        Viewer(scenes.default_scene()).toggle("normals")
    # (a fuzzing round: NaN moves were taken, and every later frame failed
    # on a non-finite eye; strings met Python's operators)
    viewer = Viewer(scenes.default_scene(), width=16, height=12)
    for move, error, match in [(lambda: viewer.rotate(float("nan"), 0), ValueError,
                                "d_azimuth must be finite"),
                               (lambda: viewer.rotate(0, float("inf")), ValueError,
                                "d_elevation must be finite"),
                               (lambda: viewer.zoom(float("nan")), ValueError,
                                "factor must be finite"),
                               (lambda: viewer.zoom(0), ValueError, "factor must be > 0"),
                               (lambda: viewer.zoom("2"), TypeError, "factor must be a number")]:
        with pytest.raises(error, match=match):
            move()
    assert viewer.frame().shape[:2] == (12, 16)  # the view unharmed
    # A mesh no orbit camera can frame is refused when the viewer is made,
    # not by every frame with a near plane the user never gave.
    triangle = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    # (1e-160: framed at the start, but zoomed all the way in its clip planes
    # are out of double precision's reach)
    for scale in (1e-300, 1e300, 1e-160):
        with pytest.raises(ValueError, match=r"the viewer cannot frame this mesh \(coordinates "
                                             rf"up to {re.escape(f'{scale:.3g}')}\): .*; scale it"):
            Viewer(zbuffer.Mesh(triangle * scale, [[0, 1, 2]]), width=16, height=16)
    # at 1e-150 every zoom works
    viewer = Viewer(zbuffer.Mesh(triangle * 1e-150, [[0, 1, 2]]), width=16, height=16)
    for factor in (1e-9, 1e9):
        viewer.zoom(factor)
        assert viewer.frame().shape[:2] == (16, 16)


def test_viewer_and_viz_are_attributes_of_the_package():
    # import zbuffer; zbuffer.viz.show_result(...) as README writes it: in a
    # fresh interpreter, where nothing has imported the submodules yet (this
    # file has imported zbuffer.viewer, which sets the attribute anyway).
    import subprocess
    import sys

    code = ("import sys, zbuffer\n"
            "assert 'zbuffer.viz' not in sys.modules and 'pyvista' not in sys.modules\n"
            "zbuffer.viewer.Viewer, zbuffer.viz.show_result\n"
            "try:\n    zbuffer.vizz\nexcept AttributeError as err:\n    print(err)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "has no attribute 'vizz'" in out.stdout
