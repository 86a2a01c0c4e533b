"""A reader for ASCII OFF files (Geomview's Object File Format) that keeps
their polygon faces as written.

trimesh fan-triangulates an OFF file's polygons as it reads them: a concave
polygon's fan covers area outside it. Like the OBJ reader (obj.py), this one
returns the faces as written; :func:`zbuffer.load` triangulates them exactly
and keeps them for the algorithms that draw polygons natively.

The files of the forms tools write are parsed by compiled code
(``_core.read_off_records``, cpp/include/zbuffer/off_reader.h); it takes
only what it reads exactly as the Python reader here does, and leaves the
rest -- errors included -- to it.
"""

from __future__ import annotations

from typing import List, Optional

import numpy as np

from . import _core
from .polygons import PolygonData, file_rgb, read_with_fast_path

__all__ = ["read_off"]

# Headers with what each vertex record holds after x y z: N a normal (3
# numbers), C a colour (3 or 4 numbers). ST (texture) and 4/n (other
# dimensions) are not read.
_HEADERS = {"OFF": (False, False), "COFF": (False, True), "NOFF": (True, False),
            "CNOFF": (True, True)}


def _colors(rows: List[List[str]], what: str, line_numbers: List[int]) -> Optional[np.ndarray]:
    """(n, 3) float RGB in [0, 1] from colour records (3 or 4 numbers
    each: integers 0-255 or, written with a point or exponent, floats 0-1),
    or None when not every record has one."""
    if not rows or any(len(r) not in (3, 4) for r in rows):
        return None
    try:
        values = np.array([[float(x) for x in r[:3]] for r in rows], dtype=np.float64)
    except ValueError:
        k = next(i for i, r in enumerate(rows) if not all(_is_number(x) for x in r))
        raise ValueError(f"line {line_numbers[k]}: {what} colour is not numbers: "
                         f"{' '.join(rows[k])!r}") from None
    floats = any(any(c in x for c in ".eE") for r in rows for x in r)
    return file_rgb(values, not floats, what)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_off(path: str) -> PolygonData:
    """Parse an ASCII OFF file: header (``OFF``, ``COFF``, ``NOFF`` or
    ``CNOFF``), counts (vertices, faces, edges; on the header's line or the
    next, and also run into the header, ``OFF9278 6940 0``, as in many files
    of the ModelNet datasets), vertex records (x y z, then
    a normal and/or colour as the header says), face records (the number of
    corners, their 0-based vertex indices, optionally a colour). ``#``
    starts a comment; records are one a line.

    Parameters
    ----------
    path : str or os.PathLike
        Read as UTF-8 (undecodable bytes replaced; a byte order mark
        allowed).

    Returns
    -------
    PolygonData
        With ``face_colors`` (one per face, as written) when every face
        record has a colour, and ``vertex_colors`` from a ``COFF`` file.

    Raises
    ------
    ValueError
        Not an ASCII OFF file (:func:`zbuffer.load` refuses binary OFF
        before calling this: :func:`is_binary_off`), counts that the records do not
        match, malformed records (naming the line), indices outside the
        vertices.
    """
    # Most files go through the compiled reader of the format's common
    # subset (cpp/include/zbuffer/off_reader.h): it gives what the reader
    # below gives, or None -- for anything else, errors included.
    return read_with_fast_path(path, _core.read_off_records, _off_data, _read_off_text)


def _off_data(records) -> PolygonData:
    """PolygonData of _core.read_off_records' records (their colours
    through file_rgb, which may raise ValueError)."""
    vertices, sizes, indices, vertex_rgb, vertex_floats, face_rgb, face_floats = records
    return PolygonData(
        vertices, sizes, indices,
        None if vertex_rgb is None else file_rgb(vertex_rgb, not vertex_floats, "vertex"),
        None if face_rgb is None else file_rgb(face_rgb, not face_floats, "face"))


