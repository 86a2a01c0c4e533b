"""``zbuffer view``: a window showing zbuffer's own software-rendered image,
live.

The window is a pyvista plotter showing one picture -- the frame zbuffer
rendered, or an overlay of it -- and a line with the frame time and the main
counters. VTK's own camera never moves: dragging and the wheel move
zbuffer's camera, and every change renders a new frame on the CPU.

Mouse: drag to rotate around the mesh, wheel to zoom. Keys:

====  =========================================================
a     next algorithm (``zbuffer.algorithms()``)
s     shading: flat, smooth, none (triangle ids in false colour)
d     overlay: the depth map
p     overlay: the Z-pyramid, one level coarser each press (then off)
o     overlay: the tree's node rectangles, coloured by fate
      (``hiz_octree`` / ``hiz_bvh``: hidden red, visited orange,
      drawn green)
r     reset the view
====  =========================================================

:class:`Viewer` holds the state and composes frames without any window
(:meth:`Viewer.frame`), which is what the tests and ``--screenshot`` use.
"""

from __future__ import annotations

import math
import os
import time
from typing import IO, Optional, Union

import numpy as np

from .api import algorithms, check_algorithm
from .camera import Camera
from .checks import as_finite, check_choice
from .load import as_mesh
from .options import check_size
from .result import RenderResult
from .scene import NODE_FATES, TREE_ALGORITHMS, Scene
from .shading import SHADINGS, check_shading
from .viz import (FATE_COLORS, check_window, depth_for_display, depth_grey, id_colors,
                  image_plane, offscreen, require_pyvista, screenshot_target, take_screenshot)

__all__ = ["Viewer", "run"]

# Overlay colours of node fates (zbuffer.scene.NODE_FATES): hidden, visited,
# drawn -- as viz.show_tree colours them.
_RECT_COLORS = {k: tuple(int(FATE_COLORS[k][i:i + 2], 16) for i in (1, 3, 5))
                for k in (NODE_FATES.index("hidden"), NODE_FATES.index("visited"),
                          NODE_FATES.index("drawn"))}


