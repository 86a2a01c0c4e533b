"""The reference renderer: pure numpy, no compiled code.

It implements docs/rasterization.md operation by operation, so that every
compiled algorithm must reproduce its ``depth`` and ``triangle_id`` bit for
bit. It is the oracle of the test suite, written for clarity first and
vectorised enough to render a 10k-triangle mesh at 256x256 in seconds.

The float64 operations below are elementwise numpy ufuncs: each is one IEEE
operation, correctly rounded, never fused, so writing them in the same order
as the C++ core gives the same bits.
"""

from __future__ import annotations

import time
from typing import Dict, Optional, Tuple

import numpy as np

from .camera import Camera
from .conventions import (GUARD_BAND_PX, HALF_PIXEL, MAX_CLIP_VERTICES, MIN_CLIP_W,
                          SUBPIXEL_BITS, SUBPIXEL_SCALE)
from .checks import check_flag
from .options import DEFAULT_SIZE, prepare
from .result import RenderResult
from .shading import (DEFAULT_AMBIENT, DEFAULT_BACKGROUND, DEFAULT_DIFFUSE, shade_numpy,
                      vertex_normals)

__all__ = ["render", "vertex_stage", "rasterize", "render_polygons", "ScreenTriangles",
           "vertex_normals"]

# Outcode bits (vertex_stage.h).
OUT_LEFT, OUT_RIGHT, OUT_BOTTOM, OUT_TOP, OUT_NEAR, OUT_FAR = (1 << k for k in range(6))
OUT_GUARD_LEFT, OUT_GUARD_RIGHT, OUT_GUARD_BOTTOM, OUT_GUARD_TOP = (1 << k for k in range(6, 10))
OUT_INVALID = 1 << 10
OUT_VIEW = OUT_LEFT | OUT_RIGHT | OUT_BOTTOM | OUT_TOP | OUT_NEAR | OUT_FAR
OUT_CLIP = OUT_NEAR | OUT_FAR | OUT_GUARD_LEFT | OUT_GUARD_RIGHT | OUT_GUARD_BOTTOM | OUT_GUARD_TOP

# Candidate pixels handled per batch in rasterize(): bounds memory (~100 MB).
_BATCH_PIXELS = 1 << 20

STAT_KEYS = ("triangles_in", "culled_invalid", "culled_frustum", "clipped", "clipped_away",
             "clip_pieces", "culled_backface", "culled_degenerate", "culled_hidden", "rasterized",
             "pixels_tested", "pixels_covered")


class ScreenTriangles:
    """Triangles after the vertex stage, oriented so that ``area > 0``.

    Attributes
    ----------
    x, y : (T, 3) int64
        Snapped window coordinates (fixed point, 8 fractional bits, y down).
    z : (T, 3) float64
        Window depth in [0, 1].
    area : (T,) int64
        Twice the signed area, > 0.
    id : (T,) int64
        Index of the input face each triangle (or clipped piece) came from.
    """

    def __init__(self, x, y, z, area, ids):
        self.x, self.y, self.z, self.area, self.id = x, y, z, area, ids

    def __len__(self) -> int:
        return len(self.id)


# Vertex Stage