def _read_off_text(text: str) -> PolygonData:
    """:func:`read_off` of the file's text (decoded as UTF-8, undecodable
    bytes replaced), in Python: every file the format allows, and the
    messages for those it does not."""
    text = text.removeprefix("\ufeff")
    records = []  # (line number, tokens)
    for number, line in enumerate(text.splitlines(), start=1):
        content = line.partition("#")[0]
        if "_" in content or not content.isascii():  # numbers Python reads but OFF has not
            raise ValueError(f"line {number}: a number may hold only ASCII digits, signs, "
                             f"'.' and 'e', got {content.strip()!r}")
        tokens = content.split()
        if tokens:
            records.append((number, tokens))
    if records:  # "OFF9278 6940 0": the header run into the vertex count (many ModelNet files)
        first = records[0][1]
        joined = next((h for h in _HEADERS if first[0].startswith(h)
                       and first[0][len(h):len(h) + 1].isdigit()), None)
        if joined and first[0] not in _HEADERS:
            first[:1] = [joined, first[0][len(joined):]]
    if not records or records[0][1][0] not in _HEADERS:
        raise ValueError("not an OFF file (the first record is not OFF, COFF, NOFF or CNOFF)")
    normals, colours = _HEADERS[records[0][1][0]]
    counts = records[0][1][1:]
    at = 1
    if not counts:
        if len(records) < 2:
            raise ValueError("no vertex, face and edge counts after the header")
        counts, at = records[1][1], 2
    try:
        if len(counts) != 3 or not all(c.isdigit() for c in counts):
            raise ValueError
        n_vertices, n_faces = int(counts[0]), int(counts[1])  # (over 4300 digits: ValueError)
    except ValueError:
        raise ValueError(f"line {records[at - 1][0]}: expected the vertex, face and edge counts, "
                         f"got {' '.join(counts)[:80]!r}") from None
    if len(records) < at + n_vertices + n_faces:
        raise ValueError(f"the header counts {n_vertices} vertices and {n_faces} faces, but the "
                         f"file has {len(records) - at} records after it")
    if len(records) > at + n_vertices + n_faces:
        number = records[at + n_vertices + n_faces][0]
        raise ValueError(f"line {number}: more records than the header counts "
                         f"({n_vertices} vertices, {n_faces} faces)")

    width = 3 + (3 if normals else 0)
    coords: List[str] = []
    vertex_colour_rows: List[List[str]] = []
    vertex_lines: List[int] = []
    for number, tokens in records[at:at + n_vertices]:
        extra = len(tokens) - width
        if extra < 0 or (not colours and extra) or (colours and extra not in (3, 4)):
            raise ValueError(f"line {number}: a vertex needs {width} numbers"
                             f"{' and a colour' if colours else ''}, got {' '.join(tokens)!r}")
        coords.extend(tokens[:3])
        vertex_colour_rows.append(tokens[width:])
        vertex_lines.append(number)
    try:
        vertices = np.array(coords, dtype=np.float64).reshape(n_vertices, 3)
    except ValueError as err:
        raise ValueError(f"a vertex record has a non-numeric coordinate: {err}") from None

    sizes: List[int] = []
    corners: List[int] = []
    face_colour_rows: List[List[str]] = []
    face_lines: List[int] = []
    for number, tokens in records[at + n_vertices:]:
        try:
            n = int(tokens[0])
            if n < 3 or len(tokens) < 1 + n:
                raise ValueError
            index = [int(x) for x in tokens[1:1 + n]]
        except ValueError:
            raise ValueError(f"line {number}: bad face record {' '.join(tokens)!r} (the "
                             "number of corners, at least 3, then their indices)") from None
        if min(index) < 0 or max(index) >= n_vertices:
            raise ValueError(f"line {number}: face index outside [0, {n_vertices})")
        colour = tokens[1 + n:]
        if len(colour) not in (0, 1, 3, 4) or not all(_is_number(x) for x in colour):
            raise ValueError(f"line {number}: after a face's indices, a colour: a colour map "
                             f"index, or 3 or 4 numbers; got {' '.join(colour)!r}")
        sizes.append(n)
        corners.extend(index)
        face_colour_rows.append(tokens[1 + n:])
        face_lines.append(number)

    vertex_colors = _colors(vertex_colour_rows, "vertex", vertex_lines) if colours else None
    return PolygonData(vertices, np.array(sizes, dtype=np.int64),
                       np.array(corners, dtype=np.int64), vertex_colors,
                       _colors(face_colour_rows, "face", face_lines))


def is_binary_off(path: str) -> bool:
    """True if the file's header says ``OFF BINARY`` (or the same after
    ``COFF``, ``NOFF``, ``CNOFF``)."""
    with open(path, "rb") as fh:
        head = fh.read(256)
    first = head.split(b"\n", 1)[0].split(b"#", 1)[0].split()
    return len(first) >= 2 and first[0].decode("ascii", "replace") in _HEADERS \
        and first[1] == b"BINARY"
