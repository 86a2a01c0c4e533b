"""Meshes from files and from other libraries' objects: :func:`load` (OBJ,
OFF and PLY read by zbuffer's own readers, other formats through trimesh)
and :func:`as_mesh` (anything :func:`zbuffer.render` accepts)."""

from __future__ import annotations

import os

import numpy as np

from .checks import check_flag
from .mesh import Mesh

__all__ = ["load", "as_mesh"]


def load(path, merge_vertices: bool = True) -> Mesh:
    """Read a mesh file: OBJ, ASCII OFF and PLY with zbuffer's own readers
    (PLY files it does not know: through trimesh), any other format trimesh
    reads (STL, glTF, ...) through trimesh. Binary OFF is refused
    (ValueError): neither reads it.

    Parameters
    ----------
    path : str or os.PathLike
    merge_vertices : bool
        For non-OBJ files: share vertices that have identical positions
        (formats with per-corner attributes repeat positions, which costs
        render time). OBJ files keep their ``v`` records as vertices. Face
        order, and therefore triangle ids, is kept either way.

    Returns
    -------
    Mesh
        OBJ, OFF and PLY polygons are kept as written (``polygon_sizes``,
        ``polygon_indices``: the scanline algorithm draws them natively) and
        triangulated exactly for the other algorithms (fans for convex
        polygons, ear clipping for concave ones); ``face_polygon`` maps
        triangles to them (None when every face is a triangle); trimesh
        fan-triangulates other formats' polygons; scenes are concatenated.
        The mesh is :meth:`~Mesh.prepare`-d for fast repeated rendering.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file cannot be parsed as a mesh.
    TypeError
        ``path`` not a str or path-like, or ``merge_vertices`` not a bool.
    """
    check_flag("merge_vertices", merge_vertices)
    path = os.fsdecode(os.fspath(path))
    if not os.path.exists(path):
        raise FileNotFoundError(f"no such mesh file: {path!r}")
    if not os.path.isfile(path):
        raise ValueError(f"{path!r} is not a mesh file (a directory or device)")
    if path.lower().endswith(".obj"):  # (its v records stay the vertices: not merged)
        from .obj import read_obj

        return _polygon_mesh(path, _parse(path, read_obj)).prepare()
    if path.lower().endswith(".off"):
        from .off import is_binary_off, read_off

        if is_binary_off(path):
            raise ValueError(f"{path!r} is a binary OFF file, which zbuffer cannot read (nor can "
                             "trimesh): convert it to ASCII OFF, PLY or OBJ")
        return _merged(_polygon_mesh(path, _parse(path, read_off)), merge_vertices).prepare()
    unsupported = None  # (why zbuffer's PLY reader left a .ply file to trimesh)
    if path.lower().endswith(".ply"):
        from .ply import UnsupportedPly, read_ply

        try:
            data = _parse(path, read_ply)
        except UnsupportedPly as err:
            unsupported = err
        else:
            return _merged(_polygon_mesh(path, data), merge_vertices).prepare()
    import trimesh  # (only here: importing it takes about 0.3 s)

    formats = trimesh.available_formats()
    if not any(path.lower().endswith("." + f) for f in formats):
        # (trimesh's own message shows the path lower-cased)
        suffix = os.path.splitext(path)[1]
        raise ValueError(f"could not read a mesh from {path!r}: "
                         + (f"unknown file suffix {suffix!r}" if suffix else "no file suffix")
                         + " (zbuffer reads .obj, .off and .ply files, and through trimesh "
                         + ", ".join("." + f for f in sorted(formats)
                                     if f not in ("obj", "off", "ply", "stl_ascii"))
                         + ")")
    try:
        tm = trimesh.load(path, force="mesh", process=False)
    except Exception as err:  # trimesh raises many types for bad files
        # (zbuffer's PLY reader says it more plainly; trimesh's own errors are
        # named with their type: some say nothing, an AssertionError, or
        # mislead, a FileNotFoundError naming a buffer a broken glTF lacks)
        reason = unsupported or (f"trimesh's reader failed ({type(err).__name__}"
                                 + (f": {err})" if str(err) else ")"))
        raise ValueError(f"could not read a mesh from {path!r}: {reason}") from err
    _check_ascii_ply_records(path)
    if not isinstance(tm, trimesh.Trimesh):
        raise ValueError(f"{path!r} holds no triangle mesh (got {type(tm).__name__})")
    if len(tm.vertices) == 0 and _has_content(path) and not _declares_no_faces(path):
        # trimesh reads some malformed files (a garbage binary STL, say) as
        # empty; an empty mesh is only believable from an empty file, or one
        # whose own header or records say it has no faces.
        raise ValueError(f"could not read a mesh from {path!r}: no vertices found in a "
                         "non-empty file (malformed or unsupported content)")
    return _merged(Mesh.from_trimesh(tm, name=os.path.basename(path)), merge_vertices).prepare()


