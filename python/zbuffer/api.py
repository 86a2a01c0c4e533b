"""The public entry points: :func:`render` and :func:`algorithms` (the
result is a :class:`~zbuffer.result.RenderResult`)."""

from __future__ import annotations

import threading
import time
from contextlib import contextmanager
from typing import List, Optional

import numpy as np

from . import _core
from .camera import Camera
from .mesh import Mesh, Visit
from .checks import check_flag
from .options import DEFAULT_SIZE, prepare
from .result import RenderResult
from .shading import (DEFAULT_AMBIENT, DEFAULT_BACKGROUND, DEFAULT_DIFFUSE, ShadingParams,
                      color_source)

__all__ = ["render", "algorithms"]


_ALGORITHMS = tuple(name for name, _ in _core.algorithms())
_POLYGON_ALGORITHMS = frozenset(_core.polygon_algorithms())


def algorithms() -> List[str]:
    """Names of the registered depth algorithms, in presentation order.

    Every name is a valid ``algo=`` for :func:`render`. On triangle meshes
    all of them produce bit-identical ``depth`` and ``triangle_id``. The
    exception is a mesh with polygon faces (OBJ, OFF or PLY files with quads
    or n-gons): ``"scanline"`` draws those polygons natively, which differs
    from drawing their triangulation (docs/rasterization.md, section 3.7:
    each polygon's pixels carry its first triangle's id, and its depth
    comes from the plane of one fan triangle);
    ``zbuffer.reference.render(..., polygons=True)`` reproduces it.

    Returns
    -------
    list of str
        A new list on every call.
    """
    return list(_ALGORITHMS)


def shade(mesh: Mesh, triangle_id: np.ndarray, camera: Camera, mvp: np.ndarray,
          params: ShadingParams, out: Optional[np.ndarray] = None,
          polygons: bool = False, ids_below: int = -1) -> np.ndarray:
    """Run the compiled shading pass; (H, W, 3) uint8 (``out``, if given).
    ``polygons``: the ids came from polygons drawn natively (each pixel
    carries its polygon's first triangle, which it may lie outside).
    ``ids_below``: the render's ``triangles_in``, every id being below it
    (the ids are not checked again where that is at most the faces shaded).
    """
    source, colors, uniform = color_source(mesh, params)
    vertices, faces, normals, vertex_colors = mesh.for_shading(
        normals=params.mode == "smooth", vertex_colors=source == "vertex")
    return _core.shade(
        triangle_id, vertices, faces,
        mvp=mvp,
        viewer=camera.viewer(), light_dir=params.light_dir,
        ambient=params.ambient, diffuse=params.diffuse,
        background=params.background, uniform_color=uniform,
        color_source=source, colors=vertex_colors if source == "vertex" else colors,
        vertex_normals=normals, out=out, pixels_beyond_faces=polygons,
        ids_below=ids_below,
    )


