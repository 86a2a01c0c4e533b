"""The Python restatement of the C++ conventions agrees with the core."""

from zbuffer import _core, conventions, reference


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
