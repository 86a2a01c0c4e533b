"""A reader for PLY files (ASCII and binary) that keeps polygon faces as
written.

trimesh fan-triangulates a PLY file's polygons (a concave polygon's fan
covers area outside it), fails on polygons with face colours, and reads
some malformed files without a word (faces dropped, colours wrapped).
:func:`zbuffer.load` reads PLY files with this reader, and leaves to trimesh
only those it does not know (:class:`UnsupportedPly`: other formats,
property types, faces not given as a vertex_indices list, point clouds).

The records of ASCII files whose every element's records are as long as
its first (meshes of triangles, or of quads) are parsed by compiled code
(``_core.read_ascii_ply_tables``, cpp/include/zbuffer/ply_reader.h) into
the tables the line-by-line reading would make; other files, and those
with errors, are read line by line.
"""

from __future__ import annotations

import struct
from typing import Tuple

import numpy as np

from . import _core
from .polygons import PolygonData, file_rgb

__all__ = ["read_ply", "UnsupportedPly"]


class UnsupportedPly(ValueError):
    """A PLY file this reader does not read (not PLY, another format or
    property type, no faces as a vertex_indices list): trimesh's to try."""

_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
          "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
          "float": "f", "float32": "f", "double": "d", "float64": "d"}
_INDEX_NAMES = ("vertex_indices", "vertex_index")


def _header(fh) -> Tuple[str, list]:
    """(format, [(element, count, [(name, type, count_type or None)])]) of
    the header at the start of ``fh``, which is left just past it."""
    if fh.readline().strip().removeprefix(b"\xef\xbb\xbf") != b"ply":
        raise UnsupportedPly("not a PLY file")
    fmt, elements = None, []
    for raw in fh:
        words = raw.decode("ascii", "replace").split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) >= 2:
            fmt = words[1]
        elif words[0] == "element" and len(words) == 3:
            if not words[2].isdigit():
                raise ValueError("an element count must be a whole number, got "
                                 f"{' '.join(words)!r}")
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) >= 3:
            if words[1] == "list" and len(words) == 5 and words[2] in _TYPES \
                    and words[3] in _TYPES:
                if _TYPES[words[2]] in "fd":
                    raise ValueError(f"a list's count must have an integer type, got "
                                     f"{' '.join(words)!r}")
                elements[-1][2].append((words[4], _TYPES[words[3]], _TYPES[words[2]]))
            elif len(words) == 3 and words[1] in _TYPES:
                elements[-1][2].append((words[2], _TYPES[words[1]], None))
            else:
                raise UnsupportedPly(f"unreadable PLY property line {' '.join(words)!r}")
        elif words[0] == "end_header":
            if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise UnsupportedPly(f"unknown PLY format {fmt!r}")
            return fmt, elements
        else:
            raise UnsupportedPly(f"unreadable PLY header line {' '.join(words)!r}")
    raise UnsupportedPly("the PLY header does not end")


def _fixed(props) -> bool:
    return all(p[2] is None for p in props)


def _records_binary(body: bytes, offset: int, order: str, count: int, props):
    """``count`` records of an element at ``offset``: (scalar values as a
    (count, scalars) float64 array, list values per list property (count
    lists), the offset after them)."""
    least = sum(struct.calcsize(p[2] or p[1]) for p in props)  # (bytes of a record, lists empty)
    if count * least > len(body) - offset:  # (before anything of the count's size is made)
        raise ValueError("the file holds fewer records than its header declares")
    if _fixed(props):
        dtype = np.dtype([(f"p{k}", order + kind) for k, (_, kind, _) in enumerate(props)])
        end = offset + count * dtype.itemsize  # (within the body: checked above)
        table = np.frombuffer(body, dtype=dtype, count=count, offset=offset)
        scalars = np.stack([table[f"p{k}"].astype(np.float64) for k in range(len(props))], 1) \
            if props else np.zeros((count, 0))
        return scalars, {}, end
    uniform = _uniform_binary(body, offset, order, count, props)
    if uniform is not None:
        return uniform
    scalars = np.zeros((count, sum(p[2] is None for p in props)))
    lists = {k: [] for k, p in enumerate(props) if p[2] is not None}
    try:
        for r in range(count):
            column = 0
            for k, (_, kind, count_kind) in enumerate(props):
                if count_kind is None:
                    (scalars[r, column],) = struct.unpack_from(order + kind, body, offset)
                    offset += struct.calcsize(kind)
                    column += 1
                else:
                    (n,) = struct.unpack_from(order + count_kind, body, offset)
                    if n < 0:
                        raise ValueError(f"record {r} of an element has a list of {n} items")
                    offset += struct.calcsize(count_kind)
                    lists[k].append(struct.unpack_from(f"{order}{n}{kind}", body, offset))
                    offset += n * struct.calcsize(kind)
    except struct.error:
        raise ValueError("the file holds fewer records than its header declares") from None
    return scalars, lists, offset