def render(mesh, algo: str = "zbuffer", camera: Optional[Camera] = None,
           width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1], *,
           cull_backfaces: bool = False, shading: str = "flat", light_dir=None,
           ambient: float = DEFAULT_AMBIENT, diffuse: float = DEFAULT_DIFFUSE, color=None,
           background=DEFAULT_BACKGROUND, record_culls: bool = False,
           out=None) -> RenderResult:
    """Render a mesh with one of the depth algorithms.

    Parameters
    ----------
    mesh : Mesh, trimesh.Trimesh, trimesh.Scene, pyvista.PolyData, (vertices, faces) or path
        What to draw. Scenes are concatenated, PolyData is triangulated (other
        pyvista datasets: their outer surface), a path
        is read with :func:`zbuffer.load`.
    algo : str
        A name from :func:`zbuffer.algorithms`. Every algorithm gives the same
        depth and triangle ids; they differ in speed, memory and statistics.
        The exception: ``"scanline"`` draws the polygon faces of a mesh that
        has them (OBJ, OFF or PLY files with quads or n-gons) natively, as
        docs/rasterization.md defines them, and
        ``zbuffer.reference.render(..., polygons=True)`` reproduces it.
    camera : Camera, optional
        None frames the whole mesh (perspective, 45 degrees, from +z). Unset
        near/far are fitted to the mesh.
    width, height : int
        Image size in pixels.
    cull_backfaces : bool
        Skip triangles wound clockwise in NDC (seen from behind). Off by
        default so that open meshes show both sides.
    shading : {"flat", "smooth", "none"}
        Face normals, interpolated vertex normals, or no image at all
        (visibility only: depth and triangle ids).
    light_dir : (3,) array_like of float, optional
        Direction the light travels in (world space); default: along the
        camera's viewing direction (a headlight).
    ambient, diffuse : float
        Lambert weights: colour = albedo * (ambient + diffuse * max(0, n . l));
        default 0.2 and 0.8 (finite, from 0 to float32's largest).
    color : (3,) array_like of int (0-255) or float (0-1), optional
        Uniform albedo (RGB) overriding the mesh's own vertex or face
        colours. Default: the mesh's colours, else light grey.
    background : (3,) array_like of int (0-255) or float (0-1)
        Colour (RGB) of pixels where nothing was drawn; default white.
    record_culls : bool
        Algorithms with a Z-pyramid (``hiz``, ``hiz_octree``, ``hiz_bvh``):
        also record where the pyramid culled, cell by cell, in
        ``RenderResult.culls`` (for :func:`zbuffer.viz.show_pyramid`). Costs
        a little time per culled triangle and an int64 count per pyramid
        cell (about 11 bytes per pixel of address space, the core counting
        into the result's arrays; memory is used only where a count is
        made: zeroed pages untouched stay unallocated); ValueError for other
        algorithms.
    out : RenderResult, or tuple of (H, W) float32, (H, W) int32 [, (H, W, 3) uint8], optional
        Arrays to render into instead of new ones: a result of an earlier
        render of the same size (its ``depth``, ``triangle_id`` and, when
        this render shades, its ``image`` if it has one), or a tuple
        ``(depth, triangle_id)`` or ``(depth, triangle_id, image)``. Depth
        and ids need contiguous rows (C-contiguous or padded, the same
        number of pixels apart in both), the image C-contiguous; all
        writeable, sharing no memory with each other or the mesh. They are
        overwritten whole and the returned result holds them. Saves allocating (and the
        operating system zeroing) new arrays every frame: about 10 ms a
        frame at 4096 x 4096 (docs/api.md).

    Returns
    -------
    RenderResult
        ``image`` (H, W, 3) uint8 or None, ``depth`` (H, W) float32,
        ``triangle_id`` (H, W) int32, ``stats`` dict, ``camera``, ``mvp``.

    Raises
    ------
    ValueError
        Unknown ``algo`` or ``shading``, bad image size, degenerate camera,
        invalid mesh data (see :class:`Mesh`), ``out`` arrays of the wrong
        shape or layout or sharing memory (or in use by another render),
        ``record_culls`` with an algorithm without a Z-pyramid.
    TypeError
        Arguments of the wrong type (``out`` arrays of the wrong dtype among
        them).
    FileNotFoundError
        ``mesh`` is a path that does not exist (:func:`load`).
    """
    start = time.perf_counter()
    check_algorithm(algo)
    mesh, camera, mvp, width, height, params = prepare(
        mesh, camera, width, height, shading, light_dir, ambient, diffuse, color, background,
        cull_backfaces)
    record_culls = check_flag("record_culls", record_culls)  # (in Scene.render's order)
    depth, ids, image = output_arrays(out, width, height, mesh)
    with claimed((depth, ids, image)):
        planes = render_visibility(mesh, algo, mvp, width, height, cull_backfaces,
                                   record_culls, out_depth=depth, out_ids=ids)
        return finish(mesh, camera, mvp, params, algo, *planes, start=start, out_image=image)


def render_visibility(mesh: Mesh, algo: str, mvp, width: int, height: int,
                      cull_backfaces: bool, record_culls: bool, **outputs) -> tuple:
    """The compiled call of an algorithm that needs no tree built beforehand
    (for :func:`render` and :meth:`Scene.render`): the polygons as written for
    an algorithm that draws them natively, the faces in visiting order
    otherwise. ``outputs``: out_depth and out_ids of ``_core.render``.
    Returns ``_core.render``'s tuple."""
    if algo == "scanline":
        # (The core's render refuses it too, but only after the mesh is prepared.)
        _core.check_scanline_faces(len(mesh.faces))
    if draws_polygons(algo, mesh):
        # Polygons as written; faces in polygon order for those drawn as triangles.
        return Visit(mesh.vertices, mesh.faces).render(
            mvp, width, height, algo, cull_backfaces, polygon_offsets=mesh.polygon_offsets,
            polygon_indices=mesh.polygon_indices, record_culls=record_culls, **outputs)
    return mesh.faces_for_render().render(mvp, width, height, algo, cull_backfaces,
                                          record_culls=record_culls, **outputs)


def draws_polygons(algo: str, mesh: Mesh) -> bool:
    """Whether ``algo`` draws ``mesh``'s polygon faces natively."""
    return algo in _POLYGON_ALGORITHMS and mesh.polygon_sizes is not None


_OUTPUTS = (("depth", np.float32, ()), ("triangle_id", np.int32, ()), ("image", np.uint8, (3,)))


def _padded_rows(a: np.ndarray) -> bool:
    """Whether a 2-D array's rows are contiguous and a whole number of
    elements apart, at least its width: a render's planes at the widths
    where the core pads them (docs/api.md)."""
    row, col = a.strides
    return col == a.itemsize and row % a.itemsize == 0 and row >= a.shape[1] * a.itemsize


