"""The result of a render."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Union

import numpy as np

from .camera import Camera

__all__ = ["RenderResult"]


@dataclass(repr=False, eq=False)  # (== by identity: its arrays compare element by element)
class RenderResult:
    """What :func:`render` returns.

    Attributes
    ----------
    image : (H, W, 3) uint8 or None
        The shaded image; None with ``shading="none"``.
    depth : (H, W) float32
        Window depth in [0, 1] (smaller is nearer), +inf where nothing was drawn.
        At widths that are multiples of 512 from 1024 up, compiled renders
        return a view of rows 16 pixels longer (docs/api.md: rows 4 KiB apart
        slow the drawing).
    triangle_id : (H, W) int32
        Index into the input faces of the visible triangle, -1 where nothing
        was drawn. Laid out as ``depth``.
    stats : dict
        Triangle and pixel counters and times in milliseconds (see docs/api.md).
    camera : Camera
        The camera used, with near/far (and ortho_height) resolved.
    mvp : (4, 4) float64
        The model-view-projection matrix used.
    algo : str
    culls : list of (h, w) int64 arrays, or None
        With ``record_culls=True`` (algorithms with a Z-pyramid): per
        pyramid level, shaped like :meth:`pyramid`'s, how many triangles
        were culled by occlusion tests that read each cell (a triangle
        culled by the maximum of several cells -- up to 3 x 3 for a small
        triangle, 2 x 2 for a large one -- counts in each; a tree node
        culled whole counts its triangles in the up to 16 x 16 cells it was
        tested against). None otherwise.
    width, height : int
        The image size (``depth.shape`` is ``(height, width)``).
    mask : (H, W) bool
        Where a triangle was drawn (``triangle_id >= 0``); a property.
    """

    image: Optional[np.ndarray]
    depth: np.ndarray
    triangle_id: np.ndarray
    stats: Dict[str, Any]
    camera: Camera
    mvp: np.ndarray
    algo: str = "zbuffer"
    culls: Optional[List[np.ndarray]] = None
    width: int = field(init=False)
    height: int = field(init=False)

    def __post_init__(self):
        self.height, self.width = self.depth.shape

    def __repr__(self) -> str:
        # A line, not every array (the camera is repr(res.camera) away).
        drawn = int(np.count_nonzero(self.triangle_id >= 0))
        ms = self.stats.get("total_ms")
        return (f"<RenderResult {self.algo!r} {self.width}x{self.height}"
                f"{'' if self.image is not None else ', no image'}: {drawn:,} pixels drawn"
                + (f", {ms:.2f} ms" if isinstance(ms, float) else "")
                + (", culls recorded" if self.culls is not None else "") + ">")

    @property
    def mask(self) -> np.ndarray:
        """(H, W) bool: pixels where a triangle was drawn."""
        return self.triangle_id >= 0

    def show(self, screenshot: Union[str, bool, None] = None, **options):
        """Show image, depth (with a colour bar) and triangle ids side by side
        in a pyvista window, or render them offscreen
        (:func:`zbuffer.viz.show_result`).

        Parameters
        ----------
        screenshot : str, os.PathLike, file object or True, optional
            Render offscreen instead of opening a window, and write the
            picture to this file: PNG, JPEG, BMP or TIFF by the suffix
            (``.png``, ``.jpg``/``.jpeg``, ``.bmp``, ``.tif``/``.tiff``, in
            any case); a name without a suffix gets ``.png`` appended.
            A file object gets a PNG. True: render offscreen and write no
            file.
        **options
            Passed on to :func:`zbuffer.viz.show_result` (``window_size``).

        Returns
        -------
        (h, w, 3|4) uint8 array or pyvista.Plotter
            With ``screenshot``, the picture rendered; without, the
            plotter shown.

        Raises
        ------
        ImportError
            pyvista is not installed.
        ValueError
            A ``screenshot`` name with another suffix, naming a folder, or
            in a folder that does not exist (said before anything is drawn).
        RuntimeError
            No ``screenshot`` and no display to open a window on.
        """
        from . import viz

        return viz.show_result(self, screenshot=screenshot, **options)

    def _repr_png_(self) -> bytes:
        """The image as PNG (false-colour triangle ids with shading="none"),
        so that a notebook cell returning a result shows it."""
        from io import BytesIO

        from PIL import Image

        from .viz import id_colors

        picture = self.image if self.image is not None else id_colors(self.triangle_id)
        buffer = BytesIO()
        Image.fromarray(picture).save(buffer, format="PNG")
        return buffer.getvalue()

    def pyramid(self) -> List[np.ndarray]:
        """The Z-pyramid of ``depth``, computed from the final depth.

        Each cell is the farthest (largest) depth of its 2 x 2 children
        inside the image, so +inf wherever any pixel under it was not
        drawn. The algorithms' own pyramids keep only its coarser
        levels (from 8 x 8 pixels; 4 x 4 for the trees of meshes with at
        least as many triangles as the image has pixels) and may
        lag the last batches drawn (never nearer than these: depth only
        decreases); brought up to date, they equal these levels.

        Returns
        -------
        list of (h, w) float32
            Level 0 is ``depth`` itself (the same array, not a copy); level
            k (new arrays on every call) has ``ceil(H / 2**k) x
            ceil(W / 2**k)`` cells, down to 1 x 1.
        """
        from . import _core

        return _core.pyramid_levels(self.depth)

    def eye_depth(self) -> np.ndarray:
        """The distance of each drawn pixel along the viewing direction.

        Eye-space -z, from ``depth`` and the camera's ``near`` and ``far``
        (window depth 0 gives exactly ``near``, 1 exactly ``far``; linear
        between them for an orthographic camera).

        Returns
        -------
        (H, W) float64
            +inf where nothing was drawn.
        """
        n, f = self.camera.near, self.camera.far
        w = self.depth.astype(np.float64)  # window depth, 0 at near and 1 at far
        # (The projection's inverse in terms of w itself: with z_ndc = 2 w - 1,
        # (f + n) - z_ndc (f - n) cancelled to 0 near w = 1 once far / near
        # passed 2^53, and drawn pixels came out +inf.)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            if self.camera.projection == "perspective":
                # (n / (...) lies in (0, 1]: no overflow, and no subnormal
                # f n where near and far are both tiny -- but it is itself
                # subnormal where near / far is, and then f n comes first)
                denominator = f * (1.0 - w) + n * w
                if n / f >= np.finfo(np.float64).tiny:
                    d = f * (n / denominator)
                else:
                    d = (f * n) / denominator
            else:
                d = n * (1.0 - w) + f * w
            d = np.where(w == 0.0, n, np.where(w == 1.0, f, d))  # (the planes exactly)
        return np.where(self.mask, d, np.inf)
