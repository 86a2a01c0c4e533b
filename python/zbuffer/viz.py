"""Seeing results: pyvista views of renders and Z-pyramids.

Every function opens a window (or shows inline in a notebook) by default,
and writes a PNG instead when given ``screenshot=``: that is how they run on
machines without a display (VTK renders offscreen through EGL with Mesa).

>>> res = zbuffer.render(mesh, algo="hiz")
>>> zbuffer.viz.show_result(res, screenshot="result.png")     # image | depth | ids
>>> zbuffer.viz.show_pyramid(res, screenshot="pyramid.png")   # every level, one colour scale
>>> scene = zbuffer.Scene(mesh)
>>> seen = scene.render(camera, algo="hiz_octree")
>>> zbuffer.viz.show_tree(scene, "hiz_octree", result=seen)   # octree boxes by fate, frustum
"""

from __future__ import annotations

import os
import sys
from typing import Dict, Iterable, List, Optional, Sequence, Union

import numpy as np

from . import _core
from .checks import check_choice, check_index, check_int
from .result import RenderResult

__all__ = ["show_result", "show_pyramid", "show_pyramid_stack", "compare_algorithms",
           "show_tree", "tree_grid", "frustum_grid", "id_colors", "depth_for_display",
           "depth_grey", "most_culling_cells", "load_benchmark", "plot_grid_times",
           "plot_grid_culling", "plot_models"]


# (require_pyvista, image_plane, can_open_window, check_window,
# screenshot_target and take_screenshot are not in __all__: they are the
# package's own, shared with viewer.py and cli.py.)


def require_pyvista():
    """pyvista, imported (ImportError naming the extra to install if it is
    missing)."""
    try:
        import pyvista as pv
    except ImportError as err:  # pragma: no cover - pyvista is in the test extra
        raise ImportError("zbuffer.viz needs pyvista: pip install 'zbuffer[viz]'") from err
    # EGL instead of X where there is no display: no 'bad X server' warning.
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    return pv


def id_colors(triangle_id: np.ndarray, seed: int = 0) -> np.ndarray:
    """False colours for a triangle-id map, black where nothing was drawn.

    Each id's colour comes from a hash of it (stable across renders), with 7
    bits a channel kept light: the first 100,000 ids all differ, but among
    more some share a colour (6.7% of the first million ids repeat an
    earlier id's colour).

    Parameters
    ----------
    triangle_id : (H, W) int array
        Ids as :attr:`RenderResult.triangle_id`, -1 where nothing was drawn.
    seed : int
        Mixed into the hash: another seed, other colours.

    Returns
    -------
    (H, W, 3) uint8
    """
    ids = np.asarray(triangle_id).astype(np.int64)
    h = (ids * 2654435761 + seed) & 0xFFFFFF
    rgb = np.stack([(h >> 16) & 255, (h >> 8) & 255, h & 255], -1).astype(np.uint8)
    rgb = (rgb // 2 + 96).astype(np.uint8)  # keep them light enough to tell apart
    rgb[ids < 0] = 0
    return rgb


def depth_grey(depth: np.ndarray, white: int, darkest: int) -> np.ndarray:
    """Grey levels of a depth map scaled to the image (for ``zbuffer render
    --depth`` and the viewer's depth overlay).

    Parameters
    ----------
    depth : (H, W) float array
        Any depth (window depth, :meth:`RenderResult.eye_depth`), +inf where
        nothing was drawn.
    white, darkest : int
        The levels of the nearest and of the farthest drawn depth; the
        others in proportion between them.

    Returns
    -------
    (H, W) int64
        The levels; 0 where nothing was drawn.
    """
    out = np.zeros(np.shape(depth), np.int64)
    drawn = np.isfinite(depth)
    if drawn.any():
        d = np.asarray(depth)[drawn].astype(np.float64)
        lo, hi = d.min(), d.max()
        t = (d - lo) / (hi - lo) if hi > lo else np.zeros_like(d)
        out[drawn] = np.round(white - t * (white - darkest)).astype(np.int64)
    return out


def depth_for_display(depth: np.ndarray) -> np.ndarray:
    """A depth map for pyvista's colour maps, which draw NaN in their own
    colour.

    Parameters
    ----------
    depth : (H, W) float array

    Returns
    -------
    (H, W) float64
        A copy, with +inf (nothing drawn) as NaN.
    """
    d = np.asarray(depth, dtype=np.float64).copy()
    d[~np.isfinite(d)] = np.nan
    return d


def image_plane(pv, values: np.ndarray):
    """An ImageData with one cell per pixel, row 0 at the top."""
    h, w = values.shape[:2]
    grid = pv.ImageData(dimensions=(w + 1, h + 1, 1))
    flat = values[::-1].reshape(h * w, *values.shape[2:])  # ImageData rows go up
    grid.cell_data["values"] = flat
    return grid


def _add_image(plotter, pv, values, title, rgb=False, clim=None, cmap="viridis",
               scalar_bar=True, bar_title=None, nan_color="black"):
    grid = image_plane(pv, values)
    # Unlit: a picture shows its own colours (lit, the white background of a
    # render came out (200, 197, 189)).
    if rgb:
        plotter.add_mesh(grid, scalars="values", rgb=True, show_scalar_bar=False,
                         lighting=False)
    else:
        plotter.add_mesh(grid, scalars="values", cmap=cmap, clim=clim, nan_color=nan_color,
                         show_scalar_bar=False, lighting=False)
        if scalar_bar:
            # Under the picture, inside its panel (upright at the right edge,
            # the title and labels were cut off by the window's border).
            plotter.add_scalar_bar(title=title if bar_title is None else bar_title,
                                   vertical=False, position_x=0.2, position_y=0.03,
                                   width=0.6, height=0.1, n_labels=3, fmt="%.4g")
    plotter.add_text(title, font_size=10)
    plotter.view_xy()
    plotter.enable_parallel_projection()
    plotter.reset_camera(bounds=grid.bounds)
    plotter.camera.zoom(1.0)


# What a screenshot may be written as (pyvista's choice), by suffix.
_SCREENSHOT_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".bmp": "BMP",
                       ".tif": "TIFF", ".tiff": "TIFF"}


