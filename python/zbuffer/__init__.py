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
from .mesh import Mesh, Visit, as_mesh, load
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
