"""Reading Wavefront OBJ files, polygons as written.

zbuffer reads OBJ itself rather than through trimesh for three reasons:
relative (negative) indices must count from the vertices defined *so far*
(trimesh 5.2 resolves them wrongly once a file changes group or object, e.g.
the McGuire Cornell box); positions only matter for rendering, so corners
that differ only in texture coordinates or normals need not be split into
separate vertices; and polygon faces are kept as written, so that a concave
polygon can be triangulated correctly (ear clipping) rather than as a fan,
which covers area outside it.

The files of the forms exporters write are parsed by compiled code
(``_core.read_obj_records``, cpp/include/zbuffer/obj_reader.h), 14-18
times faster (benchmarks/results/load.md) and in a quarter of the memory;
it takes only what it reads
exactly as the Python reader here does, and leaves the rest -- errors
included -- to it.
"""

from __future__ import annotations

from typing import List

import numpy as np

from . import _core
from .polygons import PolygonData, read_with_fast_path

__all__ = ["read_obj"]


def read_obj(path: str) -> PolygonData:
    """Parse the ``v`` and ``f`` records of an OBJ file.

    Supports ``v x y z [w]`` and ``v x y z r g b``, faces of any number of
    corners written ``i``, ``i/t``, ``i//n`` or ``i/t/n`` with positive or
    negative (relative) indices, records indented by white space, ``#``
    comments (whole lines or the end of one) and ``\\`` line continuations
    (which do not extend comments: a comment ends at its line's end).
    Everything else (texture coordinates, normals, groups, materials, lines,
    points) is ignored.

    Parameters
    ----------
    path : str or os.PathLike
        Read as UTF-8 (undecodable bytes replaced); a byte order mark and
        any line ending (``\\n``, ``\\r\\n``, ``\\r``) are allowed.

    Returns
    -------
    PolygonData
        ``vertices`` (the ``v`` records' x, y, z; ``w`` is dropped), the
        faces as written with 0-based indices (relative ones resolved
        against the vertices defined before their record), and
        ``vertex_colors`` when every ``v`` record has r g b: fractions
        in [0, 1], or bytes 0-255 (divided by 255) when every value is a
        whole number and some exceed 1; no ``face_colors``.

    Raises
    ------
    ValueError
        A malformed ``v`` or ``f`` record, a vertex coordinate that is not
        a finite number, a vertex colour outside [0, 1] (outside 0-255
        when every colour is a whole number), or an index outside
        the vertices (each naming the line).
    """
    # Most files go through the compiled reader of the format's common
    # subset (cpp/include/zbuffer/obj_reader.h): it gives what the reader
    # below gives, or None -- for anything else, errors included.
    return read_with_fast_path(path, _core.read_obj_records, _obj_data, _read_obj_text)


def _obj_data(records) -> PolygonData:
    """PolygonData of _core.read_obj_records' records."""
    vertices, colors, sizes, indices = records
    return PolygonData(vertices, sizes, indices, _unit_colors(colors))