def screenshot_target(screenshot):
    """(target, format) for ``screenshot``: True (no file: (None, None)), a
    file object (PNG), or a path -- ``~`` expanded, ``.png`` added where it
    has no suffix, any of :data:`_SCREENSHOT_FORMATS`' suffixes in any case;
    ValueError for another suffix, a folder or no name at all, or a folder
    that does not exist (checked before anything is drawn)."""
    if screenshot is True:
        return None, None
    if hasattr(screenshot, "write"):
        return screenshot, "PNG"
    given = os.fsdecode(os.fspath(screenshot))
    path = os.path.expanduser(given)
    if not path or path.endswith(("/", os.sep)) or os.path.isdir(path):
        raise ValueError(f"screenshot {given!r} is not a file name")
    folder = os.path.dirname(path) or "."
    if not os.path.isdir(folder):
        raise ValueError(f"screenshot {given!r}: no folder {folder!r} to write it in")
    suffix = os.path.splitext(path)[1].lower()
    if not suffix:
        return path + ".png", "PNG"
    if suffix not in _SCREENSHOT_FORMATS:
        raise ValueError(f"screenshot {given!r}: the file name must end in "
                         f"{', '.join(_SCREENSHOT_FORMATS)}")
    return path, _SCREENSHOT_FORMATS[suffix]


def take_screenshot(plotter, screenshot):
    """The plotter's picture, also written to ``screenshot`` unless it is True
    (:func:`screenshot_target`; by Pillow, which takes a suffix in capitals,
    as .PNG, where pyvista refused it); the plotter is closed."""
    target, fmt = screenshot_target(screenshot)
    image = plotter.screenshot(None)
    plotter.close()
    if target is not None:
        from PIL import Image  # (Pillow: scikit-image's own image library)

        picture = Image.fromarray(image)
        if fmt == "JPEG" and picture.mode == "RGBA":  # (a transparent background)
            picture = picture.convert("RGB")
        picture.save(target, format=fmt)
    return image


def offscreen(screenshot) -> bool:
    """Whether a view's ``screenshot`` argument asks for a picture drawn
    offscreen (a file, a file object or True) rather than a window (None or
    False)."""
    return screenshot is not None and screenshot is not False


