"""Argument checking and resolution shared by :func:`zbuffer.render` and
:func:`zbuffer.reference.render` (no compiled code here)."""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

from .camera import Camera
from .checks import check_flag, check_index
from .conventions import MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE
from .load import as_mesh
from .mesh import Mesh
from .shading import ShadingParams, resolve_shading

__all__ = ["prepare", "check_size", "DEFAULT_SIZE"]

DEFAULT_SIZE = (800, 600)


def check_size(width, height) -> Tuple[int, int]:
    """(width, height) of an image as ints; TypeError for non-integers,
    ValueError for sizes <= 0 or beyond the limits (conventions.py)."""
    width, height = check_index("width", width), check_index("height", height)
    if width <= 0 or height <= 0:
        raise ValueError(f"width and height must be positive, got {width}x{height}")
    if (width > MAX_IMAGE_SIDE or height > MAX_IMAGE_SIDE
            or width * height > MAX_IMAGE_PIXELS):
        raise ValueError(
            f"image {width}x{height} is too large: at most {MAX_IMAGE_SIDE} pixels "
            f"a side and {MAX_IMAGE_PIXELS} pixels in all"
        )
    return width, height


def prepare(mesh, camera: Optional[Camera], width, height, shading, light_dir,
            ambient, diffuse, color, background, cull_backfaces=False
            ) -> Tuple[Mesh, Camera, np.ndarray, int, int, ShadingParams]:
    """Check and resolve everything render() and reference.render() share."""
    width, height = check_size(width, height)
    mesh = as_mesh(mesh)
    check_flag("cull_backfaces", cull_backfaces)
    if camera is None:
        camera = mesh.auto_camera(width / height)
    elif not isinstance(camera, Camera):
        raise TypeError(f"camera must be a zbuffer.Camera or None, got {type(camera).__name__}")
    camera = mesh.resolved_camera(camera)
    mvp = camera.mvp(width, height)
    if not np.isfinite(mvp).all():
        raise ValueError("the camera matrix has a NaN or infinite entry")
    params = resolve_shading(shading, camera, light_dir, ambient, diffuse, color, background)
    return mesh, camera, mvp, width, height, params