def output_arrays(out, width: int, height: int, mesh: Mesh) -> tuple:
    """``out=`` of :func:`render` and :meth:`Scene.render`, checked, as
    (depth, triangle_id, image): each an array to render into, or None for a
    new one. None of them may share memory with another or with any array of
    ``mesh`` (its own, its colours, its prepared copies): a render writes the
    outputs while it and the shading pass read the mesh. (The core checks
    the arrays it is given again.)"""
    if out is None:
        return None, None, None
    if isinstance(out, RenderResult):
        arrays = (out.depth, out.triangle_id, out.image)
    elif isinstance(out, tuple) and len(out) in (2, 3):
        arrays = tuple(out) + (None,) * (3 - len(out))
    else:
        raise TypeError("out must be a RenderResult or a tuple (depth, triangle_id[, image]), "
                        f"got {type(out).__name__}")
    for (name, dtype, tail), a in zip(_OUTPUTS, arrays):
        if a is None and name == "image":
            continue
        if not isinstance(a, np.ndarray):
            raise TypeError(f"out: {name} must be a numpy array, got {type(a).__name__}")
        if a.dtype != dtype:
            raise TypeError(f"out: {name} must have dtype {np.dtype(dtype)}, got {a.dtype}")
        if a.shape != (height, width) + tail:
            raise ValueError(f"out: {name} has shape {a.shape}; this render needs "
                             f"{(height, width) + tail}")
        if not (a.flags.c_contiguous or (name != "image" and _padded_rows(a))):
            raise ValueError(f"out: {name} must be C-contiguous"
                             + ("" if name == "image" else " or have contiguous, padded rows"))
        if not a.flags.writeable:
            raise ValueError(f"out: {name} must be writeable")
    if height > 1 and arrays[0].strides[0] // 4 != arrays[1].strides[0] // 4:
        raise ValueError("out: depth and triangle_id must have their rows the same number of "
                         f"pixels apart, got {arrays[0].strides[0] // 4} and "
                         f"{arrays[1].strides[0] // 4}")
    present = [(name, a) for (name, _, _), a in zip(_OUTPUTS, arrays) if a is not None]
    for i, (name, a) in enumerate(present):
        for other, b in present[i + 1:]:
            if _share_memory(a, b):
                raise ValueError(f"out: {name} and {other} share memory")
        for other, b in mesh.arrays():
            if _share_memory(a, b):
                raise ValueError(f"out: {name} shares memory with the mesh's {other}")
    return arrays


_TooHardError = getattr(getattr(np, "exceptions", np), "TooHardError")


def _share_memory(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether a and b have an element in common: views that only interleave
    (the left and right halves of one wider array) do not. Where numpy
    cannot tell within a bounded effort, they are taken to share."""
    try:
        return bool(np.shares_memory(a, b, max_work=100_000))
    except _TooHardError:
        return True


# The caller's arrays that renders are writing into now (out=), so that a
# second render into any of them while the first runs is refused: its
# shading would read ids the other render is writing -- ids of another mesh,
# perhaps, beyond this one's faces.
_CLAIM_LOCK = threading.Lock()
_CLAIMED: List[np.ndarray] = []


@contextmanager
def claimed(arrays):
    """Hold the arrays of ``out=`` (None entries aside) for one render;
    ValueError if another render holds memory of theirs."""
    mine = [a for a in arrays if a is not None]
    with _CLAIM_LOCK:
        for a in mine:
            if any(_share_memory(a, b) for b in _CLAIMED):
                raise ValueError("out: another render is writing into these arrays now; "
                                 "renders that run at the same time need arrays of their own")
        _CLAIMED.extend(mine)
    try:
        yield
    finally:
        with _CLAIM_LOCK:
            for a in mine:
                del _CLAIMED[next(k for k, b in enumerate(_CLAIMED) if b is a)]


def check_algorithm(algo, takes_camera: bool = True) -> None:
    """ValueError unless ``algo`` names a registered algorithm (TypeError
    for what is not a name at all). ``takes_camera``: whether the caller
    has a ``camera=`` to point a misplaced Camera to."""
    if isinstance(algo, Camera):  # render(mesh, cam): Scene.render takes the camera first
        raise TypeError("algo must be an algorithm name, got a Camera"
                        + (": pass it as camera=... (render's second argument is algo)"
                           if takes_camera else ""))
    if not isinstance(algo, str):
        raise TypeError(f"algo must be an algorithm name (a str), got {type(algo).__name__}")
    if algo not in _ALGORITHMS:
        raise ValueError(
            f"unknown algorithm {algo!r}; valid values are {', '.join(map(repr, _ALGORITHMS))}"
        )


def finish(mesh: Mesh, camera: Camera, mvp: np.ndarray, params: ShadingParams, algo: str,
           depth: np.ndarray, triangle_id: np.ndarray, stats: dict, culls=None, *,
           start: float, out_image: Optional[np.ndarray] = None) -> RenderResult:
    """Shade (unless shading is "none"; into ``out_image`` if given), time,
    and wrap up a render."""
    image = None
    shade_ms = 0.0
    if params.mode != "none":
        t0 = time.perf_counter()
        image = shade(mesh, triangle_id, camera, mvp, params, out=out_image,
                      polygons=draws_polygons(algo, mesh), ids_below=stats["triangles_in"])
        shade_ms = (time.perf_counter() - t0) * 1e3
    stats["shade_ms"] = shade_ms
    stats["total_ms"] = (time.perf_counter() - start) * 1e3
    return RenderResult(image=image, depth=depth, triangle_id=triangle_id, stats=stats,
                        camera=camera, mvp=mvp, algo=algo, culls=culls)