def _finish(plotter, screenshot):
    """Show the plotter, or with ``screenshot`` (a path, or True for no file)
    render it offscreen and return the picture."""
    if offscreen(screenshot):
        return take_screenshot(plotter, screenshot)
    plotter.show()
    return plotter


def can_open_window() -> bool:
    """Whether a window can be opened here (a display, or a desktop system)."""
    return sys.platform in ("win32", "darwin") or bool(os.environ.get("DISPLAY")
                                                       or os.environ.get("WAYLAND_DISPLAY"))


def check_window(plotter) -> None:
    """RuntimeError (the plotter closed) for a plotter that would open a
    window where none can open -- no display, not offscreen, not in a
    notebook -- rather than pyvista's warning and nothing shown."""
    if plotter.off_screen or plotter.notebook or can_open_window():
        return
    plotter.close()
    raise RuntimeError("no display to open a window on: pass screenshot='picture.png' to write "
                       "a PNG file instead")


def _plotter(pv, shape, window_size, screenshot):
    drawn_offscreen = offscreen(screenshot)
    if drawn_offscreen:
        screenshot_target(screenshot)  # (a bad file name said before anything is drawn)
    # (None: pyvista's own setting, pyvista.OFF_SCREEN)
    plotter = pv.Plotter(shape=shape, off_screen=True if drawn_offscreen else None,
                         window_size=window_size, border=False)
    check_window(plotter)
    plotter.set_background("white")
    return plotter


def show_result(result: RenderResult, screenshot: Union[str, bool, None] = None,
                window_size=(1500, 450)):
    """The shaded image, the depth map (with a colour bar) and the triangle
    ids in false colour, side by side.

    Parameters
    ----------
    result : RenderResult
    screenshot : str or True, optional
        Write the picture there (PNG, or JPEG, BMP or TIFF by the file's
        suffix) instead of opening a window (True: render
        offscreen and only return the picture).
    window_size : (int, int)

    Returns
    -------
    (H, W, 3|4) uint8 array of the screenshot, or the pyvista Plotter shown.
    """
    pv = require_pyvista()
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
    levels = [np.asarray(level) for level in source]
    if not levels:
        raise ValueError("no pyramid levels to show")
    return levels


def show_pyramid(source: Union[RenderResult, Sequence[np.ndarray]], screenshot: Union[str, bool, None] = None,
                 levels: Optional[Iterable[int]] = None, window_size=None,
                 highlight_culls: Union[bool, int] = False):
    """Z-pyramid levels side by side, one shared colour scale: the depth of
    the farthest pixel under each cell, near bright, far dark; grey where a
    pixel under the cell was not drawn (+inf: such a cell never culls).

    Parameters
    ----------
    source : RenderResult or list of (h, w) float32 arrays
        A render (its pyramid is computed) or levels as from
        :meth:`RenderResult.pyramid`.
    screenshot : str or True, optional
        Write the picture there (PNG, or JPEG, BMP or TIFF by the file's
        suffix) instead of opening a window (True: render
        offscreen and only return the picture).
    levels : iterable of int, optional
        Which levels to show (default: all down to 4 x 4 cells or less).
    window_size : (int, int), optional
        Pixels of the window or screenshot (default: 360 wide per level shown,
        at most 2400, by 380).
    highlight_culls : bool or int
        Outline in red, on every level shown, the cells that culled the most
        triangles (True: the top 5 of each level; an int: that many), and
        give each level's total in its title. Needs a render made with
        ``record_culls=True`` (:attr:`RenderResult.culls`).

    Returns
    -------
    (H, W, 3|4) uint8 array of the screenshot, or the pyvista Plotter shown.
    """
    pv = require_pyvista()
    pyramid = _levels(source)
    top = _highlight_count(highlight_culls)
    if top and (not isinstance(source, RenderResult) or source.culls is None):
        raise ValueError("highlight_culls needs a RenderResult rendered with record_culls=True "
                         "by an algorithm with a Z-pyramid (hiz, hiz_octree, hiz_bvh)")
    chosen = list(levels) if levels is not None else [
        k for k, level in enumerate(pyramid) if k == 0 or min(pyramid[k - 1].shape) > 4]
    if not chosen:
        raise ValueError("levels: no level to show")
    for i, k in enumerate(chosen):
        try:
            chosen[i] = check_index("levels", k)
        except TypeError:
            chosen[i] = -1  # (refused below)
        if not 0 <= chosen[i] < len(pyramid):
            raise ValueError(f"levels: {k!r} is not a level of this pyramid "
                             f"(0 .. {len(pyramid) - 1})")
    shown = [depth_for_display(pyramid[k]) for k in chosen]
    finite = np.concatenate([s[np.isfinite(s)] for s in shown] + [np.zeros(0)])
    clim = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    cols = len(chosen)
    size = window_size or (min(360 * cols, 2400), 380)
    plotter = _plotter(pv, (1, cols), size, screenshot)
    for k, (level, values) in enumerate(zip(chosen, shown)):
        plotter.subplot(0, k)
        h, w = values.shape
        title = f"level {level}: {w}x{h}"
        if top:
            counts = source.culls[level]
            title += f", {int(counts.sum()):,} culls counted"
        _add_image(plotter, pv, values, title, clim=clim, cmap="viridis_r",
                   scalar_bar=k == cols - 1, bar_title="depth", nan_color="#c8c8c8")
        if top:
            outlines = _cell_outlines(pv, most_culling_cells(counts, top), h)
            if outlines is not None:
                plotter.add_mesh(outlines, color="red", line_width=3)
    return _finish(plotter, screenshot)


