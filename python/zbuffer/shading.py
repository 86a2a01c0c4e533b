"""Shading options, and the numpy form of the shading pass.

The compiled pass (``cpp/src/shading.cpp``) and :func:`shade_numpy` implement
the same model: Lambert diffuse plus ambient under one directional light, lit
from both sides, with uniform, per-vertex or per-face colours and
perspective-correct interpolation through the pixel's view ray.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import math

import numpy as np

from .camera import _unit
from .checks import as_number, as_reals, check_choice
from .mesh import one_rgb

__all__ = ["SHADINGS", "ShadingParams", "resolve_shading", "shade_numpy", "vertex_normals"]

SHADINGS = ("flat", "smooth", "none")
DEFAULT_COLOR = (0.8, 0.8, 0.8)
DEFAULT_AMBIENT = 0.2
DEFAULT_DIFFUSE = 0.8
DEFAULT_BACKGROUND = (255, 255, 255)


@dataclass(frozen=True, eq=False)  # (== and hash by identity: it holds arrays)
class ShadingParams:
    """Resolved shading options (see :func:`zbuffer.render` for their meaning)."""

    mode: str                 # "flat", "smooth" or "none"
    light_dir: np.ndarray     # (3,) float64 unit direction the light travels in
    ambient: float
    diffuse: float
    color: Optional[np.ndarray]  # (3,) float32 override, or None: mesh colours
    background: np.ndarray    # (3,) uint8


def check_shading(shading) -> None:
    """ValueError unless ``shading`` is one of :data:`SHADINGS` (TypeError
    for what is not a string)."""
    check_choice("shading", shading, SHADINGS)


_MAX_WEIGHT = float(np.finfo(np.float32).max)


def resolve_shading(shading: str, camera, light_dir=None, ambient: float = DEFAULT_AMBIENT,
                    diffuse: float = DEFAULT_DIFFUSE, color=None, background=DEFAULT_BACKGROUND
                    ) -> ShadingParams:
    """Check and normalise shading options. ``light_dir=None`` is a headlight:
    the light travels along the camera's viewing direction.

    Parameters
    ----------
    shading : {"flat", "smooth", "none"}
    camera : Camera
        Only its viewing direction is used (the headlight).
    light_dir : (3,) array_like of float, optional
        Direction the light travels in; any length but zero.
    ambient, diffuse : float
        Finite, from 0 to float32's largest.
    color : (3,) array_like of int (0-255) or float (0-1), optional
    background : (3,) array_like of int (0-255) or float (0-1)

    Returns
    -------
    ShadingParams
        ``light_dir`` a unit (3,) float64 vector, ``color`` (3,) float32 in
        [0, 1] or None, ``background`` (3,) uint8 (rounded). For
        ``shading="none"`` with every other option at its default, a
        shared constant whose ``light_dir`` is a placeholder (nothing is
        shaded).

    Raises
    ------
    ValueError
        Unknown ``shading``; ``ambient`` or ``diffuse`` out of range;
        ``light_dir`` not 3 finite numbers or zero; ``color`` or
        ``background`` not 3 numbers in range.
    TypeError
        Arguments of the wrong type (a ``shading`` that is not a string,
        weights or colours that are not numbers).
    """
    check_shading(shading)
    # (At most float32's largest: the compiled passes weigh in float32, where
    # a larger weight is inf, and inf times a back-lit 0 is NaN -- black.)
    for name, value in (("ambient", ambient), ("diffuse", diffuse)):
        x = as_number(name, value)
        if not (math.isfinite(x) and 0.0 <= x <= _MAX_WEIGHT):
            raise ValueError(f"{name} must be a finite number >= 0 (at most {_MAX_WEIGHT:.4g}), "
                             f"got {value!r}")
    if shading == "none" and light_dir is None and color is None \
            and float(ambient) == DEFAULT_AMBIENT and float(diffuse) == DEFAULT_DIFFUSE \
            and background is DEFAULT_BACKGROUND:
        return _NO_SHADING  # visibility only, default options: nothing else to check
    if light_dir is None:
        light = camera.forward()
    else:
        try:
            light = as_reals("light_dir", light_dir, "3 numbers")
        except ValueError:  # a Python int beyond float range
            raise ValueError(f"light_dir must be 3 finite numbers, got {light_dir!r}") from None
        if light.shape != (3,) or not np.all(np.isfinite(light)):
            raise ValueError(f"light_dir must be 3 finite numbers, got {light_dir!r}")
        light, norm = _unit(light)
        if norm == 0.0:
            raise ValueError("light_dir must not be the zero vector")
    bg = one_rgb(background, "background")
    return ShadingParams(
        mode=shading,
        light_dir=np.ascontiguousarray(light, dtype=np.float64),
        ambient=float(ambient),
        diffuse=float(diffuse),
        color=None if color is None else one_rgb(color, "color"),
        background=np.round(bg.astype(np.float64) * 255.0).astype(np.uint8),
    )


_NO_SHADING = ShadingParams(mode="none", light_dir=np.array([0.0, 0.0, -1.0]),
                            ambient=DEFAULT_AMBIENT, diffuse=DEFAULT_DIFFUSE, color=None,
                            background=np.array(DEFAULT_BACKGROUND, np.uint8))


def color_source(mesh, params: ShadingParams):
    """("uniform" | "vertex" | "face", colours or None, uniform colour (3,) float32)."""
    uniform = params.color if params.color is not None else np.asarray(DEFAULT_COLOR, np.float32)
    if params.color is None and mesh.face_colors is not None:
        return "face", mesh.face_colors, uniform
    if params.color is None and mesh.vertex_colors is not None:
        return "vertex", mesh.vertex_colors, uniform
    return "uniform", None, uniform


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def power_scaled(a: np.ndarray, axis=-1) -> np.ndarray:
    """``a`` times, for each slice along ``axis`` (an int or a tuple), the
    power of two that brings the slice's largest magnitude into [1, 2)
    (exact: the same directions), where that is positive and finite (the
    core's power_scaled, shading.cpp)."""
    m = np.abs(a).max(axis=axis, keepdims=True)
    ok = (m > 0.0) & np.isfinite(m)
    e = np.frexp(np.where(ok, m, 1.0))[1] - 1
    return np.where(ok, np.ldexp(a, -e), a)


def face_normal_directions(e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """The faces' normal directions from their edges e1 = p1 - p0 and
    e2 = p2 - p0, as the compiled pass computes them (shading.cpp:
    face_normal_direction): the cross product where its largest magnitude
    lies in [2**-400, 2**400], else that of the edges scaled by powers of
    two, scaled again -- squaring it then neither underflows nor overflows."""
    ng = np.cross(e1, e2)
    m = np.abs(ng).max(axis=1, initial=0.0)
    robust = ~((m >= 2.0**-400) & (m <= 2.0**400))
    if robust.any():
        ng[robust] = power_scaled(np.cross(power_scaled(e1[robust]), power_scaled(e2[robust])))
    return ng


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals, in numpy.

    Each vertex sums the cross products (b - a) x (c - a) of the faces
    (a, b, c) it is a corner of, first corners in face order, then second,
    then third (``np.bincount`` adds in the order of its input), and is
    divided by the sum's length. Where the largest coordinate magnitude
    lies outside [2**-200, 2**200], all coordinates are first scaled by a
    power of two (exact: the same directions). ``Mesh.vertex_normals``
    computes the same bits in the compiled core.

    Parameters
    ----------
    vertices : (N, 3) array_like of float
    faces : (M, 3) array_like of int
        Indices into ``vertices`` (not checked).

    Returns
    -------
    (N, 3) float64
        Zero for unused vertices (and where the sum vanishes).
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    # Coordinates whose largest magnitude lies outside [2**-200, 2**200]:
    # scaled by the power of two that brings it into [1, 2) (exact; the
    # same weights), so that nothing below overflows or underflows.
    finite = vertices[np.isfinite(vertices)]
    big = float(np.abs(finite).max(initial=0.0))
    if big > 0.0 and (big < 2.0**-200 or big > 2.0**200):
        vertices = np.ldexp(vertices, 1 - np.frexp(big)[1])
    p = vertices[faces]
    area_normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    corners = faces.T.ravel()
    acc = np.stack([np.bincount(corners, weights=np.tile(area_normals[:, c], 3),
                                minlength=len(vertices)) for c in range(3)],
                   axis=1).astype(np.float64, copy=False)  # (int64 without faces)
    length = np.linalg.norm(acc, axis=1, keepdims=True)
    return np.divide(acc, length, out=np.zeros_like(acc), where=length > 0)


def shade_numpy(mesh, triangle_id: np.ndarray, camera, mvp: np.ndarray,
                params: ShadingParams) -> np.ndarray:
    """The shading pass in numpy: the image of a visibility result (smooth
    shading from :func:`vertex_normals`, the bits ``Mesh.vertex_normals``
    computes in the compiled core). Agrees with the compiled pass within
    one level of 255 (docs/rasterization.md, section 4).

    Parameters
    ----------
    mesh : Mesh
        The mesh rendered.
    triangle_id : (H, W) int32
        Face indices into ``mesh.faces``, -1 where nothing was drawn.
    camera : Camera
        The camera rendered from (each face's normal is turned towards its
        viewer: faces are lit from both sides).
    mvp : (4, 4) float64
        Its matrix (perspective-correct interpolation).
    params : ShadingParams
        From :func:`resolve_shading`; ``mode`` "smooth" interpolates vertex
        normals, any other face normals.

    Returns
    -------
    (H, W, 3) uint8
        ``params.background`` where nothing was drawn.
    """
    height, width = triangle_id.shape
    image = np.empty((height, width, 3), np.uint8)
    image[...] = params.background
    js, is_ = np.nonzero(triangle_id >= 0)
    if len(js) == 0:
        return image
    f = triangle_id[js, is_].astype(np.int64)
    source, colors, uniform = color_source(mesh, params)
    smooth = params.mode == "smooth"
    need_bary = smooth or source == "vertex"

    v = mesh.vertices
    idx = mesh.faces[f]
    p0 = v[idx[:, 0]]
    e1 = v[idx[:, 1]] - p0
    e2 = v[idx[:, 2]] - p0
    ng = face_normal_directions(e1, e2)
    viewer = camera.viewer()
    to_viewer = viewer[:3] - viewer[3] * p0
    side = np.where(_dot(ng, to_viewer) < 0.0, -1.0, 1.0)

    b1 = np.full(len(f), 1.0 / 3.0)
    b2 = np.full(len(f), 1.0 / 3.0)
    b0 = np.full(len(f), 1.0 / 3.0)
    if need_bary:
        # Perspective-correct barycentrics: adj(M) (x_ndc, y_ndc, 1), with the
        # corners' clip-space (x, y, w) as the columns of M (shading.h), its
        # coefficients scaled to a largest magnitude of 1 -- the scalar pass's
        # operations in its order (shading.cpp: prepare_face,
        # clamped_barycentrics), so that the two agree even on faces whose
        # corners are collinear within rounding, where the barycentrics are
        # rounding noise before the clamp.
        xn = (is_ + 0.5) / (0.5 * width) - 1.0
        yn = 1.0 - (js + 0.5) / (0.5 * height)
        corners = [v[idx[:, k]] for k in range(3)]

        def clip_row(r):
            m = mvp[r]
            return [c[:, 0] * m[0] + c[:, 1] * m[1] + c[:, 2] * m[2] + m[3] for c in corners]

        cx, cy, cw = clip_row(0), clip_row(1), clip_row(3)
        coef = []
        for k in range(3):
            a, c = (k + 1) % 3, (k + 2) % 3
            coef += [cy[a] * cw[c] - cy[c] * cw[a], cw[a] * cx[c] - cw[c] * cx[a],
                     cx[a] * cy[c] - cx[c] * cy[a]]
        big = np.fmax.reduce(np.abs(coef), axis=0)  # NaNs aside, as std::max
        scale = np.where((big > 0.0) & np.isfinite(big), 1.0 / np.where(big > 0.0, big, 1.0), 1.0)
        coef = [e * scale for e in coef]
        b = [coef[3 * k] * xn + coef[3 * k + 1] * yn + coef[3 * k + 2] for k in range(3)]
        total = b[0] + b[1] + b[2]
        ok = (total != 0.0) & np.isfinite(total)
        safe = np.where(ok, total, 1.0)
        b = [np.minimum(1.0, np.maximum(0.0, bk / safe)) for bk in b]
        total = b[0] + b[1] + b[2]
        b0 = np.where(ok, b[0] / total, b0)
        b1 = np.where(ok, b[1] / total, b1)
        b2 = np.where(ok, b[2] / total, b2)

    n = ng
    if smooth:
        vn = vertex_normals(mesh.vertices, mesh.faces)
        ns = (b0[:, None] * vn[idx[:, 0]] + b1[:, None] * vn[idx[:, 1]]
              + b2[:, None] * vn[idx[:, 2]])
        n = np.where((_dot(ns, ns) > 0.0)[:, None], ns, ng)
    length = np.sqrt(_dot(n, n))
    n = np.divide(n, length[:, None], out=np.zeros_like(n), where=length[:, None] > 0)
    n = side[:, None] * n

    intensity = params.ambient + params.diffuse * np.maximum(0.0, _dot(n, -params.light_dir[None, :]))
    if source == "uniform":
        albedo = np.broadcast_to(uniform.astype(np.float64), (len(f), 3))
    elif source == "face":
        albedo = colors[f].astype(np.float64)
    else:
        c = colors.astype(np.float64)
        albedo = (b0[:, None] * c[idx[:, 0]] + b1[:, None] * c[idx[:, 1]]
                  + b2[:, None] * c[idx[:, 2]])
    rgb = np.floor(np.clip(albedo * intensity[:, None], 0.0, 1.0) * 255.0 + 0.5)
    image[js, is_] = rgb.astype(np.uint8)
    return image
