"""Polygon faces as mesh files hold them: what the readers return
(:class:`PolygonData`), colours as files write them, and the exact
triangulation of polygons -- fans for convex ones, ear clipping for concave
ones -- that :func:`zbuffer.load` applies."""

from __future__ import annotations

from typing import List, Tuple

import numpy as np

from .shading import power_scaled

__all__ = ["PolygonData", "file_rgb", "triangulate_polygons"]


class PolygonData:
    """What a reader of a polygon mesh file found (obj.read_obj,
    off.read_off, ply.read_ply).

    Attributes
    ----------
    vertices : (N, 3) float64
    polygon_sizes : (P,) int64
        Number of corners of each face, in file order (>= 3).
    polygon_indices : (sum of sizes,) int64
        Vertex indices of all faces' corners, concatenated, 0-based.
    vertex_colors : (N, 3) float64 or None
        From the file (OBJ: ``v x y z r g b`` lines, when every vertex has them).
    face_colors : (P, 3) float64 or None
        One per face (OFF and PLY files); OBJ faces have none.
    """

    def __init__(self, vertices, polygon_sizes, polygon_indices, vertex_colors,
                 face_colors=None):
        self.vertices = vertices
        self.polygon_sizes = polygon_sizes
        self.polygon_indices = polygon_indices
        self.vertex_colors = vertex_colors
        self.face_colors = face_colors


def read_with_fast_path(path, fast, from_records, from_text) -> PolygonData:
    """A mesh file through its format's compiled fast path: ``fast`` (the
    file's bytes -> records, or None for anything it leaves, errors
    included) and ``from_records`` (records -> PolygonData); else its text
    (UTF-8, undecodable bytes replaced) through the Python reader
    ``from_text``, the one source of error messages."""
    with open(path, "rb") as fh:
        raw = fh.read()
    records = fast(raw)
    if records is not None:
        return from_records(records)
    text = raw.decode("utf-8", errors="replace")
    del raw  # (the text alone from here on)
    return from_text(text)


def file_rgb(rgb: np.ndarray, integers: bool, what: str) -> np.ndarray:
    """Colours read from a file as RGB in [0, 1]: divided by 255 where the
    file gave integers; ValueError outside 0-255 (integers) or [0, 1]
    (floats). (The OFF and PLY readers'.)

    Parameters
    ----------
    rgb : (n, 3) float64
    integers : bool
        Whether the file wrote the values as integers.
    what : str
        What the colours are, for the error message.

    Returns
    -------
    (n, 3) float64

    Raises
    ------
    ValueError
        A value out of range, NaN or infinite.
    """
    if integers:
        rgb = rgb / 255.0
    if rgb.size and (not np.all(np.isfinite(rgb)) or rgb.min() < 0.0 or rgb.max() > 1.0):
        raise ValueError(f"{what} colours must lie in 0-255 (integers) or [0, 1] (floats)")
    return rgb


# Triangulation

# Ear clipping takes time quadratic in a concave polygon's corners (about
# 4 s at this limit, for a comb whose every other corner is reflex): larger
# concave polygons are refused rather than triangulated for minutes.
MAX_CONCAVE_CORNERS = 2**15


def _newell_normals(p: np.ndarray) -> np.ndarray:
    """(..., 3) normals of polygons with corners (..., n, 3) (Newell's
    method), of length twice their areas."""
    q = np.roll(p, -1, axis=-2)
    return np.stack([((p[..., 1] - q[..., 1]) * (p[..., 2] + q[..., 2])).sum(-1),
                     ((p[..., 2] - q[..., 2]) * (p[..., 0] + q[..., 0])).sum(-1),
                     ((p[..., 0] - q[..., 0]) * (p[..., 1] + q[..., 1])).sum(-1)], -1)