class Viewer:
    """The state of an interactive view of one mesh, and its frames.

    Parameters
    ----------
    mesh : anything :func:`zbuffer.render` accepts
    algo : str
        Starting algorithm.
    width, height : int
        Frame size in pixels.
    shading : {"flat", "smooth", "none"}

    Raises
    ------
    ValueError
        Unknown ``algo`` or ``shading``, a bad frame size, a bad mesh, or
        one the orbit camera cannot frame (coordinates out of double
        precision's reach).
    TypeError
        Arguments of the wrong type.
    """

    def __init__(self, mesh, algo: str = "hiz_octree", width: int = 800, height: int = 600,
                 shading: str = "flat"):
        check_algorithm(algo, takes_camera=False)
        check_shading(shading)
        self.width, self.height = check_size(width, height)
        self.scene = Scene(as_mesh(mesh))
        self.algo = algo
        self.shading = shading
        self.overlay = "none"     # "none", "depth", "pyramid", "tree"
        self.pyramid_level = 0
        self.result: Optional[RenderResult] = None
        self.frame_ms = 0.0
        try:  # (said now, not by every frame: the start, and the nearest and farthest zoom)
            self.reset_view()
            for distance in (self.distance, self._NEAREST * self.radius,
                             self._FARTHEST * self.radius):
                self.camera(distance).resolve(self.scene.mesh).mvp(self.width, self.height)
        except ValueError as err:  # (the cause, in the traceback, says which plane or matrix)
            v = self.scene.mesh.vertices
            extent = float(np.abs(v).max()) if len(v) else 0.0
            raise ValueError(f"the viewer cannot frame this mesh (coordinates up to "
                             f"{extent:.3g}): its orbit camera's clip planes or matrices are "
                             f"out of double precision's reach; scale it") from err

    # Camera

    def reset_view(self) -> None:
        """Azimuth 0 (looking down -z), a little from above, the mesh framed."""
        centre, radius = self.scene.mesh.bounding_sphere
        self.target = np.asarray(centre, float)
        self.radius = float(radius) if radius > 0 else 1.0
        self.azimuth, self.elevation = 0.0, 20.0
        self.distance = 2.6 * self.radius

    def rotate(self, d_azimuth: float, d_elevation: float) -> None:
        """Orbit around the target (degrees); elevation stays within +-89.

        Parameters
        ----------
        d_azimuth, d_elevation : float
            Degrees to add; the azimuth wraps into [0, 360).

        Raises
        ------
        TypeError
            Not numbers.
        ValueError
            NaN or infinite.
        """
        d_azimuth = as_finite("d_azimuth", d_azimuth)
        d_elevation = as_finite("d_elevation", d_elevation)
        self.azimuth = (self.azimuth + d_azimuth) % 360.0
        self.elevation = float(np.clip(self.elevation + d_elevation, -89.0, 89.0))

    # How close to and how far from the target zoom may go, in radii.
    _NEAREST, _FARTHEST = 0.05, 100.0

    def zoom(self, factor: float) -> None:
        """Move towards (0 < factor < 1) or away from the target (factor > 1).

        Parameters
        ----------
        factor : float
            Multiplies the distance, which stays between 0.05 and 100
            times the mesh's bounding radius.

        Raises
        ------
        TypeError
            Not a number.
        ValueError
            Not positive and finite.
        """
        x = as_finite("factor", factor)
        if x <= 0.0:
            raise ValueError(f"factor must be > 0, got {factor!r}")
        self.distance = float(np.clip(self.distance * x, self._NEAREST * self.radius,
                                      self._FARTHEST * self.radius))

    def camera(self, distance: Optional[float] = None) -> Camera:
        """The orbit camera: ``distance`` (default: the current one) from
        ``target`` at ``azimuth`` and ``elevation`` (degrees), near and far
        around the mesh's sphere.

        Parameters
        ----------
        distance : float, optional

        Returns
        -------
        Camera
            Perspective, 45 degrees, y up; ``far`` is ``distance + 1.5
            radius`` and ``near`` ``distance - 1.5 radius``, at least
            ``distance / 1000``.
        """
        d = self.distance if distance is None else distance
        a, e = math.radians(self.azimuth), math.radians(self.elevation)
        offset = np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])
        eye = self.target + d * offset
        return Camera.look_at(eye, self.target, fov_y=45.0,
                              near=max(d - 1.5 * self.radius, 1e-3 * d),
                              far=d + 1.5 * self.radius)

    # Modes

    def next_algorithm(self) -> None:
        """The next registered algorithm (the tree overlay goes off for one
        without a tree)."""
        names = algorithms()
        self.algo = names[(names.index(self.algo) + 1) % len(names)]
        if self.overlay == "tree" and self.algo not in TREE_ALGORITHMS:
            self.overlay = "none"

    def next_shading(self) -> None:
        """The next shading mode: flat, smooth, none, and round again."""
        self.shading = SHADINGS[(SHADINGS.index(self.shading) + 1) % len(SHADINGS)]

    def toggle(self, overlay: str) -> None:
        """Switch an overlay on (or off, if it is on). "pyramid" steps one
        level coarser each call instead, and off after the last level.

        Parameters
        ----------
        overlay : {"depth", "pyramid", "tree"}
            "tree" does nothing unless it is on or the algorithm has a tree
            (``hiz_octree``, ``hiz_bvh``).

        Raises
        ------
        ValueError
            Another string.
        TypeError
            Not a string.
        """
        check_choice("overlay", overlay, ("depth", "pyramid", "tree"))
        if overlay == "pyramid":
            levels = _pyramid_levels(self.width, self.height)
            if self.overlay != "pyramid":
                # Level 1 first (level 0 is the depth overlay), unless the
                # image is a single pixel: then its only level.
                self.overlay, self.pyramid_level = "pyramid", min(1, levels - 1)
            else:
                self.pyramid_level += 1
                if self.pyramid_level >= levels:
                    self.overlay, self.pyramid_level = "none", 0
            return
        if overlay == "tree" and self.overlay != "tree" and self.algo not in TREE_ALGORITHMS:
            return  # no tree to show
        self.overlay = "none" if self.overlay == overlay else overlay

    # Frames

    def render(self) -> RenderResult:
        """Render the current view with the current algorithm.

        Returns
        -------
        RenderResult
            Also kept as ``self.result``; ``self.frame_ms`` is the time
            the render took, in milliseconds.
        """
        t0 = time.perf_counter()
        self.result = self.scene.render(self.camera(), algo=self.algo, width=self.width,
                                        height=self.height, shading=self.shading)
        self.frame_ms = (time.perf_counter() - t0) * 1e3
        return self.result

    def frame(self) -> np.ndarray:
        """Render (:meth:`render`) and compose the picture shown.

        Returns
        -------
        (H, W, 3) uint8
            The shaded image (triangle ids in false colour with shading
            "none"), or the overlay: the depth map or a pyramid level in
            grey (nearest white, nothing drawn black), or the image with
            the tree's node rectangles.
        """
        res = self.render()
        picture = res.image if res.image is not None else id_colors(res.triangle_id)
        if self.overlay == "depth":
            picture = _grey(depth_for_display(res.depth))
        elif self.overlay == "pyramid":
            level = res.pyramid()[self.pyramid_level]
            k = 2 ** self.pyramid_level
            up = np.repeat(np.repeat(level, k, axis=0), k, axis=1)[:self.height, :self.width]
            picture = _grey(depth_for_display(up))
        elif self.overlay == "tree":
            picture = picture.copy()
            _draw_node_rects(picture, self.scene.nodes(self.algo), res.mvp)
        return picture

    def status(self) -> str:
        """The on-screen line: algorithm, frame time and the main counters.

        Returns
        -------
        str
            Of the last frame rendered; empty before the first.
        """
        if self.result is None:
            return ""
        s = self.result.stats
        line = (f"{self.algo}  {self.frame_ms:.1f} ms/frame (core {s['render_ms']:.1f})  "
                f"{s['rasterized']:,} drawn, {s['culled_hidden']:,} culled")
        if self.algo in TREE_ALGORITHMS:
            line += (f", {s['culled_in_nodes']:,} in culled nodes "
                     f"({s['nodes_hidden']:,} hidden / {s['nodes_visited']:,} visited nodes)")
        overlay = {"none": "", "depth": "  [depth]", "tree": "  [tree nodes]",
                   "pyramid": f"  [pyramid level {self.pyramid_level}]"}[self.overlay]
        return line + overlay + f"  shading {self.shading}"