def _merged(mesh: Mesh, merge: bool) -> Mesh:
    return mesh.merged() if merge else mesh


def _parse(path: str, read):
    """``read(path)`` (obj.read_obj, off.read_off, ply.read_ply), its
    ValueError naming the file -- but a PLY file the reader does not know
    (ply.UnsupportedPly) as it is, for trimesh to try."""
    from .ply import UnsupportedPly

    try:
        return read(path)
    except UnsupportedPly:
        raise
    except ValueError as err:
        raise ValueError(f"could not read a mesh from {path!r}: {err}") from err


def _polygon_mesh(path: str, data) -> Mesh:
    """The mesh of the polygon faces a reader found in ``path`` (polygons.PolygonData):
    the polygons triangulated exactly, and kept as written when any has more
    than 3 corners; colours per polygon become colours per triangle."""
    from .polygons import triangulate_polygons

    if (len(data.vertices) == 0 and path.lower().endswith(".obj")
            and not _is_obj_without_geometry(path)):
        raise ValueError(f"could not read a mesh from {path!r}: no vertices found in a "
                         "non-empty file")
    faces, owner = triangulate_polygons(data.vertices, data.polygon_sizes, data.polygon_indices)
    polygons = bool(len(data.polygon_sizes)) and bool((data.polygon_sizes > 3).any())
    # (A mesh has vertex or face colours: given both, the vertices' are kept.)
    face_colors = None if data.face_colors is None or data.vertex_colors is not None \
        else data.face_colors[owner]
    try:
        return Mesh(data.vertices, faces, vertex_colors=data.vertex_colors,
                    face_colors=face_colors, name=os.path.basename(path),
                    face_polygon=owner if polygons else None,
                    polygons=(data.polygon_sizes, data.polygon_indices) if polygons else None)
    except ValueError as err:
        raise ValueError(f"could not read a mesh from {path!r}: {err}") from err


def _declares_no_faces(path: str) -> bool:
    """True if the file says, in its format's own terms and nothing else,
    that it holds no faces: a PLY header whose only elements are its
    vertices and, if any, ``face 0``; an ASCII STL that is only ``solid
    ...`` and ``endsolid ...``; a binary STL of exactly 84 bytes that counts
    0 triangles. (For the files trimesh reads: OFF files never get here.)"""
    suffix = os.path.splitext(path)[1].lower()
    if suffix == ".ply":
        with open(path, "rb") as fh:
            header = _ply_header(fh)
        return header is not None and all(
            e[:1] == [b"vertex"] or e == [b"face", b"0"] for e in header[1])
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    if suffix == ".stl":
        if len(head) == 84:
            return head[80:84] == b"\0\0\0\0"
        lines = head.split()
        return (len(head) < (1 << 16) and lines[:1] == [b"solid"]
                and b"endsolid" in lines and all(not w.startswith(b"facet") for w in lines))
    return False