def _ear_clip(p2: np.ndarray) -> List[Tuple[int, int, int]]:
    """Triangles (local indices) of a simple polygon given counter-clockwise
    in 2D, by ear clipping. Falls back to a fan if no ear is found (the
    polygon is self-intersecting or degenerate).

    The corners form a circular linked list; after an ear is cut the search
    goes on from its neighbour, and a candidate is tested only against the
    corners that are not convex (only such a corner can lie in an ear of a
    simple polygon), all at once: O(n^2) for n corners in the worst case,
    not O(n^3) (a 2,000-corner spiral takes well under a second).
    """
    n = len(p2)
    x = p2[:, 0].astype(np.float64)
    y = p2[:, 1].astype(np.float64)
    prev = [(k - 1) % n for k in range(n)]
    nxt = [(k + 1) % n for k in range(n)]

    def cross(o, a, b):
        return (x[a] - x[o]) * (y[b] - y[o]) - (y[a] - y[o]) * (x[b] - x[o])

    def convex(v):
        return cross(prev[v], v, nxt[v]) > 0.0

    # Corners that are reflex or flat: the only ones an ear can hold.
    reflex = np.zeros(n, bool)
    for v in range(n):
        reflex[v] = not convex(v)

    def is_ear(b):
        a, c = prev[b], nxt[b]
        if reflex[b]:
            return False
        d = np.flatnonzero(reflex)
        d = d[(d != a) & (d != c)]
        if len(d) == 0:
            return True
        xd, yd = x[d], y[d]
        inside = (((x[b] - x[a]) * (yd - y[a]) - (y[b] - y[a]) * (xd - x[a])) >= 0.0) & \
                 (((x[c] - x[b]) * (yd - y[b]) - (y[c] - y[b]) * (xd - x[b])) >= 0.0) & \
                 (((x[a] - x[c]) * (yd - y[c]) - (y[a] - y[c]) * (xd - x[c])) >= 0.0)
        return not inside.any()

    triangles = []
    remaining, v, misses = n, 0, 0
    while remaining > 3 and misses < remaining:
        if not is_ear(v):
            v, misses = nxt[v], misses + 1
            continue
        a, c = prev[v], nxt[v]
        triangles.append((a, v, c))
        nxt[a], prev[c] = c, a
        reflex[v] = False
        remaining -= 1
        for u in (a, c):
            reflex[u] = not convex(u)
        v, misses = a, 0
    if remaining >= 3:  # no ear left (self-intersecting or degenerate): a fan
        rest = [v]
        for _ in range(remaining - 1):
            rest.append(nxt[rest[-1]])
        triangles += [(rest[0], rest[k], rest[k + 1]) for k in range(1, len(rest) - 1)]
    return triangles


# The two triangles _ear_clip cuts a quad into, by the first corner v
# (0-3) that is an ear: the ear (v - 1, v, v + 1), then a fan of the rest
# from v - 1; row 4, no ear (a self-intersecting or degenerate quad): the
# fan from corner 0 that _ear_clip falls back to.
_QUAD_TRIANGLES = np.array([[[3, 0, 1], [3, 1, 2]],
                            [[0, 1, 2], [0, 2, 3]],
                            [[1, 2, 3], [1, 3, 0]],
                            [[2, 3, 0], [2, 0, 1]],
                            [[0, 1, 2], [0, 2, 3]]], dtype=np.int64)


def _ear_clip_quads(p2: np.ndarray) -> np.ndarray:
    """:func:`_ear_clip` of many quads at once: (Q, 4, 2) corners, each quad
    counter-clockwise in 2D, to (Q, 2, 3) local indices -- the same
    triangles, from the same operations on the same numbers (tests hold
    the two to that).

    In a quad, a corner b that is not reflex is an ear unless the corner
    opposite it, the only other corner that can lie in the triangle of b
    and its neighbours, is reflex and lies in it; the first ear in corner
    order decides the triangles (:data:`_QUAD_TRIANGLES`).
    """
    x = p2[..., 0].astype(np.float64)
    y = p2[..., 1].astype(np.float64)
    k = np.arange(4)
    prev, nxt, opp = (k - 1) % 4, (k + 1) % 4, (k + 2) % 4
    xa, ya, xc, yc, xd, yd = x[:, prev], y[:, prev], x[:, nxt], y[:, nxt], x[:, opp], y[:, opp]
    reflex = ~((x - xa) * (yc - ya) - (y - ya) * (xc - xa) > 0.0)
    inside = (((x - xa) * (yd - ya) - (y - ya) * (xd - xa)) >= 0.0) & \
             (((xc - x) * (yd - y) - (yc - y) * (xd - x)) >= 0.0) & \
             (((xa - xc) * (yd - yc) - (ya - yc) * (xd - xc)) >= 0.0)
    ear = ~reflex & ~(reflex[:, opp] & inside)
    first = np.where(ear.any(axis=1), np.argmax(ear, axis=1), 4)
    return _QUAD_TRIANGLES[first]