def _uniform_binary(body: bytes, offset: int, order: str, count: int, props):
    """_records_binary's result where every list of the element has as many
    items as in its first record (a mesh of triangles: most files), read
    as fixed-size records at once; None otherwise."""
    fields, at = [], offset
    for k, (_, kind, count_kind) in enumerate(props):
        if count_kind is None:
            fields.append((f"s{k}", order + kind))
            at += struct.calcsize(kind)
            continue
        if at + struct.calcsize(count_kind) > len(body):
            return None
        (n,) = struct.unpack_from(order + count_kind, body, at)
        at += struct.calcsize(count_kind) + n * struct.calcsize(kind)
        if n < 0 or at > len(body):
            return None  # (the record by record reading says what is wrong)
        fields += [(f"n{k}", order + count_kind), (f"l{k}", order + kind, (n,))]
    dtype = np.dtype(fields)
    if count == 0 or offset + count * dtype.itemsize > len(body):
        return None
    table = np.frombuffer(body, dtype=dtype, count=count, offset=offset)
    lists = {}
    for k, p in enumerate(props):
        if p[2] is not None:
            if (table[f"n{k}"] != dtype[f"l{k}"].shape[0]).any():
                return None
            lists[k] = table[f"l{k}"].reshape(count, -1)
    columns = [table[f"s{k}"].astype(np.float64) for k, p in enumerate(props) if p[2] is None]
    scalars = np.stack(columns, 1) if columns else np.zeros((count, 0))
    return scalars, lists, offset + count * dtype.itemsize


def _as_declared(scalars: np.ndarray, props) -> np.ndarray:
    """ASCII scalars as their declared types hold them (a ``float``
    property's text rounded to float32, as binary files and trimesh have
    it)."""
    names = [p[0] for p in props if p[2] is None]
    kinds = [p[1] for p in props if p[2] is None]
    for c, kind in enumerate(kinds):
        if kind == "f":
            column = scalars[:, c]
            big = np.isfinite(column) & (np.abs(column) > np.finfo(np.float32).max)
            if big.any():
                raise ValueError(f"property {names[c]!r} is a float (32-bit), but a record "
                                 f"holds {float(column[big][0])!r}, beyond its range")
            scalars[:, c] = column.astype(np.float32)
        elif kind != "d" and (scalars[:, c] != np.round(scalars[:, c])).any():
            bad = scalars[:, c][scalars[:, c] != np.round(scalars[:, c])][0]
            raise ValueError(f"property {names[c]!r} has an integer type, but a record holds "
                             f"{float(bad)!r}")
    return scalars


def _ascii_fast(body: bytes, elements):
    """Every element's _records_ascii result, from the number tables the
    compiled reader makes of the body (``_core.read_ascii_ply_tables``,
    cpp/include/zbuffer/ply_reader.h: files whose every element's records
    are as long as its first, of plain numbers, nothing after them); None
    for other files, which _records_ascii then reads line by line -- those
    with an element named twice (of which that reading refuses a second
    vertex or face element before reading it) or a count beyond the body's
    size included."""
    names = [name for name, _, _ in elements]
    if len(set(names)) < len(names) or any(count > len(body) for _, count, _ in elements):
        return None
    tables = _core.read_ascii_ply_tables(body, [count for _, count, _ in elements])
    if tables is None:
        return None
    records = []
    for (_, count, props), table in zip(elements, tables):
        found = _table_records(table, props) if count else _records_ascii(iter(()), 0, props)
        if found is None:
            return None
        records.append(found)
    return records