def _highlight_count(highlight) -> int:
    if isinstance(highlight, (bool, np.bool_)):
        return 5 if highlight else 0
    if not isinstance(highlight, (int, np.integer)):
        raise TypeError(f"highlight_culls must be a bool or a count >= 0, got {highlight!r}")
    if highlight < 0:
        raise ValueError(f"highlight_culls must be a bool or a count >= 0, got {highlight!r}")
    return int(highlight)


def most_culling_cells(counts: np.ndarray, n: int) -> np.ndarray:
    """The cells of one level of :attr:`RenderResult.culls` that culled most.

    Parameters
    ----------
    counts : (h, w) int64 array
        One level's counts.
    n : int
        How many cells at most.

    Returns
    -------
    (k, 2) int64 array
        (row, column) of the at most ``n`` cells with the highest counts,
        highest first (cells that culled nothing are left out; ties by
        position).
    """
    n = check_int("n", n, 0)
    if isinstance(counts, (list, tuple)):
        raise TypeError("counts: one level of RenderResult.culls (res.culls[k]), not the list "
                        "of levels")
    counts = np.asarray(counts)
    if counts.ndim != 2:
        raise ValueError(f"counts must be one level's (h, w) array, got shape {counts.shape}")
    flat = counts.ravel()
    order = np.argsort(-flat, kind="stable")[:n]
    order = order[flat[order] > 0]
    return np.stack(np.unravel_index(order, counts.shape), axis=1)


def _cell_outlines(pv, cells: np.ndarray, h: int):
    """The outlines of cells (row, column) of an image plane of h rows, as
    one PolyData of line loops, just above the plane; None for no cells."""
    if len(cells) == 0:
        return None
    rows, cols = cells[:, 0], cells[:, 1]
    x0, x1 = cols.astype(float), cols + 1.0
    y0, y1 = h - rows - 1.0, h - rows.astype(float)
    corners = np.stack([np.stack([x0, y0], 1), np.stack([x1, y0], 1),
                        np.stack([x1, y1], 1), np.stack([x0, y1], 1)], 1)  # (k, 4, 2)
    points = np.concatenate([corners.reshape(-1, 2), np.full((4 * len(cells), 1), 0.01)], 1)
    base = 4 * np.arange(len(cells))[:, None]
    lines = np.concatenate([np.full((len(cells), 1), 5), base + [0, 1, 2, 3, 0]], 1)
    return pv.PolyData(points, lines=lines.ravel())


