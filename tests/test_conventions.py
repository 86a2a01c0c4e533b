"""The Python restatement of the C++ conventions agrees with the core."""

import numpy as np
import pytest

import zbuffer
from zbuffer import _core, conventions, reference, scenes


def test_python_conventions_match_the_compiled_core():
    assert conventions.SUBPIXEL_BITS == _core.SUBPIXEL_BITS
    assert conventions.MAX_IMAGE_SIDE == _core.MAX_IMAGE_SIDE
    assert conventions.MAX_IMAGE_PIXELS == _core.MAX_IMAGE_PIXELS
    assert conventions.GUARD_BAND_PX == _core.GUARD_BAND_PX


def test_reference_needs_no_compiled_code():
    import ast
    import inspect

    for module in (reference, conventions):
        tree = ast.parse(inspect.getsource(module))
        names = {a.name for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
                 for a in n.names}
        modules = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
        assert "_core" not in names and "api" not in modules


def test_clip_constants_match_the_compiled_core():
    assert conventions.MIN_CLIP_W == _core.MIN_CLIP_W
    assert conventions.MAX_CLIP_VERTICES == _core.MAX_CLIP_VERTICES


@pytest.mark.parametrize("algo", zbuffer.algorithms())
def test_cull_backfaces_keeps_what_faces_the_camera(algo):
    # Counter-clockwise as seen is the front: a closed box wound outwards
    # looks the same with culling, and inside out it does not. (The core and
    # the reference are otherwise only held to each other: a convention
    # flipped in both would pass.)
    v, f = scenes.box()  # counter-clockwise seen from outside
    cam = zbuffer.Camera.look_at((2, 1.5, 3), (0, 0, 0))
    kw = dict(camera=cam, width=48, height=40, shading="none")
    plain = zbuffer.render((v, f), algo=algo, **kw)
    culled = zbuffer.render((v, f), algo=algo, cull_backfaces=True, **kw)
    np.testing.assert_array_equal(culled.triangle_id, plain.triangle_id)
    assert culled.stats["culled_backface"] == 6  # the three sides turned away
    inside_out = zbuffer.render((v, f[:, ::-1]), algo=algo, cull_backfaces=True, **kw)
    assert inside_out.mask.any() and not np.array_equal(inside_out.triangle_id, plain.triangle_id)