def _grey(values: np.ndarray) -> np.ndarray:
    """Depth to grey RGB: nearest white, farthest dark, nothing drawn black."""
    return np.repeat(depth_grey(values, 255, 55).astype(np.uint8)[..., None], 3, axis=-1)


def _draw_node_rects(picture: np.ndarray, nodes: dict, mvp: np.ndarray) -> None:
    """Outline, in place, the screen rectangle of every hidden, visited or
    drawn tree node in front of the camera (the rectangle its node test used, without
    the margin), in its fate's colour."""
    h, w = picture.shape[:2]
    fate = nodes["fate"]
    keep = np.isin(fate, list(_RECT_COLORS))
    lo, hi = nodes["lo"][keep], nodes["hi"][keep]
    corners = np.stack([np.where(np.array([i & 1, i & 2, i & 4], bool), hi, lo)
                        for i in range(8)], axis=1)                       # (K, 8, 3)
    clip = np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], -1) @ mvp.T
    in_front = (clip[..., 3] > 0).all(axis=1) & (clip[..., 2] >= -clip[..., 3]).all(axis=1)
    x = (clip[..., 0] / clip[..., 3] + 1) * (w / 2)
    y = (1 - clip[..., 1] / clip[..., 3]) * (h / 2)
    for k in np.flatnonzero(in_front):
        x0, x1 = int(np.clip(np.floor(x[k].min()), 0, w - 1)), int(np.clip(np.floor(x[k].max()), 0, w - 1))
        y0, y1 = int(np.clip(np.floor(y[k].min()), 0, h - 1)), int(np.clip(np.floor(y[k].max()), 0, h - 1))
        color = _RECT_COLORS[int(fate[keep][k])]
        picture[y0, x0:x1 + 1] = color
        picture[y1, x0:x1 + 1] = color
        picture[y0:y1 + 1, x0] = color
        picture[y0:y1 + 1, x1] = color