def show_pyramid_stack(source: Union[RenderResult, Sequence[np.ndarray]],
                       screenshot: Union[str, bool, None] = None, spacing: float = 0.25,
                       window_size=(900, 900)):
    """The pyramid as a 3D stack of planes: level 0 (the depth map) at the
    bottom, each coarser level above it, all at the image's scale, so a cell
    sits right over the pixels it bounds.

    Parameters
    ----------
    source : RenderResult or list of (h, w) float32 arrays
        A render (its pyramid is computed) or levels as from
        :meth:`RenderResult.pyramid`.
    screenshot : str or True, optional
        As for :func:`show_pyramid`.
    spacing : float
        Height between levels, as a fraction of the image's larger side.
    window_size : (int, int)
        Pixels of the window or screenshot.

    Returns
    -------
    (H, W, 3|4) uint8 array of the screenshot, or the pyvista Plotter shown.
    """
    pv = require_pyvista()
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
                         nan_opacity=0.08, opacity=1.0 if k == 0 else 0.85, lighting=False,
                         show_scalar_bar=k == 0, show_edges=lw <= 32)
    plotter.add_text("Z-pyramid: each level the max of 2x2 cells below", font_size=10)
    plotter.view_isometric()
    return _finish(plotter, screenshot)


def compare_algorithms(mesh, camera=None, width: int = 320, height: int = 240,
                       algos: Optional[Sequence[str]] = None, screenshot: Union[str, bool, None] = None,
                       **render_options) -> Dict[str, RenderResult]:
    """The same view rendered by several algorithms: their images with times
    and counters, and the difference of their depth maps from the first one's
    (all zeros: they agree bit for bit -- except ``"scanline"`` on a mesh with
    polygon faces, which it draws natively: docs/rasterization.md, 3.7).

    Parameters
    ----------
    mesh : Mesh, trimesh.Trimesh, pyvista.PolyData, (vertices, faces) or path
        As for :func:`zbuffer.render`.
    camera : Camera, optional
        As for :func:`zbuffer.render` (None: framed); every algorithm the same.
    width, height : int
        Image size; small by default (320 x 240).
    algos : str or sequence of str, optional
        The algorithm, or the algorithms (each once), in the order shown
        (default: ``zbuffer.algorithms()``); the depth differences are from
        the first.
    screenshot : str or True, optional
        Write a picture of the figure there (PNG, or JPEG, BMP or TIFF by the
        file's suffix) instead of opening a window (True:
        draw it offscreen only; the results are returned either way).
    **render_options
        Passed on to every :func:`zbuffer.render` (``shading``,
        ``cull_backfaces``, ...); ``record_culls`` only to the algorithms
        with a Z-pyramid.

    Returns
    -------
    dict
        algorithm name -> RenderResult (the screenshot, if any, is written).
    """
    from .api import algorithms, render

    pv = require_pyvista()
    if isinstance(algos, str):  # one name (not its letters)
        algos = [algos]
    names = list(algos) if algos is not None else algorithms()
    if not names:
        raise ValueError("algos: give at least one algorithm to compare")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:  # (the results are a dict by name: one would hide the other)
        raise ValueError(f"algos names {repeated[0]!r} more than once")
    # (record_culls: for the algorithms with a Z-pyramid; the others have none to record)
    record = render_options.pop("record_culls", False)
    with_pyramid = set(_core.pyramid_algorithms())
    # The window first: where none can open, say so before rendering anything.
    plotter = _plotter(pv, (2, len(names)), (400 * len(names), 720), screenshot)
    try:
        results = {name: render(mesh, algo=name, camera=camera, width=width, height=height,
                                record_culls=record if name in with_pyramid else False,
                                **render_options)
                   for name in names}
    except BaseException:
        plotter.close()
        raise
    first = results[names[0]]
    same = np.where(np.isfinite(first.depth), first.depth, 0.0)
    diffs = []
    for name in names:
        res = results[name]
        diff = np.abs(np.where(np.isfinite(res.depth), res.depth, 0.0).astype(np.float64) - same)
        diff[res.triangle_id != first.triangle_id] = 1.0
        diffs.append(diff)
    clim = (0.0, max(max(float(d.max()) for d in diffs), 1e-12))  # one scale, one bar
    for k, (name, diff) in enumerate(zip(names, diffs)):
        res = results[name]
        plotter.subplot(0, k)
        picture = res.image if res.image is not None else id_colors(res.triangle_id)
        _add_image(plotter, pv, picture, f"{name}: {res.stats['render_ms']:.2f} ms, "
                   f"{res.stats['rasterized']:,} drawn, "
                   f"{res.stats.get('culled_hidden', 0) + res.stats.get('culled_in_nodes', 0):,} "
                   f"culled",
                   rgb=True)
        plotter.subplot(1, k)
        _add_image(plotter, pv, diff, f"depth difference from {names[0]}: max {diff.max():g}",
                   clim=clim, cmap="magma", scalar_bar=k == 0,
                   bar_title="depth difference (1: another triangle)")
    _finish(plotter, screenshot)
    return results