def _transform(mvp: np.ndarray, p: np.ndarray) -> Tuple[np.ndarray, ...]:
    """clip = mvp (p, 1), each row summed left to right: four (N,) arrays."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    m = mvp
    return tuple(((m[r, 0] * x + m[r, 1] * y) + m[r, 2] * z) + m[r, 3] for r in range(4))


def _outcodes(cx, cy, cz, cw, gx: float, gy: float) -> np.ndarray:
    finite = np.isfinite(cx) & np.isfinite(cy) & np.isfinite(cz) & np.isfinite(cw)
    oc = np.zeros(cx.shape, np.int64)
    with np.errstate(invalid="ignore", over="ignore"):
        gxw = gx * cw
        gyw = gy * cw
        oc |= np.where(cx + cw < 0.0, OUT_LEFT, 0)
        oc |= np.where(cw - cx < 0.0, OUT_RIGHT, 0)
        oc |= np.where(cy + cw < 0.0, OUT_BOTTOM, 0)
        oc |= np.where(cw - cy < 0.0, OUT_TOP, 0)
        oc |= np.where((cz + cw < 0.0) | ~(cw >= MIN_CLIP_W), OUT_NEAR, 0)
        oc |= np.where(cw - cz < 0.0, OUT_FAR, 0)
        oc |= np.where(cx + gxw < 0.0, OUT_GUARD_LEFT, 0)
        oc |= np.where(gxw - cx < 0.0, OUT_GUARD_RIGHT, 0)
        oc |= np.where(cy + gyw < 0.0, OUT_GUARD_BOTTOM, 0)
        oc |= np.where(gyw - cy < 0.0, OUT_GUARD_TOP, 0)
    return np.where(finite, oc, OUT_INVALID)


def _vertex_stage(vertices, mvp, half_w, half_h, gx, gy):
    """Every vertex once: clip coordinates, outcodes, and the window
    coordinates (fixed-point x, y; z) of the vertices that need no clipping
    (zeros elsewhere)."""
    with np.errstate(over="ignore", invalid="ignore"):
        cx, cy, cz, cw = _transform(mvp, np.asarray(vertices, dtype=np.float64))
    oc = _outcodes(cx, cy, cz, cw, gx, gy)
    direct = (oc & (OUT_CLIP | OUT_INVALID)) == 0
    vx = np.zeros(len(oc), np.int64)
    vy = np.zeros(len(oc), np.int64)
    vz = np.zeros(len(oc), np.float64)
    vx[direct], vy[direct], vz[direct] = _to_screen(
        cx[direct], cy[direct], cz[direct], cw[direct], half_w, half_h)
    return (cx, cy, cz, cw), oc, (vx, vy, vz)


def _to_screen(cx, cy, cz, cw, half_w: float, half_h: float):
    """Divide, viewport, clamp depth, snap: (x_fx int64, y_fx int64, z float64)."""
    inv_w = 1.0 / cw
    xn = cx * inv_w
    yn = cy * inv_w
    zn = cz * inv_w
    xw = (xn + 1.0) * half_w
    yw = (1.0 - yn) * half_h
    zw = zn * 0.5 + 0.5
    zw = np.where(zw < 0.0, 0.0, zw)
    zw = np.where(zw > 1.0, 1.0, zw)
    x_fx = np.rint(xw * SUBPIXEL_SCALE).astype(np.int64)  # round half to even
    y_fx = np.rint(yw * SUBPIXEL_SCALE).astype(np.int64)
    return x_fx, y_fx, zw


def _plane_distance(plane: int, v: np.ndarray, gx: float, gy: float) -> float:
    x, y, z, w = v
    if plane == 0:
        return z + w
    if plane == 1:
        return w - z
    if plane == 2:
        return x + gx * w
    if plane == 3:
        return gx * w - x
    if plane == 4:
        return y + gy * w
    return gy * w - y


def _intersection(a: np.ndarray, da: float, b: np.ndarray, db: float) -> np.ndarray:
    """Where the edge from inside vertex a to outside vertex b meets the plane."""
    t = da / (da - db)
    return np.array([a[k] + t * (b[k] - a[k]) for k in range(4)])


def clip_polygon(poly, gx: float, gy: float):
    """Sutherland-Hodgman against near, far and the guard band: a list of
    (4,) clip-space vertices, empty if nothing (or nothing valid) is left."""
    # Coordinates near the float limit overflow to inf or NaN here, as in
    # the core, which drops what they leave (below): no warnings.
    with np.errstate(over="ignore", invalid="ignore"):
        return _clip_polygon(poly, gx, gy)


def _clip_polygon(poly, gx: float, gy: float):
    for plane in range(6):
        if len(poly) < 3:
            break
        d = [float(_plane_distance(plane, v, gx, gy)) for v in poly]
        if not any(dk < 0.0 for dk in d):
            continue
        out = []
        n = len(poly)
        for k in range(n):
            prev = (k + n - 1) % n
            prev_in, cur_in = d[prev] >= 0.0, d[k] >= 0.0
            if cur_in != prev_in:
                if cur_in:
                    out.append(_intersection(poly[k], d[k], poly[prev], d[prev]))
                else:
                    out.append(_intersection(poly[prev], d[prev], poly[k], d[k]))
            if cur_in:
                out.append(poly[k])
        if len(out) > MAX_CLIP_VERTICES:  # only rounding at absurd scales
            return []
        poly = out
    if len(poly) < 3:
        return []
    for v in poly:
        if not (v[3] >= MIN_CLIP_W) or not np.all(np.isfinite(v)):
            return []
    # A vertex that rounding left outside a guard-band plane goes onto it
    # (docs/rasterization.md, 2.3).
    placed = []
    for v in poly:
        v = v.copy()
        if _plane_distance(2, v, gx, gy) < 0.0:
            v[0] = -(gx * v[3])
        elif _plane_distance(3, v, gx, gy) < 0.0:
            v[0] = gx * v[3]
        if _plane_distance(4, v, gx, gy) < 0.0:
            v[1] = -(gy * v[3])
        elif _plane_distance(5, v, gx, gy) < 0.0:
            v[1] = gy * v[3]
        placed.append(v)
    return placed


def vertex_stage(vertices: np.ndarray, faces: np.ndarray, mvp: np.ndarray, width: int,
                 height: int, cull_backfaces: bool = False
                 ) -> Tuple[ScreenTriangles, Dict[str, int]]:
    """Transform, cull, clip, snap and orient: the triangles the raster core sees.

    Expects checked input, as :class:`zbuffer.Mesh` holds it (finite vertices,
    face indices in range); :func:`render` checks it.

    Parameters
    ----------
    vertices : (N, 3) float64
    faces : (M, 3) integer
    mvp : (4, 4) float64
    width, height : int
    cull_backfaces : bool

    Returns
    -------
    (ScreenTriangles, dict)
        The triangles, and the triangle counters of docs/api.md.
    """
    half_w, half_h = 0.5 * width, 0.5 * height
    gx, gy = GUARD_BAND_PX / half_w, GUARD_BAND_PX / half_h
    stats = dict.fromkeys(STAT_KEYS, 0)
    stats["triangles_in"] = len(faces)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)

    # Per vertex: clip coordinates, outcodes, and window coordinates where no
    # clipping is needed.
    (cx, cy, cz, cw), oc, (vx, vy, vz) = _vertex_stage(vertices, mvp, half_w, half_h, gx, gy)

    # Per face: invalid, outside the view volume, needing clipping, or direct.
    foc = oc[faces]
    any_out = foc[:, 0] | foc[:, 1] | foc[:, 2]
    all_out = foc[:, 0] & foc[:, 1] & foc[:, 2]
    invalid = (any_out & OUT_INVALID) != 0
    outside = ~invalid & ((all_out & OUT_VIEW) != 0)
    clipped = ~invalid & ~outside & ((any_out & OUT_CLIP) != 0)
    keep = ~invalid & ~outside & ~clipped
    stats["culled_invalid"] = int(invalid.sum())
    stats["culled_frustum"] = int(outside.sum())
    stats["clipped"] = int(clipped.sum())

    kept = faces[keep]
    xs, ys, zs = [vx[kept]], [vy[kept]], [vz[kept]]
    ids = [np.flatnonzero(keep)]

    # Clipped faces, one at a time: they are few.
    pieces_x, pieces_y, pieces_z, pieces_id = [], [], [], []
    for f in np.flatnonzero(clipped):
        c = _transform(mvp, np.asarray(vertices, dtype=np.float64)[faces[f]])
        poly = clip_polygon([np.array([c[0][k], c[1][k], c[2][k], c[3][k]]) for k in range(3)],
                            gx, gy)
        if not poly:
            stats["clipped_away"] += 1
            continue
        p = np.array(poly)
        sx, sy, sz = _to_screen(p[:, 0], p[:, 1], p[:, 2], p[:, 3], half_w, half_h)
        for k in range(1, len(poly) - 1):
            pieces_x.append([sx[0], sx[k], sx[k + 1]])
            pieces_y.append([sy[0], sy[k], sy[k + 1]])
            pieces_z.append([sz[0], sz[k], sz[k + 1]])
            pieces_id.append(f)
    stats["clip_pieces"] = len(pieces_id)
    if pieces_id:
        xs.append(np.array(pieces_x, np.int64))
        ys.append(np.array(pieces_y, np.int64))
        zs.append(np.array(pieces_z, np.float64))
        ids.append(np.array(pieces_id, np.int64))
    x = np.concatenate(xs).reshape(-1, 3)
    y = np.concatenate(ys).reshape(-1, 3)
    z = np.concatenate(zs).reshape(-1, 3)
    tid = np.concatenate(ids)

    # Assembly: exact integer area, degenerate and back-face culling, and
    # orientation (front faces have area < 0 in y-down window coordinates).
    area = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (y[:, 1] - y[:, 0]) * (x[:, 2] - x[:, 0])
    degenerate = area == 0
    back = ~degenerate & (area > 0) & bool(cull_backfaces)
    stats["culled_degenerate"] = int(degenerate.sum())
    stats["culled_backface"] = int(back.sum())
    live = ~degenerate & ~back
    x, y, z, area, tid = x[live], y[live], z[live], area[live], tid[live]
    flip = area < 0
    for a in (x, y, z):
        a[flip, 1], a[flip, 2] = a[flip, 2].copy(), a[flip, 1].copy()
    area = np.abs(area)
    stats["rasterized"] = len(tid)
    return ScreenTriangles(x, y, z, area, tid), stats


# Raster Core

def rasterize(tris: ScreenTriangles, width: int, height: int
              ) -> Tuple[np.ndarray, np.ndarray, Dict[str, int]]:
    """Coverage, depth and the depth write of docs/rasterization.md.

    Parameters
    ----------
    tris : ScreenTriangles
        As :func:`vertex_stage` returns them (``area > 0``).
    width, height : int
        Image size in pixels.

    Returns
    -------
    depth : (H, W) float32
        +inf where nothing was drawn.
    triangle_id : (H, W) int32
        -1 where nothing was drawn.
    stats : dict
        ``pixels_tested`` (pixel centres in the triangles' clamped boxes) and
        ``pixels_covered``.
    """
    x, y, z = tris.x, tris.y, tris.z
    # Pixel box: centres at 256 i + 128; >> on int64 is a floor.
    i0 = np.maximum((x.min(axis=1) - HALF_PIXEL + SUBPIXEL_SCALE - 1) >> SUBPIXEL_BITS, 0)
    i1 = np.minimum((x.max(axis=1) - HALF_PIXEL) >> SUBPIXEL_BITS, width - 1)
    j0 = np.maximum((y.min(axis=1) - HALF_PIXEL + SUBPIXEL_SCALE - 1) >> SUBPIXEL_BITS, 0)
    j1 = np.minimum((y.max(axis=1) - HALF_PIXEL) >> SUBPIXEL_BITS, height - 1)
    ncols = np.maximum(i1 - i0 + 1, 0)
    nrows = np.maximum(j1 - j0 + 1, 0)
    nrows[ncols == 0] = 0

    # Edge k runs from vertex k+1 to vertex k+2; top-left: dy < 0, or dy == 0 and dx > 0.
    ax = [x[:, (k + 1) % 3] for k in range(3)]
    ay = [y[:, (k + 1) % 3] for k in range(3)]
    dx = [x[:, (k + 2) % 3] - ax[k] for k in range(3)]
    dy = [y[:, (k + 2) % 3] - ay[k] for k in range(3)]
    top_left = [(dy[k] < 0) | ((dy[k] == 0) & (dx[k] > 0)) for k in range(3)]

    # Depth plane: coefficients in float64 rounded once to float32; per pixel
    # z = z0 + (float32(w1) * a1 + float32(w2) * a2) in float32, clamped.
    inv_area = 1.0 / tris.area.astype(np.float64)
    z0 = z[:, 0].astype(np.float32)
    a1 = ((z[:, 1] - z[:, 0]) * inv_area).astype(np.float32)
    a2 = ((z[:, 2] - z[:, 0]) * inv_area).astype(np.float32)
    z_lo = z.min(axis=1).astype(np.float32)
    z_hi = z.max(axis=1).astype(np.float32)

    # Keys: float32 depth bits (non-negative floats order like their bits)
    # above the id, so that one minimum is "nearer, then smaller id".
    empty = np.iinfo(np.uint64).max
    keys = np.full(width * height, empty, np.uint64)
    stats = {"pixels_tested": int((ncols * nrows).sum()), "pixels_covered": 0}

    # Enumerate (triangle, row) pairs, then their pixels, a batch at a time.
    row_tri = np.repeat(np.arange(len(nrows)), nrows)
    row_start = np.cumsum(nrows) - nrows
    row_j = j0[row_tri] + (np.arange(len(row_tri)) - row_start[row_tri])
    row_n = ncols[row_tri]
    ends = np.cumsum(row_n)
    start = 0
    while start < len(row_tri):
        stop = int(np.searchsorted(ends, (ends[start - 1] if start else 0) + _BATCH_PIXELS,
                                   side="right"))
        stop = max(stop, start + 1)
        sel = slice(start, stop)
        counts = row_n[sel]
        t = np.repeat(row_tri[sel], counts)
        first = np.cumsum(counts) - counts
        i = i0[t] + (np.arange(len(t)) - np.repeat(first, counts))
        j = np.repeat(row_j[sel], counts)
        px = i * SUBPIXEL_SCALE + HALF_PIXEL
        py = j * SUBPIXEL_SCALE + HALF_PIXEL

        w = [dx[k][t] * (py - ay[k][t]) - dy[k][t] * (px - ax[k][t]) for k in range(3)]
        inside = np.ones(len(t), bool)
        for k in range(3):
            inside &= (w[k] > 0) | ((w[k] == 0) & top_left[k][t])
        t, i, j = t[inside], i[inside], j[inside]
        w1, w2 = w[1][inside], w[2][inside]
        stats["pixels_covered"] += len(t)

        zf = z0[t] + (w1.astype(np.float32) * a1[t] + w2.astype(np.float32) * a2[t])
        zf = np.where(zf < z_lo[t], z_lo[t], zf)
        zf = np.where(zf > z_hi[t], z_hi[t], zf)
        assert zf.dtype == np.float32  # every operation above was a float32 one
        bits = zf.view(np.uint32).astype(np.uint64)
        key = (bits << np.uint64(32)) | tris.id[t].astype(np.uint64)
        np.minimum.at(keys, j * width + i, key)
        start = stop

    drawn = keys != empty
    depth = np.full(width * height, np.inf, np.float32)
    ids = np.full(width * height, -1, np.int32)
    depth[drawn] = (keys[drawn] >> np.uint64(32)).astype(np.uint32).view(np.float32)
    ids[drawn] = (keys[drawn] & np.uint64(0xFFFFFFFF)).astype(np.int32)
    return depth.reshape(height, width), ids.reshape(height, width), stats


# Polygons

# Polygons with more corners are drawn as their triangles (scanline.h).
MAX_POLYGON_CORNERS = 4096


def _keys(depth: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """(depth bits << 32) | id per pixel, the maximum where nothing was drawn."""
    d = depth.reshape(-1)
    keys = np.full(d.shape, np.iinfo(np.uint64).max, np.uint64)
    drawn = ids.reshape(-1) >= 0
    keys[drawn] = (d[drawn].view(np.uint32).astype(np.uint64) << np.uint64(32)) | \
        ids.reshape(-1)[drawn].astype(np.uint64)
    return keys


def _from_keys(keys: np.ndarray, width: int, height: int):
    drawn = keys != np.iinfo(np.uint64).max
    depth = np.full(keys.shape, np.inf, np.float32)
    ids = np.full(keys.shape, -1, np.int32)
    depth[drawn] = (keys[drawn] >> np.uint64(32)).astype(np.uint32).view(np.float32)
    ids[drawn] = (keys[drawn] & np.uint64(0xFFFFFFFF)).astype(np.int32)
    return depth.reshape(height, width), ids.reshape(height, width)


def _polygon_pixels(x, y, z, area: int, width: int, height: int):
    """Covered pixels of one polygon (snapped vertices x, y: Python ints,
    window depths z) and their depth: (flat pixel indices, float32 depths).
    docs/rasterization.md, "Polygons"."""
    n = len(x)
    # Rows with centres in [min y, max y), columns with centres in [min x, max x].
    j0 = max((min(y) - HALF_PIXEL + SUBPIXEL_SCALE - 1) >> SUBPIXEL_BITS, 0)
    j1 = min(((max(y) - HALF_PIXEL + SUBPIXEL_SCALE - 1) >> SUBPIXEL_BITS) - 1, height - 1)
    i0 = max((min(x) - HALF_PIXEL + SUBPIXEL_SCALE - 1) >> SUBPIXEL_BITS, 0)
    i1 = min((max(x) - HALF_PIXEL) >> SUBPIXEL_BITS, width - 1)
    if j0 > j1 or i0 > i1:
        return np.zeros(0, np.int64), np.zeros(0, np.float32)
    jj, ii = np.meshgrid(np.arange(j0, j1 + 1, dtype=np.int64),
                         np.arange(i0, i1 + 1, dtype=np.int64), indexing="ij")
    px = ii * SUBPIXEL_SCALE + HALF_PIXEL
    py = jj * SUBPIXEL_SCALE + HALF_PIXEL

    # Coverage: an odd number of edges crossing the row (centres in
    # [y_top, y_bottom)) at or left of the centre.
    count = np.zeros(px.shape, np.int64)
    for k in range(n):
        xa, ya, xb, yb = x[k], y[k], x[(k + 1) % n], y[(k + 1) % n]
        if ya == yb:
            continue
        (xt, yt), (xu, yu) = ((xa, ya), (xb, yb)) if ya < yb else ((xb, yb), (xa, ya))
        cross = (xu - xt) * (py - yt) - (yu - yt) * (px - xt)
        count += (yt <= py) & (py < yu) & (cross <= 0)
    inside = (count & 1) == 1
    if not inside.any():
        return np.zeros(0, np.int64), np.zeros(0, np.float32)

    # Depth plane: the fan triangle (v0, v_k, v_k+1) of largest area with the
    # polygon's orientation (first k on a tie), oriented to area > 0.
    best, best_area = 1, 0
    for k in range(1, n - 1):
        a = (x[k] - x[0]) * (y[k + 1] - y[0]) - (y[k] - y[0]) * (x[k + 1] - x[0])
        oriented = a if area > 0 else -a
        if oriented > best_area:
            best, best_area = k, oriented
    tri = [0, best, best + 1] if area > 0 else [0, best + 1, best]
    X = [x[t] for t in tri]
    Y = [y[t] for t in tri]
    Z = [float(z[t]) for t in tri]
    px, py = px[inside], py[inside]
    w1 = (X[0] - X[2]) * (py - Y[2]) - (Y[0] - Y[2]) * (px - X[2])  # edge 1: v2 -> v0
    w2 = (X[1] - X[0]) * (py - Y[0]) - (Y[1] - Y[0]) * (px - X[0])  # edge 2: v0 -> v1
    inv_area = 1.0 / np.float64(best_area)
    a1 = np.float32((np.float64(Z[1]) - np.float64(Z[0])) * inv_area)
    a2 = np.float32((np.float64(Z[2]) - np.float64(Z[0])) * inv_area)
    z0 = np.float32(Z[0])
    z_lo, z_hi = np.float32(np.min(z)), np.float32(np.max(z))
    zf = z0 + (w1.astype(np.float32) * a1 + w2.astype(np.float32) * a2)
    zf = np.where(zf < z_lo, z_lo, zf)
    zf = np.where(zf > z_hi, z_hi, zf)
    assert zf.dtype == np.float32
    return jj[inside] * width + ii[inside], zf


def render_polygons(vertices: np.ndarray, faces: np.ndarray, sizes: np.ndarray,
                    indices: np.ndarray, mvp: np.ndarray, width: int, height: int,
                    cull_backfaces: bool = False):
    """Visibility of polygon faces drawn natively, as ``algo="scanline"``
    draws them (docs/rasterization.md, "Polygons").

    Parameters
    ----------
    vertices : (N, 3) float64
    faces : (M, 3) integer
        The polygons' triangulation in polygon order, ``size - 2`` each:
        polygons that need clipping are drawn as these triangles.
    sizes : (P,) integer
    indices : (sum of sizes,) integer
    mvp : (4, 4) float64
    width, height : int
    cull_backfaces : bool

    Returns
    -------
    depth : (H, W) float32
    triangle_id : (H, W) int32
        A polygon's pixels carry the id of its first triangle.
    stats : dict
        Triangle counters (each polygon decision counts its ``size - 2``
        triangles) and ``pixels_covered``.
    """
    sizes = np.asarray(sizes, dtype=np.int64)
    indices = np.asarray(indices, dtype=np.int64)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    half_w, half_h = 0.5 * width, 0.5 * height
    gx, gy = GUARD_BAND_PX / half_w, GUARD_BAND_PX / half_h
    (cx, cy, cz, cw), oc, (vx, vy, vz) = _vertex_stage(vertices, mvp, half_w, half_h, gx, gy)

    stats = dict.fromkeys(STAT_KEYS, 0)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    first_tri = np.concatenate([[0], np.cumsum(sizes - 2)])
    fallback = []
    native = []
    for p in range(len(sizes)):
        idx = indices[offsets[p]:offsets[p + 1]]
        n, t = len(idx), len(idx) - 2
        codes = oc[idx]
        any_out = int(np.bitwise_or.reduce(codes))
        all_out = int(np.bitwise_and.reduce(codes))
        if any_out & OUT_INVALID:
            stats["culled_invalid"] += t
        elif all_out & OUT_VIEW:
            stats["culled_frustum"] += t
        elif any_out & OUT_CLIP or n > MAX_POLYGON_CORNERS:
            fallback.extend(range(first_tri[p], first_tri[p] + t))
        else:
            x = [int(v) for v in vx[idx]]
            y = [int(v) for v in vy[idx]]
            area = sum((x[k] - x[0]) * (y[k + 1] - y[0]) - (y[k] - y[0]) * (x[k + 1] - x[0])
                       for k in range(1, n - 1))
            if area == 0:
                stats["culled_degenerate"] += t
            elif area > 0 and cull_backfaces:
                stats["culled_backface"] += t
            else:
                stats["rasterized"] += t
                native.append((x, y, vz[idx], area, int(first_tri[p])))

    # Polygons drawn as their triangles: the triangle pipeline.
    fb = np.array(fallback, dtype=np.int64)
    tris, tri_stats = vertex_stage(vertices, faces[fb], mvp, width, height, cull_backfaces)
    tris.id = fb[tris.id] if len(fb) else tris.id
    for key in STAT_KEYS:
        if key != "triangles_in":
            stats[key] += tri_stats[key]
    stats["triangles_in"] = len(faces)
    depth, ids, pixel_stats = rasterize(tris, width, height)
    stats["pixels_covered"] = pixel_stats["pixels_covered"]
    keys = _keys(depth, ids)
    for x, y, z, area, pid in native:
        pix, zf = _polygon_pixels(x, y, z, area, width, height)
        stats["pixels_covered"] += len(pix)
        key = (zf.view(np.uint32).astype(np.uint64) << np.uint64(32)) | np.uint64(pid)
        keys[pix] = np.minimum(keys[pix], key)  # a polygon covers a pixel once
    del stats["pixels_tested"]  # (an algorithm's own business for polygons)
    depth, ids = _from_keys(keys, width, height)
    return depth, ids, stats


# Whole Renders

def render(mesh, camera: Optional[Camera] = None, width: int = DEFAULT_SIZE[0],
           height: int = DEFAULT_SIZE[1], *, cull_backfaces: bool = False,
           shading: str = "flat", light_dir=None, ambient: float = DEFAULT_AMBIENT,
           diffuse: float = DEFAULT_DIFFUSE, color=None, background=DEFAULT_BACKGROUND,
           polygons: bool = False) -> RenderResult:
    """Render like :func:`zbuffer.render`, in pure numpy.

    Takes the same arguments but ``algo``, ``record_culls`` and ``out``, and
    returns a :class:`~zbuffer.RenderResult` whose ``depth`` and
    ``triangle_id`` every compiled algorithm reproduces exactly. ``stats``
    holds the pipeline's counters that do not depend on the visiting order
    -- ``triangles_in``, ``culled_invalid``, ``culled_frustum``, ``clipped``,
    ``clipped_away``, ``clip_pieces``, ``culled_backface``,
    ``culled_degenerate``, ``culled_hidden`` (0: it culls nothing as
    hidden), ``rasterized``, ``pixels_tested`` (not with
    polygons drawn natively, where it is each algorithm's own) and
    ``pixels_covered`` -- and ``total_ms``.

    With ``polygons=True``, a mesh that keeps polygon faces
    (``mesh.polygon_sizes``) has them drawn natively, as the algorithms
    that draw polygons (``"scanline"``) draw them; other meshes are drawn
    as triangles either way.

    Parameters
    ----------
    mesh, camera, width, height, cull_backfaces
        As for :func:`zbuffer.render`.
    shading, light_dir, ambient, diffuse, color, background
        As for :func:`zbuffer.render`.
    polygons : bool
        Draw polygon faces natively (see above); default False, the
        triangulation, as every algorithm but ``"scanline"`` draws it.

    Returns
    -------
    RenderResult
        ``algo`` is ``"reference"``, ``culls`` None. ``depth`` (H, W)
        float32 and ``triangle_id`` (H, W) int32 as the compiled
        algorithms give them; ``image`` (H, W, 3) uint8 from
        :func:`zbuffer.shading.shade_numpy` (within one level of 255 of
        the compiled shading pass; None with ``shading="none"``).

    Raises
    ------
    ValueError, TypeError
        As :func:`zbuffer.render` for the arguments they share; TypeError
        for a ``polygons`` that is not a bool.
    """
    start = time.perf_counter()
    polygons = check_flag("polygons", polygons)
    mesh, camera, mvp, width, height, params = prepare(
        mesh, camera, width, height, shading, light_dir, ambient, diffuse, color, background,
        cull_backfaces)
    if polygons and mesh.polygon_sizes is not None:
        depth, triangle_id, stats = render_polygons(
            mesh.vertices, mesh.faces, mesh.polygon_sizes, mesh.polygon_indices, mvp,
            width, height, cull_backfaces)
    else:
        tris, stats = vertex_stage(mesh.vertices, mesh.faces, mvp, width, height,
                                   cull_backfaces)
        depth, triangle_id, pixel_stats = rasterize(tris, width, height)
        stats.update(pixel_stats)
    image = None
    if params.mode != "none":
        image = shade_numpy(mesh, triangle_id, camera, mvp, params)
    stats["total_ms"] = (time.perf_counter() - start) * 1e3
    return RenderResult(image=image, depth=depth, triangle_id=triangle_id, stats=stats,
                        camera=camera, mvp=mvp, algo="reference")