def triangulate_polygons(vertices: np.ndarray, sizes: np.ndarray, indices: np.ndarray
                         ) -> Tuple[np.ndarray, np.ndarray]:
    """Triangles covering each polygon exactly.

    Convex polygons become fans from their first corner (in the corners'
    order, so triangles keep the polygon's winding); other polygons are ear
    clipped in their best-fit plane (time quadratic in the corners: up to
    :data:`MAX_CONCAVE_CORNERS` of them). A fan of a concave polygon would
    cover area outside it.

    Parameters
    ----------
    vertices : (N, 3) float64
    sizes : (P,) array_like of int
        Corners of each polygon, each at least 3.
    indices : (sum of sizes,) array_like of int
        The polygons' vertex indices, concatenated, 0-based (not checked).

    Returns
    -------
    faces : (M, 3) int64
        ``size - 2`` triangles per polygon, in polygon order: M is the sum
        of ``sizes - 2``.
    face_polygon : (M,) int64
        The polygon each triangle came from.

    Raises
    ------
    ValueError
        A polygon that is not convex has more than
        :data:`MAX_CONCAVE_CORNERS` corners.
    """
    sizes = np.asarray(sizes, dtype=np.int64)
    indices = np.asarray(indices, dtype=np.int64)
    if len(sizes) and (sizes == 3).all():  # triangles only (most meshes): as they are
        return indices.reshape(-1, 3), np.arange(len(sizes), dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]) if len(sizes) else sizes

    def group(n):  # the polygons of n corners, their vertex indices (P, n), scaled corners
        polys = np.flatnonzero(sizes == n)
        idx = indices[starts[polys, None] + np.arange(n)]
        # Each polygon is scaled by a power of two (exact: the same
        # decisions), so that no product below -- up to the fourth power of
        # the coordinates -- underflows or overflows: near 1e-80 or 1e77 a
        # concave polygon passed for convex and became a fan, and near 1e154
        # the ear clipping found no ear.
        return polys, idx, power_scaled(vertices[idx], axis=(1, 2))

    def convexity(p):  # every corner turns the same way as the polygon's normal
        turn = np.cross(p - np.roll(p, 1, axis=1), np.roll(p, -1, axis=1) - p)  # (P, n, 3)
        return (np.einsum("pnk,pk->pn", turn, _newell_normals(p)) >= 0.0).all(axis=1)

    tested = {}  # n: convexity of the polygons of the sizes over the limit, tested first
    for n in np.unique(sizes[sizes > MAX_CONCAVE_CORNERS]):  # refused before any is clipped
        polys, _, p = group(n)
        convex = tested[n] = convexity(p)
        if not convex.all():
            raise ValueError(
                f"polygon {int(polys[np.argmin(convex)])} has {n:,} corners and is not convex: "
                f"concave polygons are triangulated (by ear clipping, in time quadratic in the "
                f"corners) up to {MAX_CONCAVE_CORNERS:,} corners each; split it, or triangulate "
                "it before loading")
    faces: List[np.ndarray] = []
    owners: List[np.ndarray] = []
    for n in np.unique(sizes):
        if n == 3:
            polys = np.flatnonzero(sizes == 3)
            faces.append(indices[starts[polys, None] + np.arange(3)])
            owners.append(polys)
            continue
        polys, idx, p = group(n)
        convex = tested[n] if n in tested else convexity(p)
        k = np.arange(1, n - 1)
        fan = np.stack([np.repeat(idx[convex, :1], n - 2, axis=1),
                        idx[convex][:, k], idx[convex][:, k + 1]], -1)
        faces.append(fan.reshape(-1, 3))
        owners.append(np.repeat(polys[convex], n - 2))
        if convex.all():
            continue
        concave = np.flatnonzero(~convex)
        pts = p[concave]
        nrm = _newell_normals(pts)
        axis = np.argmax(np.abs(nrm), axis=1)
        # Project along the dominant axis onto a right-handed 2D frame
        # (y, z), (z, x) or (x, y), mirrored if the normal points the other
        # way: the polygon is then counter-clockwise.
        mirrored = np.take_along_axis(nrm, axis[:, None], axis=1)[:, 0] < 0.0
        first = np.where(mirrored, axis + 2, axis + 1) % 3
        second = np.where(mirrored, axis + 1, axis + 2) % 3
        p2 = np.stack([np.take_along_axis(pts, first[:, None, None], axis=2)[..., 0],
                       np.take_along_axis(pts, second[:, None, None], axis=2)[..., 0]], -1)
        if n == 4:  # the common case, all at once
            tris = _ear_clip_quads(p2)
            corners = np.take_along_axis(idx[concave], tris.reshape(-1, 6), axis=1)
            faces.append(corners.reshape(-1, 3))
            owners.append(np.repeat(polys[concave], 2))
            continue
        for j, corners, q in zip(concave, idx[concave], p2):
            tris = np.array(_ear_clip(q), dtype=np.int64).reshape(-1, 3)
            faces.append(corners[tris])
            owners.append(np.full(len(tris), polys[j]))
    if not faces:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    faces_all = np.concatenate(faces)
    owner_all = np.concatenate(owners)
    order = np.argsort(owner_all, kind="stable")  # triangles in polygon order
    return faces_all[order], owner_all[order]