# Trees

# Colours of the node fates (zbuffer.scene.NODE_FATES, in order).
FATE_COLORS = ("#d0d0d0", "#7fb3e6", "#d62728", "#ff9f1c", "#2ca02c")

# The 8 corners of a box as VTK orders a hexahedron: the bottom face (z low)
# counter-clockwise, then the top face.
_HEX_CORNERS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                         [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=bool)


def tree_grid(scene, algo: str = "hiz_octree", level: Optional[int] = None):
    """The boxes of a Scene's tree as one ``pyvista.UnstructuredGrid`` of
    hexahedra (one cell per node; never one actor per node), with cell data
    ``fate`` (index into :data:`zbuffer.scene.NODE_FATES`, last render),
    ``depth`` (in the tree) and ``triangles`` (in the subtree).

    Parameters
    ----------
    scene : zbuffer.Scene
    algo : {"hiz_octree", "hiz_bvh"}
    level : int, optional
        Only the nodes at this depth in the tree (root 0); default all.

    Returns
    -------
    pyvista.UnstructuredGrid
    """
    pv = require_pyvista()
    nodes = scene.nodes(algo)
    keep = np.ones(len(nodes["depth"]), bool) if level is None else nodes["depth"] == level
    lo, hi = nodes["lo"][keep], nodes["hi"][keep]
    n = len(lo)
    points = np.where(_HEX_CORNERS[None, :, :], hi[:, None, :], lo[:, None, :]).reshape(-1, 3)
    cells = np.hstack([np.full((n, 1), 8), np.arange(8 * n).reshape(n, 8)]).ravel()
    grid = pv.UnstructuredGrid(cells, np.full(n, pv.CellType.HEXAHEDRON, np.uint8), points)
    grid.cell_data["fate"] = nodes["fate"][keep].astype(np.int32)
    grid.cell_data["depth"] = nodes["depth"][keep]
    grid.cell_data["triangles"] = nodes["n_triangles"][keep]
    return grid


def frustum_grid(result: RenderResult):
    """The view volume of a render (its camera's near-to-far frustum) as one
    hexahedron, from the inverse of the result's MVP.

    Parameters
    ----------
    result : RenderResult

    Returns
    -------
    pyvista.UnstructuredGrid
        One hexahedron, its corners in world space.
    """
    pv = require_pyvista()
    inv = np.linalg.inv(result.mvp)
    ndc = np.where(_HEX_CORNERS, 1.0, -1.0)
    clip = np.hstack([ndc, np.ones((8, 1))]) @ inv.T
    points = clip[:, :3] / clip[:, 3:]
    return pv.UnstructuredGrid(np.array([8, *range(8)]), np.array([pv.CellType.HEXAHEDRON], np.uint8),
                               points)


# The depth scale of show_tree: upright at the right edge, clear of the
# title and of the legend's place.
_SIDE_BAR = dict(vertical=True, position_x=0.85, position_y=0.2, width=0.08, height=0.5,
                 title_font_size=12, label_font_size=12)


