"""zbuffer: exact software renderers for triangle meshes.

The plain Z-buffer, the scanline Z-buffer and the hierarchical Z-buffer family
side by side, all bit-identical to a pure-numpy reference.

>>> import zbuffer
>>> res = zbuffer.render(zbuffer.scenes.default_scene(), width=320, height=240)
>>> res.depth.shape, res.triangle_id.dtype
((240, 320), dtype('int32'))
"""

from . import reference, scenes
from .api import algorithms, render
from .camera import Camera
from .load import as_mesh, load
from .mesh import Mesh, Visit
from .result import RenderResult
from .scene import Scene

__version__ = "0.1.0"

__all__ = [
    "Camera",
    "Mesh",
    "RenderResult",
    "Scene",
    "Visit",
    "algorithms",
    "as_mesh",
    "load",
    "reference",
    "render",
    "scenes",
]


def __getattr__(name):
    """``zbuffer.viz`` and ``zbuffer.viewer`` on first use: they import
    pyvista (and matplotlib), which rendering never needs."""
    if name in ("viz", "viewer"):
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