def _read_obj_text(text: str) -> PolygonData:
    """:func:`read_obj` of the file's text (decoded as UTF-8, undecodable
    bytes replaced), in Python: every file the format allows, and the
    messages for those it does not."""
    text = text.removeprefix("\ufeff")  # a byte order mark is not part of the first record

    coords: List[str] = []        # the numbers of the v records, as text
    coord_count: List[int] = []   # how many numbers each v record has
    sizes: List[int] = []
    corners: List[int] = []
    vertex_lines: List[int] = []  # the line each v record starts on (for messages)
    face_lines: List[int] = []    # and each f record
    # Lines end at \n, \r\n or \r, as editors count them (not at the other
    # characters str.splitlines breaks at: form feeds, \x85, \u2028, ...).
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    number = 0
    while number < len(lines):
        line = lines[number].lstrip()
        number += 1
        start = number  # 1-based number of the record's first line
        if not line or line[0] not in "vf":
            continue  # comments (even ending in a backslash) and other records
        # A comment ends the record; a backslash ending what is left of a
        # line (white space after it aside) continues it on the next line.
        line = line.partition("#")[0].rstrip()
        while line.endswith("\\") and number < len(lines):  # continuation
            line = line[:-1] + " " + lines[number].partition("#")[0].rstrip()
            number += 1
        parts = line.split()
        if not parts:
            continue
        if "_" in line or not line.isascii():  # numbers Python reads but OBJ has not: 1_0, ١
            raise ValueError(f"line {start}: a number may hold only ASCII digits, signs, "
                             f"'.', 'e' and '/' separators, got {line.strip()!r}")
        tag = parts[0]
        if tag == "v":
            if len(parts) not in (4, 5, 7):
                raise ValueError(f"line {start}: a vertex needs 3 coordinates "
                                 f"(optionally w, or r g b), got {line.strip()!r}")
            coords.extend(parts[1:])
            coord_count.append(len(parts) - 1)
            vertex_lines.append(start)
        elif tag == "f":
            if len(parts) < 4:
                raise ValueError(f"line {start}: a face needs at least 3 corners, "
                                 f"got {line.strip()!r}")
            defined = len(coord_count)
            try:
                for corner in parts[1:]:
                    k = int(corner.split("/", 1)[0])
                    if abs(k) > 2**31:
                        raise ValueError("index out of range")
                    if k < 0:
                        k += defined   # -1 is the last vertex defined so far
                    elif k > 0:
                        k -= 1
                    else:
                        raise ValueError("index 0")
                    corners.append(k)
            except ValueError:
                raise ValueError(f"line {start}: bad face record {line.strip()!r}") from None
            sizes.append(len(parts) - 1)
            face_lines.append(start)

    try:
        values = np.array(coords, dtype=np.float64)
    except ValueError:
        k = next(i for i, c in enumerate(coords) if not _is_float(c))
        record = int(np.searchsorted(np.cumsum(coord_count), k, side="right"))
        raise ValueError(f"line {vertex_lines[record]}: a vertex coordinate is not a number, "
                         f"got {coords[k]!r}") from None
    counts = np.array(coord_count, dtype=np.int64)
    n = len(counts)
    if n and (counts == counts[0]).all():
        table = values.reshape(n, counts[0])
    else:  # mixed record lengths: pad to 7 columns
        table = np.zeros((n, 7))
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]]) if n else counts
        for c in np.unique(counts):
            rows = np.flatnonzero(counts == c)
            idx = starts[rows, None] + np.arange(c)
            table[rows, :c] = values[idx]
    vertices = np.ascontiguousarray(table[:, :3]) if n else np.zeros((0, 3))
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"line {vertex_lines[k]}: a vertex coordinate is NaN or infinite, "
                         f"got {vertices[k].tolist()}")
    colors = None
    if n and (counts == 6).all():
        colors = np.ascontiguousarray(table[:, 3:6])
        bad = ~(np.isfinite(colors) & (colors >= 0.0) & (colors <= 255.0)).all(axis=1)
        if not bad.any() and not _whole(colors):
            bad = (colors > 1.0).any(axis=1)  # fractions: all in [0, 1]
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(f"line {vertex_lines[k]}: a vertex colour must lie in [0, 1], or "
                             f"in 0-255 with every colour of the file a whole number, got "
                             f"{colors[k].tolist()}")

    polygon_sizes = np.array(sizes, dtype=np.int64)
    polygon_indices = np.array(corners, dtype=np.int64)
    bad = (polygon_indices < 0) | (polygon_indices >= n)
    if bad.any():
        k = int(np.argmax(bad))
        face = int(np.searchsorted(np.cumsum(polygon_sizes), k, side="right"))
        raise ValueError(f"line {face_lines[face]}: face {face} refers to vertex "
                         f"{int(polygon_indices[k]) + 1} (1-based, after resolving relative "
                         f"indices), but the file has {n} vertices")
    return PolygonData(vertices, polygon_sizes, polygon_indices, _unit_colors(colors))


def _unit_colors(colors):
    """The v records' colours in [0, 1]: divided by 255 when any exceeds 1
    (some exporters write 0-255; the readers have checked that every value
    is then a whole number)."""
    if colors is not None and colors.max(initial=0.0) > 1.0:
        return colors / 255.0
    return colors


def _whole(colors: np.ndarray) -> bool:
    """Whether every colour value is a whole number, as bytes 0-255 are (and
    fractions that are all 0 or 1)."""
    return bool((colors == np.floor(colors)).all())


def _is_float(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False