def _is_obj_without_geometry(path: str) -> bool:
    """True if every record of the file is one an OBJ file may hold (blank
    lines and comments aside): then an OBJ without vertices is an empty
    mesh (what an exporter writes for an empty scene), not another kind of
    file."""
    keywords = {b"v", b"vt", b"vn", b"vp", b"f", b"l", b"p", b"o", b"g", b"s", b"mg",
                b"mtllib", b"usemtl", b"cstype", b"deg", b"curv", b"curv2", b"surf", b"parm",
                b"trim", b"hole", b"end", b"bevel", b"c_interp", b"d_interp", b"lod",
                b"shadow_obj", b"trace_obj", b"ctech", b"stech", b"call", b"csh"}
    with open(path, "rb") as fh:
        text = fh.read().removeprefix(b"\xef\xbb\xbf")
    for line in text.splitlines():
        words = line.split(b"#", 1)[0].split()
        if words and words[0] not in keywords:
            return False
    return True


def _ply_header(fh):
    """(format, elements) of the PLY header at the start of the binary file
    ``fh`` -- the words after ``format`` and after each ``element`` (name,
    count) -- leaving ``fh`` just past ``end_header``; None if the file does
    not start with a PLY header (a BOM before ``ply`` allowed) or it does
    not end."""
    if fh.readline().strip().removeprefix(b"\xef\xbb\xbf") != b"ply":
        return None
    fmt, elements = None, []  # (None: no format line)
    for line in fh:
        words = line.split()
        if words[:1] == [b"format"]:
            fmt = words[1:]
        elif words[:1] == [b"element"]:
            elements.append(words[1:])
        elif words[:1] == [b"end_header"]:
            return fmt, elements
    return None


def _check_ascii_ply_records(path: str) -> None:
    """ValueError if an ASCII PLY file holds fewer records than its header
    declares (trimesh reads a truncated one as a smaller mesh; it refuses
    truncated binary ones itself). Each element instance is one line."""
    if os.path.splitext(path)[1].lower() != ".ply":
        return
    with open(path, "rb") as fh:
        header = _ply_header(fh)
        if header is None or (header[0] is not None and header[0][:1] != [b"ascii"]):
            return  # (no header end: trimesh has judged it already)
        declared = sum(int(e[1]) for e in header[1] if len(e) == 2 and e[1].isdigit())
        found = sum(1 for line in fh if line.strip())
    if found < declared:
        raise ValueError(f"could not read a mesh from {path!r}: its header declares "
                         f"{declared} element records, the file holds {found} (truncated?)")


def _has_content(path: str) -> bool:
    """True if the file holds anything but blank lines and # comments."""
    with open(path, "rb") as fh:
        for line in fh:
            line = line.strip()
            if line and not line.startswith(b"#"):
                return True
    return False