def show_tree(scene, algo: str = "hiz_octree", result: Optional[RenderResult] = None,
              color_by: str = "fate", level: Optional[int] = None,
              screenshot: Union[str, bool, None] = None, window_size=(900, 700), mesh_opacity: float = 0.35):
    """The mesh and its octree or BVH: every node's box as one wireframe
    grid, coloured by its fate in the last render (culled as hidden or
    outside, visited, drawn) or by its depth in the tree, with the camera's
    view volume when ``result`` (a render of this tree) is given.

    Parameters
    ----------
    scene : zbuffer.Scene
    algo : {"hiz_octree", "hiz_bvh"}
    result : RenderResult, optional
        The last ``scene.render(..., algo=algo)``: its frustum is drawn.
    color_by : {"fate", "depth"}
    level : int, optional
        Show the nodes of one tree depth only. In a window without
        ``level`` or ``screenshot``, a slider picks the depth.
    screenshot : str or True, optional
        Write the picture there (PNG, or JPEG, BMP or TIFF by the file's
        suffix) instead of opening a window (True: render
        offscreen and only return the picture).
    window_size : (int, int)
        Pixels of the window or screenshot.
    mesh_opacity : float
        Opacity of the mesh drawn under the boxes (0: hidden, 1: opaque).

    Returns
    -------
    (H, W, 3|4) uint8 array of the screenshot, or the pyvista Plotter shown.
    """
    from .scene import NODE_FATES

    check_choice("color_by", color_by, ("fate", "depth"))
    pv = require_pyvista()
    plotter = _plotter(pv, (1, 1), window_size, screenshot)
    mesh = scene.mesh
    if len(mesh.faces):
        faces = np.hstack([np.full((len(mesh.faces), 1), 3), mesh.faces]).ravel()
        plotter.add_mesh(pv.PolyData(mesh.vertices, faces), color="#bbbbbb",
                         opacity=mesh_opacity)
    depth_max = int(scene.nodes(algo)["depth"].max(initial=0))
    options = dict(style="wireframe", line_width=1.5)
    if color_by == "fate":
        # A legend of named colours (a categorical scalar bar set its names
        # apart from their colours, or over them).
        options.update(scalars="fate", cmap=list(FATE_COLORS), clim=(-0.5, len(NODE_FATES) - 0.5),
                       n_colors=len(NODE_FATES), show_scalar_bar=False)
        plotter.add_legend([[name, color] for name, color in zip(NODE_FATES, FATE_COLORS)],
                           bcolor="#505050", face="rectangle", size=(0.2, 0.2), loc="upper right")
    else:
        options.update(scalars="depth", cmap="viridis", clim=(0, max(depth_max, 1)),
                       show_scalar_bar=True,
                       scalar_bar_args={"title": "depth in the tree\n", "fmt": "%.0f", **_SIDE_BAR})

    def draw(depth):
        grid = tree_grid(scene, algo, depth)
        if grid.n_cells:
            plotter.add_mesh(grid, name="tree", **options)
        else:
            plotter.remove_actor("tree")

    if level is None and not offscreen(screenshot) and depth_max > 0:
        plotter.add_slider_widget(lambda value: draw(int(round(value))), (0, depth_max),
                                  value=0, title="tree depth", fmt="%.0f")
    else:
        draw(level)
    if result is not None:
        plotter.add_mesh(frustum_grid(result), style="wireframe", color="black", line_width=2)
    what = "octree" if algo == "hiz_octree" else "BVH"
    plotter.add_text(f"{what} of {len(mesh.faces):,} triangles"
                     + ("" if level is None else f", depth {level}"), font_size=10)
    # Seen from a corner, framed on the tree: the view volume reaches far
    # past it (framed on both, the tree was a small part of the picture).
    nodes = scene.nodes(algo)
    if len(nodes["lo"]):
        lo, hi = nodes["lo"].min(axis=0), nodes["hi"].max(axis=0)
        plotter.view_isometric()
        plotter.reset_camera(bounds=(lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]))
        plotter.camera_set = True  # (or the first render frames every actor again)
    else:
        plotter.reset_camera()
    return _finish(plotter, screenshot)


# Recorded Benchmarks (matplotlib; the figures of notebook 04)

def load_benchmark(path) -> dict:
    """A benchmark report written by ``benchmarks/bench_*.py``.

    Parameters
    ----------
    path : str or path-like
        Its JSON file (``benchmarks/results/*.json``).

    Returns
    -------
    dict
        The report as written: cases, machine, command, date.
    """
    import json

    with open(path) as fh:
        return json.load(fh)