def _table_records(table: np.ndarray, props):
    """_records_ascii's result from a (count >= 1, words) table of an
    element's records, every record as long as the first, its words read
    as numbers; None where a list's count differs between records, or
    exceeds the record, or an integer list holds a fraction (the record by
    record reading says which)."""
    scalars, lists, at = [], {}, 0
    for k, (_, kind, count_kind) in enumerate(props):
        if at >= table.shape[1]:
            return None  # (records shorter than the properties)
        if count_kind is None:
            scalars.append(table[:, at])
            at += 1
            continue
        counts = table[:, at]
        if not np.isfinite(counts[0]) or (counts != counts[0]).any():
            return None  # (inf, nan, or counts that differ: the record by record reading says)
        n = int(counts[0])
        if n < 0 or at + 1 + n > table.shape[1]:
            return None
        values = table[:, at + 1:at + 1 + n]
        if kind not in "fd":
            if not (np.abs(values) < 2.0 ** 53).all() or (values != np.round(values)).any():
                return None
            values = values.astype(np.int64)
        lists[k] = values
        at += 1 + n
    if at != table.shape[1]:
        return None
    scalars = np.stack(scalars, 1) if scalars else np.zeros((len(table), 0))
    return _as_declared(scalars, props), lists


def _records_ascii(lines, count: int, props):
    """(scalar table, lists per list property) from the next ``count``
    lines of ASCII records: as _records_binary, without the offset."""
    rows = []
    for _ in range(count):  # (a line a record: stops where they run out, whatever the count)
        line = next(lines, None)
        if line is None:
            raise ValueError("the file holds fewer records than its header declares")
        rows.append(line)
    try:  # every record as long as the first (a mesh of triangles): all at once
        table = np.array([r.split() for r in rows], dtype=np.float64)
    except ValueError:
        table = None
    if table is not None and table.ndim == 2 and count:
        records = _table_records(table, props)
        if records is not None:
            return records
    lines = iter(rows)
    scalars = np.zeros((count, sum(p[2] is None for p in props)))
    lists = {k: [] for k, p in enumerate(props) if p[2] is not None}
    for r in range(count):
        line = next(lines)  # (rows holds count lines)
        tokens, at, column = line.split(), 0, 0
        try:
            for k, (_, kind, count_kind) in enumerate(props):
                if count_kind is None:
                    scalars[r, column] = float(tokens[at])
                    at, column = at + 1, column + 1
                else:
                    n = int(tokens[at])
                    values = tokens[at + 1:at + 1 + n]
                    if len(values) != n:
                        raise IndexError
                    lists[k].append(tuple(float(x) if kind in "fd" else int(x) for x in values))
                    at += 1 + n
            if at != len(tokens):
                raise ValueError
        except (IndexError, ValueError):
            raise ValueError(f"malformed PLY record {line.strip()!r}") from None
    return _as_declared(scalars, props), lists


def _colours(scalars, names, kinds, what: str):
    """(n, 3) RGB in [0, 1] from red, green and blue properties (integers
    0-255, floats 0-1), or None without them."""
    if not all(c in names for c in ("red", "green", "blue")):
        return None
    at = [names.index(c) for c in ("red", "green", "blue")]
    return file_rgb(scalars[:, at], kinds[at[0]] not in "fd", f"PLY {what}")


def read_ply(path: str) -> PolygonData:
    """A PLY file's vertices (x, y, z; red, green, blue when present) and
    the polygons of its ``face`` element as written (with red, green, blue
    when present), skipping every other property and element.

    Parameters
    ----------
    path : str or os.PathLike
        An ASCII, binary little-endian or binary big-endian PLY file.

    Returns
    -------
    PolygonData
        ``vertices`` as float64 (``float`` properties of ASCII files
        rounded to float32 first, as binary files hold them), the faces'
        ``vertex_indices`` (or ``vertex_index``) lists as written, and
        vertex or face colours where the element has ``red``, ``green``
        and ``blue`` (integer types divided by 255, float types kept).

    Raises
    ------
    UnsupportedPly
        A header this reader does not know: not PLY, another format or
        property type, no vertex element with x, y and z, no face element
        with a ``vertex_indices`` list.
    ValueError
        Malformed: an element count that is not a whole number, a list
        counted by a float type or with a negative count, records that run
        out, do not parse, hold more than their properties or outnumber the
        header's counts (ASCII), a fraction in an integer property (ASCII),
        face indices outside the vertices or not whole numbers, faces of
        fewer than 3 corners, colours out of range.
    """
    try:
        return _read_ply(path)
    except (IndexError, KeyError, struct.error) as err:  # (malformed in a way not foreseen)
        raise ValueError(f"malformed PLY file: {err!r}") from None


