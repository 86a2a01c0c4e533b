"""Argument checking and resolution shared by :func:`zbuffer.render` and
:func:`zbuffer.reference.render` (no compiled code here)."""

from __future__ import annotations

import operator
from typing import Optional, Tuple

import numpy as np

from .camera import Camera
from .conventions import MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE
from .mesh import Mesh, as_mesh
from .shading import ShadingParams, resolve_shading

__all__ = ["prepare", "check_size", "DEFAULT_SIZE"]

DEFAULT_SIZE = (800, 600)


def check_size(width, height) -> Tuple[int, int]:
    for name, value in (("width", width), ("height", height)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name} must be an int, got {value!r}")
    width, height = int(width), int(height)
    if width <= 0 or height <= 0:
        raise ValueError(f"width and height must be positive, got {width}x{height}")
    if (width > MAX_IMAGE_SIDE or height > MAX_IMAGE_SIDE
            or width * height > MAX_IMAGE_PIXELS):
        raise ValueError(
            f"image {width}x{height} is too large: at most {MAX_IMAGE_SIDE} pixels "
            f"a side and {MAX_IMAGE_PIXELS} pixels in all"
        )
    return width, height


def check_index(name: str, value) -> int:
    """``value`` as an int: any integer numpy's indexing takes (Python and
    numpy integers, 0-d integer arrays), not a bool; TypeError otherwise."""
    try:
        if isinstance(value, (bool, np.bool_)):
            raise TypeError
        return operator.index(value)
    except TypeError:
        raise TypeError(f"{name} must be an integer, got {value!r}") from None


def check_flag(name: str, value) -> bool:
    """``value`` as a bool; TypeError unless it is one (a string such as
    "no" would otherwise count as True)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {value!r}")
    return bool(value)


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