def plot_grid_times(report: dict):
    """Frame time against N on the spot grid (``bench_hiz.py``), one panel per
    projection, one line per algorithm and mode, log-log.

    Parameters
    ----------
    report : dict
        ``bench_hiz.py``'s report (:func:`load_benchmark`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator

    projections = sorted({c["projection"] for c in report["grid"]}, reverse=True)
    fig, axes = plt.subplots(1, len(projections), figsize=(6 * len(projections), 4.2),
                             squeeze=False)
    for ax, projection in zip(axes[0], projections):
        cases = [c for c in report["grid"] if c["projection"] == projection]
        for key in sorted({(c["algo"], c["mode"]) for c in cases}):
            rows = sorted((c for c in cases if (c["algo"], c["mode"]) == key), key=lambda c: c["N"])
            ax.plot([c["N"] for c in rows], [c["ms_median"] for c in rows], marker="o",
                    linestyle="--" if key[1] == "built once" else "-",
                    label=f"{key[0]} ({key[1]})")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ns = sorted({c["N"] for c in cases})
        ax.set_xticks(ns, [str(n) for n in ns])  # N itself, not powers of 2
        ax.minorticks_off()
        # Times at 1, 2 and 5 of each decade, written as numbers (a decade
        # or two of data had one labelled tick).
        ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.set_xlabel("N (5 x 5 x N copies)")
        ax.set_ylabel("ms per frame (median)")
        ax.set_title(f"{projection}, {report['size']}x{report['size']}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_grid_culling(report: dict, n: Optional[int] = None):
    """Where the triangles went at one N of the spot grid: drawn, culled by
    the triangle test, never reached (in culled nodes), per algorithm and
    projection, as stacked bars (fractions of the input).

    Parameters
    ----------
    report : dict
        ``bench_hiz.py``'s report (:func:`load_benchmark`).
    n : int, optional
        The N shown (default: the largest measured).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    n = n if n is not None else max(c["N"] for c in report["grid"])
    cases = [c for c in report["grid"] if c["N"] == n and c["mode"] == "per frame"]
    labels = [f"{c['algo']}\n{c['projection'][:5]}" for c in cases]
    total = np.array([c["triangles"] for c in cases], float)
    parts = [("rasterized", "drawn"), ("culled_hidden", "culled by the triangle test"),
             ("culled_in_nodes", "in culled nodes")]
    fig, ax = plt.subplots(figsize=(1.2 * len(cases) + 2, 4))
    bottom = np.zeros(len(cases))
    for key, label in parts:
        share = np.array([c[key] for c in cases], float) / total
        ax.bar(labels, share, bottom=bottom, label=label)
        bottom += share
    ax.set_ylabel(f"share of {int(total[0]):,} triangles")
    ax.set_title(f"spot grid N={n}: what happened to the triangles")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig



def plot_models(report: dict, size: Optional[str] = None, cull: bool = False):
    """Models x algorithms (``bench_models.py``): each algorithm's frame time
    as a multiple of the plain Z-buffer's in the same rounds, one group of
    bars per model.

    Parameters
    ----------
    report : dict
        ``bench_models.py``'s report (:func:`load_benchmark`).
    size : str, optional
        The image size shown, as ``"WxH"`` (default: the largest measured).
    cull : bool
        The back-face culling setting shown.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    cases = [c for c in report["cases"] if "algorithms" in c]
    size = size if size is not None else max(
        (c["size"] for c in cases), key=lambda s: int(s.split("x")[0]) * int(s.split("x")[1]))
    cases = [c for c in cases if c["size"] == size and c["cull"] == cull]
    algos = [a for a in report["algorithms"] if a != "zbuffer"]
    fig, ax = plt.subplots(figsize=(1.1 * len(cases) + 3, 4))
    x = np.arange(len(cases))
    width = 0.8 / max(len(algos), 1)
    for k, algo in enumerate(algos):
        ax.bar(x + (k - (len(algos) - 1) / 2) * width,
               [c["algorithms"][algo]["x_zbuffer"] for c in cases], width, label=algo)
    ax.axhline(1.0, color="black", linewidth=0.8)
    ax.set_xticks(x, [c["model"].rsplit(".", 1)[0] for c in cases], rotation=30, ha="right")
    ax.set_ylabel("time / zbuffer's time (median)")
    ax.set_title(f"every algorithm per frame, {size}, back-face culling {'on' if cull else 'off'}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