def _read_ply(path: str) -> PolygonData:
    """read_ply's work."""
    with open(path, "rb") as fh:
        fmt, elements = _header(fh)
        body = fh.read()
    names = [e[0] for e in elements]
    if "vertex" not in names or "face" not in names:
        raise UnsupportedPly("no vertex or no face element")
    fast = _ascii_fast(body, elements) if fmt == "ascii" else None
    lines = iter(line for line in body.decode("ascii", "replace").splitlines() if line.strip()) \
        if fmt == "ascii" and fast is None else None
    order = "<" if fmt == "binary_little_endian" else ">"
    offset, found = 0, {}
    for e, (name, count, props) in enumerate(elements):
        if name in found:
            raise ValueError(f"two {name} elements")
        if fast is not None:
            scalars, lists = fast[e]
        elif lines is not None:
            scalars, lists = _records_ascii(lines, count, props)
        else:
            scalars, lists, offset = _records_binary(body, offset, order, count, props)
        if name in ("vertex", "face"):
            found[name] = (scalars, lists, props)
    if lines is not None:
        more = next(lines, None) is not None
    elif fast is not None:
        more = False  # (the compiled reader found nothing after the records)
    else:
        more = bool(body[offset:].strip(b" \t\r\n\0"))  # (white space after the data: fine)
    if more:
        raise ValueError("the file holds more records than its header declares")
    scalars, _, props = found["vertex"]
    scalar_names = [p[0] for p in props if p[2] is None]
    scalar_kinds = [p[1] for p in props if p[2] is None]
    if not all(c in scalar_names for c in "xyz"):
        raise UnsupportedPly("the vertex element has no x, y and z")
    vertices = scalars[:, [scalar_names.index(c) for c in "xyz"]]
    vertex_colours = _colours(scalars, scalar_names, scalar_kinds, "vertex")
    scalars, lists, props = found["face"]
    at = next((k for k, p in enumerate(props) if p[0] in _INDEX_NAMES and p[2] is not None), None)
    if at is None:
        raise UnsupportedPly("the face element has no vertex_indices list")
    faces = lists[at]
    if isinstance(faces, np.ndarray):  # (all faces the same size)
        sizes = np.full(len(faces), faces.shape[1] if faces.ndim == 2 else 0, dtype=np.int64)
        raw = faces.reshape(-1)
    else:
        sizes = np.array([len(f) for f in faces], dtype=np.int64)
        # (float64 holds any index a file can hold exactly enough to judge it:
        # ASCII integers past int64 would overflow an int64 array)
        try:
            raw = np.array([i for f in faces for i in f], dtype=np.float64)
        except OverflowError:  # (an integer beyond float64's range)
            raise ValueError(f"a face index lies outside [0, {len(vertices)})") from None
    if raw.dtype.kind == "f" and raw.size and not (np.isfinite(raw).all()
                                                   and (raw == np.round(raw)).all()):
        bad = raw[~(np.isfinite(raw) & (raw == np.round(raw)))][0]
        raise ValueError(f"a face index is not a whole number: {float(bad)!r}")
    if raw.size and (raw.min() < 0 or raw.max() >= len(vertices)):
        raise ValueError(f"a face index lies outside [0, {len(vertices)})")
    indices = raw.astype(np.int64)
    if sizes.size and sizes.min() < 3:
        raise ValueError("a face has fewer than 3 corners")
    scalar_names = [p[0] for p in props if p[2] is None]
    scalar_kinds = [p[1] for p in props if p[2] is None]
    return PolygonData(vertices, sizes, indices, vertex_colours,
                       _colours(scalars, scalar_names, scalar_kinds, "face"))