def run(viewer: Viewer, screenshot: Union[str, os.PathLike, IO, bool, None] = None):
    """Show the viewer in a window (or, with ``screenshot``, render one frame
    offscreen into that file -- viz.screenshot_target -- and return the
    picture).

    Parameters
    ----------
    viewer : Viewer
    screenshot : str, os.PathLike, file object or True, optional
        PNG, JPEG, BMP or TIFF by the suffix (none: ``.png`` is appended);
        a file object gets a PNG; True: offscreen, no file; None or False:
        a window.

    Returns
    -------
    (h, w, 3|4) uint8 array or pyvista.Plotter
        With ``screenshot``, the picture; without, the plotter, once
        ``show`` returns (the window closed).

    Raises
    ------
    ImportError
        pyvista is not installed.
    ValueError
        A bad ``screenshot`` name (said before anything is drawn).
    RuntimeError
        No ``screenshot`` and no display to open a window on.
    """
    pv = require_pyvista()
    drawn_offscreen = offscreen(screenshot)
    if drawn_offscreen:
        screenshot_target(screenshot)  # (a bad file name said before anything is drawn)
    plotter = pv.Plotter(off_screen=True if drawn_offscreen else None,  # None: pyvista.OFF_SCREEN
                         window_size=(viewer.width, viewer.height),
                         border=False, title="zbuffer view")
    check_window(plotter)
    plotter.set_background("black")

    def show():
        grid = image_plane(pv, viewer.frame())
        plotter.add_mesh(grid, scalars="values", rgb=True, show_scalar_bar=False, name="frame",
                         lighting=False)  # the frame's own colours (viz._add_image)
        plotter.add_text(viewer.status(), position="upper_left", font_size=9, color="white",
                         shadow=True, name="status")
        plotter.view_xy()
        plotter.enable_parallel_projection()
        plotter.reset_camera(bounds=grid.bounds)
        plotter.camera.parallel_scale = viewer.height / 2  # one picture pixel per screen pixel
        plotter.render()

    show()
    if drawn_offscreen:
        return take_screenshot(plotter, screenshot)

    # zbuffer's camera, not VTK's: a style that does nothing, and observers.
    from vtkmodules.vtkInteractionStyle import vtkInteractorStyleUser

    interactor = plotter.iren.interactor
    interactor.SetInteractorStyle(vtkInteractorStyleUser())
    drag = {"at": None}

    def press(obj, event):
        drag["at"] = obj.GetEventPosition()

    def release(obj, event):
        drag["at"] = None

    def move(obj, event):
        if drag["at"] is None:
            return
        x, y = obj.GetEventPosition()
        x0, y0 = drag["at"]
        drag["at"] = (x, y)
        viewer.rotate(-(x - x0) * 0.4, -(y - y0) * 0.4)
        show()

    def wheel(factor):
        def handler(obj, event):
            viewer.zoom(factor)
            show()
        return handler

    interactor.AddObserver("LeftButtonPressEvent", press)
    interactor.AddObserver("LeftButtonReleaseEvent", release)
    interactor.AddObserver("MouseMoveEvent", move)
    interactor.AddObserver("MouseWheelForwardEvent", wheel(1 / 1.15))
    interactor.AddObserver("MouseWheelBackwardEvent", wheel(1.15))
    for key, action in {"a": viewer.next_algorithm, "s": viewer.next_shading,
                        "d": lambda: viewer.toggle("depth"), "p": lambda: viewer.toggle("pyramid"),
                        "o": lambda: viewer.toggle("tree"), "r": viewer.reset_view}.items():
        plotter.add_key_event(key, lambda action=action: (action(), show()))
    plotter.show()
    return plotter


def _pyramid_levels(width: int, height: int) -> int:
    """How many levels the Z-pyramid of a width x height image has (level 0
    the image itself, the last one 1 x 1)."""
    return (max(width, height) - 1).bit_length() + 1
