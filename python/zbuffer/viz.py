"""Seeing results: pyvista views of renders and Z-pyramids.

Every function opens a window (or shows inline in a notebook) by default,
and writes a PNG instead when given ``screenshot=``: that is how they run on
machines without a display (VTK renders offscreen through EGL with Mesa).

>>> res = zbuffer.render(mesh, algo="hiz")
>>> zbuffer.viz.show_result(res, screenshot="result.png")     # image | depth | ids
>>> zbuffer.viz.show_pyramid(res, screenshot="pyramid.png")   # every level, one colour scale
"""

from __future__ import annotations

import os
from typing import Dict, Iterable, List, Optional, Sequence, Union

import numpy as np

from .result import RenderResult

__all__ = ["show_result", "show_pyramid", "show_pyramid_stack", "compare_algorithms",
           "id_colors", "depth_for_display"]


def _pyvista():
    try:
        import pyvista as pv
    except ImportError as err:  # pragma: no cover - pyvista is in the test extra
        raise ImportError("zbuffer.viz needs pyvista: pip install 'zbuffer[viz]'") from err
    # EGL instead of X where there is no display: no 'bad X server' warning.
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    return pv


def id_colors(triangle_id: np.ndarray, seed: int = 0) -> np.ndarray:
    """(H, W, 3) uint8 false colours for a triangle-id map: each id its own
    colour (from a hash, stable across renders), black where nothing was drawn."""
    ids = np.asarray(triangle_id).astype(np.int64)
    h = (ids * 2654435761 + seed) & 0xFFFFFF
    rgb = np.stack([(h >> 16) & 255, (h >> 8) & 255, h & 255], -1).astype(np.uint8)
    rgb = (rgb // 2 + 96).astype(np.uint8)  # keep them light enough to tell apart
    rgb[ids < 0] = 0
    return rgb


def depth_for_display(depth: np.ndarray) -> np.ndarray:
    """float64 copy of a depth map with +inf (nothing drawn) as NaN."""
    d = np.asarray(depth, dtype=np.float64).copy()
    d[~np.isfinite(d)] = np.nan
    return d


def _image_plane(pv, values: np.ndarray):
    """An ImageData with one cell per pixel, row 0 at the top."""
    h, w = values.shape[:2]
    grid = pv.ImageData(dimensions=(w + 1, h + 1, 1))
    flat = values[::-1].reshape(h * w, *values.shape[2:])  # ImageData rows go up
    grid.cell_data["values"] = flat
    return grid


def _add_image(plotter, pv, values, title, rgb=False, clim=None, cmap="viridis",
               scalar_bar=True):
    grid = _image_plane(pv, values)
    if rgb:
        plotter.add_mesh(grid, scalars="values", rgb=True, show_scalar_bar=False)
    else:
        plotter.add_mesh(grid, scalars="values", cmap=cmap, clim=clim, nan_color="black",
                         show_scalar_bar=False)
        if scalar_bar:
            plotter.add_scalar_bar(title=title, vertical=True, n_labels=3, fmt="%.4f")
    plotter.add_text(title, font_size=10)
    plotter.view_xy()
    plotter.enable_parallel_projection()
    plotter.reset_camera(bounds=grid.bounds)
    plotter.camera.zoom(1.0)


def _finish(plotter, screenshot: Optional[str]):
    if screenshot is not None:
        image = plotter.screenshot(screenshot)
        plotter.close()
        return image
    plotter.show()
    return plotter


def _plotter(pv, shape, window_size, screenshot):
    plotter = pv.Plotter(shape=shape, off_screen=screenshot is not None, window_size=window_size,
                         border=False)
    plotter.set_background("white")
    return plotter


def show_result(result: RenderResult, screenshot: Optional[str] = None,
                window_size=(1500, 450)):
    """The shaded image, the depth map (with a colour bar) and the triangle
    ids in false colour, side by side.

    Parameters
    ----------
    result : RenderResult
    screenshot : str, optional
        Write a PNG there instead of opening a window.
    window_size : (int, int)

    Returns
    -------
    (H, W, 3|4) uint8 array of the screenshot, or the pyvista Plotter shown.
    """
    pv = _pyvista()
    panels = []
    if result.image is not None:
        panels.append(("image", result.image, dict(rgb=True)))
    panels.append(("depth", depth_for_display(result.depth), dict(cmap="viridis_r")))
    panels.append(("triangle id", id_colors(result.triangle_id), dict(rgb=True)))
    plotter = _plotter(pv, (1, len(panels)), window_size, screenshot)
    for k, (title, values, options) in enumerate(panels):
        plotter.subplot(0, k)
        _add_image(plotter, pv, values, title, **options)
    return _finish(plotter, screenshot)


def _levels(source) -> List[np.ndarray]:
    if isinstance(source, RenderResult):
        return source.pyramid()
    return [np.asarray(level) for level in source]


def show_pyramid(source: Union[RenderResult, Sequence[np.ndarray]], screenshot: Optional[str] = None,
                 levels: Optional[Iterable[int]] = None, window_size=None):
    """Z-pyramid levels side by side, one shared colour scale (depth of the
    farthest pixel under each cell; black where nothing was drawn).

    Parameters
    ----------
    source : RenderResult or list of (h, w) float32 arrays
        A render (its pyramid is computed) or levels as from
        :meth:`RenderResult.pyramid`.
    screenshot : str, optional
        Write a PNG there instead of opening a window.
    levels : iterable of int, optional
        Which levels to show (default: all down to 4 x 4 cells or less).
    """
    pv = _pyvista()
    pyramid = _levels(source)
    chosen = list(levels) if levels is not None else [
        k for k, level in enumerate(pyramid) if k == 0 or min(pyramid[k - 1].shape) > 4]
    shown = [depth_for_display(pyramid[k]) for k in chosen]
    finite = np.concatenate([s[np.isfinite(s)] for s in shown] + [np.zeros(0)])
    clim = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    cols = len(chosen)
    size = window_size or (min(360 * cols, 2400), 380)
    plotter = _plotter(pv, (1, cols), size, screenshot)
    for k, (level, values) in enumerate(zip(chosen, shown)):
        plotter.subplot(0, k)
        h, w = values.shape
        _add_image(plotter, pv, values, f"level {level}: {w}x{h}", clim=clim, cmap="viridis_r",
                   scalar_bar=k == cols - 1)
    return _finish(plotter, screenshot)


def show_pyramid_stack(source: Union[RenderResult, Sequence[np.ndarray]],
                       screenshot: Optional[str] = None, spacing: float = 0.25,
                       window_size=(900, 900)):
    """The pyramid as a 3D stack of planes: level 0 (the depth map) at the
    bottom, each coarser level above it, all at the image's scale, so a cell
    sits right over the pixels it bounds."""
    pv = _pyvista()
    pyramid = _levels(source)
    h, w = pyramid[0].shape
    shown = [depth_for_display(level) for level in pyramid]
    finite = np.concatenate([d[np.isfinite(d)] for d in shown] + [np.zeros(0)])
    clim = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    plotter = _plotter(pv, (1, 1), window_size, screenshot)
    for k, level in enumerate(shown):
        lh, lw = level.shape
        scale = 2 ** k
        grid = pv.ImageData(dimensions=(lw + 1, lh + 1, 1), spacing=(scale, scale, 1),
                            origin=(0, h - lh * scale, k * spacing * max(w, h)))
        grid.cell_data["depth"] = level[::-1].reshape(-1)
        plotter.add_mesh(grid, scalars="depth", cmap="viridis_r", clim=clim, nan_color="black",
                         nan_opacity=0.08, opacity=1.0 if k == 0 else 0.85,
                         show_scalar_bar=k == 0, show_edges=lw <= 32)
    plotter.add_text("Z-pyramid: each level the max of 2x2 cells below", font_size=10)
    plotter.view_isometric()
    return _finish(plotter, screenshot)


def compare_algorithms(mesh, camera=None, width: int = 320, height: int = 240,
                       algos: Optional[Sequence[str]] = None, screenshot: Optional[str] = None,
                       **render_options) -> Dict[str, RenderResult]:
    """The same view rendered by several algorithms: their images with times
    and counters, and the difference of their depth maps from the first one's
    (all zeros: they agree bit for bit -- except ``"scanline"`` on a mesh with
    polygon faces, which it draws natively: docs/rasterization.md, 3.7).

    Returns
    -------
    dict
        algorithm name -> RenderResult (the screenshot, if any, is written).
    """
    from .api import algorithms, render

    pv = _pyvista()
    names = list(algos) if algos is not None else algorithms()
    results = {name: render(mesh, algo=name, camera=camera, width=width, height=height,
                            **render_options) for name in names}
    first = results[names[0]]
    plotter = _plotter(pv, (2, len(names)), (400 * len(names), 720), screenshot)
    for k, name in enumerate(names):
        res = results[name]
        plotter.subplot(0, k)
        picture = res.image if res.image is not None else id_colors(res.triangle_id)
        _add_image(plotter, pv, picture, f"{name}: {res.stats['render_ms']:.2f} ms, "
                   f"{res.stats['rasterized']:,} drawn, {res.stats.get('culled_hidden', 0):,} culled",
                   rgb=True)
        plotter.subplot(1, k)
        same = np.where(np.isfinite(first.depth), first.depth, 0.0)
        other = np.where(np.isfinite(res.depth), res.depth, 0.0)
        diff = np.abs(other.astype(np.float64) - same)
        diff[res.triangle_id != first.triangle_id] = 1.0
        _add_image(plotter, pv, diff, f"|depth - {names[0]}| (max {diff.max():g})",
                   clim=(0.0, max(float(diff.max()), 1e-12)), cmap="magma")
    _finish(plotter, screenshot)
    return results