def _pyvista_mesh(poly) -> Mesh:
    """A Mesh of a pyvista.PolyData's polygons and strips, triangulated (in
    VTK's order: the polygons' triangles, then the strips'), with its
    colours: its active scalars when they are uint8 with 3 or 4 components
    (RGB or RGBA, as pyvista reads them from PLY files and plots them), per
    point or per cell; other scalars are data, not colours, and are not
    kept. Point and line cells draw nothing."""
    import pyvista

    # Polygons and strips are triangulated apart, each triangle tagged with
    # its cell: VTK's triangle filter can misplace cell data (colours) when
    # it gets them together, or beside point and line cells.
    n_verts_lines = poly.n_verts + poly.n_lines  # (cells are numbered these first)
    n_polys = poly.n_cells - n_verts_lines - poly.n_strips
    points = np.asarray(poly.points, dtype=np.float64)
    faces, cells = [np.zeros((0, 3), np.int64)], [np.zeros(0, np.int64)]
    strips_first = n_verts_lines + n_polys
    for first, part in ((n_verts_lines, dict(faces=poly.faces) if n_polys else None),
                        (strips_first, dict(strips=poly.strips) if poly.n_strips else None)):
        if part is None:
            continue
        piece = pyvista.PolyData(points, **part)
        piece.cell_data["cell"] = first + np.arange(piece.n_cells)
        triangles = piece.triangulate()
        if triangles.n_cells:
            faces.append(np.asarray(triangles.regular_faces, dtype=np.int64))
            cells.append(np.asarray(triangles.cell_data["cell"], dtype=np.int64))
    faces, cells = np.concatenate(faces), np.concatenate(cells)
    colors = {}
    values = None if poly.active_scalars_name is None else np.asarray(poly.active_scalars)
    if (values is not None and values.dtype == np.uint8 and values.ndim == 2
            and values.shape[1] in (3, 4)):
        association = poly.active_scalars_info.association.name
        if association == "POINT" and len(values) == poly.n_points:
            colors = {"vertex_colors": values}
        elif association == "CELL" and len(values) == poly.n_cells:
            colors = {"face_colors": values[cells]}
    return Mesh(points, faces, **colors)


def as_mesh(obj) -> Mesh:
    """Turn anything :func:`zbuffer.render` accepts into a :class:`Mesh`.

    Accepted: a :class:`Mesh`; a ``trimesh.Trimesh``; a ``trimesh.Scene``
    (concatenated); a ``pyvista.PolyData`` (triangulated), or any other
    pyvista dataset (its outer surface, triangulated); a
    ``(vertices, faces)`` pair of arrays; a file path. The colours of
    trimesh meshes are kept, and those of pyvista datasets whose active
    scalars are uint8 RGB or RGBA (per point or per cell).

    Parameters
    ----------
    obj : Mesh, trimesh.Trimesh, trimesh.Scene, pyvista dataset, (vertices, faces) or path
        A pair is a tuple or list of two: ``(N, 3)`` vertices and ``(M, 3)``
        faces, as :class:`Mesh` takes them. A path is a ``str`` or
        ``os.PathLike``.

    Returns
    -------
    Mesh
        ``obj`` itself if it is a Mesh; for a path, :func:`load`'s mesh
        (its default ``merge_vertices=True``, prepared); otherwise a new,
        unprepared Mesh.

    Raises
    ------
    TypeError
        Anything else (a ``trimesh.PointCloud``, say), or arrays
        :class:`Mesh` refuses.
    ValueError
        Data :class:`Mesh` refuses, or a file :func:`load` cannot read.
    FileNotFoundError
        A path to no file.
    """
    if isinstance(obj, Mesh):
        return obj
    if isinstance(obj, (str, os.PathLike)):
        return load(obj)
    module = type(obj).__module__ or ""
    if module.startswith("trimesh"):
        import trimesh

        if isinstance(obj, trimesh.Scene):
            obj = obj.to_mesh()
        if isinstance(obj, trimesh.Trimesh):
            return Mesh.from_trimesh(obj)
    if module.startswith("pyvista") and hasattr(obj, "extract_surface"):
        import pyvista

        # (Not hasattr(obj, "regular_faces"): that property raises for a
        # PolyData of mixed polygon sizes.)
        if not isinstance(obj, pyvista.PolyData):  # a volume or grid: its outer surface
            try:  # (newer pyvista warns unless the algorithm is named)
                obj = obj.extract_surface(algorithm="dataset_surface")
            except TypeError:
                obj = obj.extract_surface()
        return _pyvista_mesh(obj)
    if isinstance(obj, (tuple, list)) and len(obj) == 2:
        return Mesh(obj[0], obj[1])
    raise TypeError(
        "cannot render a "
        f"{type(obj).__name__}: pass a zbuffer.Mesh, trimesh.Trimesh, trimesh.Scene, "
        "pyvista.PolyData, a (vertices, faces) pair or a file path"
    )
