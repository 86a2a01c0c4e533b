"""Meshes: what zbuffer renders, and how other mesh types become one."""

from __future__ import annotations

from functools import cached_property
from typing import NamedTuple, Optional, Tuple

import numpy as np

from .checks import as_number, integer_dtype, number_dtype

__all__ = ["Mesh", "Visit", "unit_rgb", "one_rgb"]

_INT32_MAX = np.iinfo(np.int32).max


def _array(value, name: str) -> np.ndarray:
    """np.asarray, with a message naming the argument for ragged lists."""
    try:
        return np.asarray(value)
    except ValueError as err:
        raise ValueError(f"{name} must be a rectangular array: {err}") from None


def _readonly(a: np.ndarray) -> np.ndarray:
    view = a.view()
    view.flags.writeable = False
    return view


def unit_rgb(c: np.ndarray, what: str) -> np.ndarray:
    """float32 RGB in [0, 1] from colours along the last axis of ``c`` (RGB
    or RGBA): integers 0-255 or floats 0-1 (alpha dropped, but checked like
    the rest). For the mesh's colours and the render's ``color`` and
    ``background``.

    Parameters
    ----------
    c : (..., 3|4) ndarray of int (0-255) or float (0-1)
    what : str
        What ``c`` is, for the error messages.

    Returns
    -------
    (..., 3) float32
        A view of ``c`` where it already is float32.

    Raises
    ------
    ValueError
        Values out of range, NaN or infinite.
    TypeError
        Any other dtype (bools among them).
    """
    def values() -> str:
        if c.size <= 4:
            return f"{c.tolist()!r}"
        if not np.isfinite(c).all():
            return "a NaN or infinite value"
        return f"values from {c.min().item()!r} to {c.max().item()!r}"

    if integer_dtype(c.dtype):
        if c.size and (c.min() < 0 or c.max() > 255):
            raise ValueError(f"integer {what} must lie in 0-255, got {values()}")
        return c[..., :3].astype(np.float32) / np.float32(255.0)
    if c.dtype.kind != "f":
        raise TypeError(f"{what} must be integers (0-255) or floats (0-1), got dtype {c.dtype}")
    if c.size and (not np.all(np.isfinite(c)) or c.min() < 0.0 or c.max() > 1.0):
        raise ValueError(f"float {what} must lie in [0, 1], got {values()}")
    return np.asarray(c[..., :3], dtype=np.float32)  # (float32 RGB kept as given, no copy)


def one_rgb(value, what: str) -> np.ndarray:
    """One colour, as :func:`unit_rgb` takes it: 3 integers (0-255) or 3
    floats (0-1), ValueError naming ``what`` for another shape. Returns a
    (3,) float32 array."""
    c = np.asarray(value)
    if c.shape != (3,):
        raise ValueError(f"{what} must be 3 numbers (RGB), got {value!r}")
    return unit_rgb(c, what)


def _as_colors(colors, n: int, what: str) -> Optional[np.ndarray]:
    """(n, 3) float32 RGB in [0, 1] from uint8 or float RGB/RGBA, or None."""
    if colors is None:
        return None
    c = np.asarray(colors)
    if c.ndim != 2 or c.shape[0] != n or c.shape[1] not in (3, 4):
        raise ValueError(f"{what} must have shape ({n}, 3) or ({n}, 4), got {c.shape}")
    return np.ascontiguousarray(unit_rgb(c, what))


class Visit(NamedTuple):
    """A mesh as the compiled algorithms visit it: ``vertices`` and the
    ``faces`` that index them.

    Unprepared, these are the mesh's own arrays. Prepared (:meth:`Mesh.prepare`),
    ``faces`` are the mesh's triangles reordered -- face k is the mesh's face
    ``ids[k]`` -- and ``vertices`` the mesh's vertices renumbered in the order
    those faces first use them (so that neighbouring faces read neighbouring
    vertices): ``vertices[faces[k]]`` equals ``mesh.vertices[mesh.faces[ids[k]]]``,
    but ``faces`` do not index ``mesh.vertices``. With cells,
    ``faces[cell_start[k]:cell_start[k + 1]]`` share a cell of a coarse grid
    centred at ``cell_centre[k]``, which the image-space algorithms visit
    nearest first.
    """

    vertices: np.ndarray
    faces: np.ndarray
    ids: Optional[np.ndarray] = None
    cell_start: Optional[np.ndarray] = None
    cell_centre: Optional[np.ndarray] = None
    vertex_order: Optional[np.ndarray] = None  # vertex k is the mesh's vertex_order[k]

    def render(self, mvp, width: int, height: int, algo: str, cull_backfaces: bool,
               **options):
        """``_core.render`` of this visit: its own vertices with the faces that
        index them, their ids and cells. The one place that passes a visit to
        the core, so that faces are never paired with another mesh's vertices.
        Arrays that are not read-only are passed as copies (the core reads
        them without the GIL).

        Parameters
        ----------
        mvp : (4, 4) float64
        width, height : int
        algo : str
            A name from :func:`zbuffer.algorithms`.
        cull_backfaces : bool
        **options
            The other keywords of ``_core.render``: ``polygon_offsets`` and
            ``polygon_indices``, ``record_culls``, ``out_depth``, ``out_ids``.

        Returns
        -------
        tuple
            ``(depth, triangle_id, stats)``: (H, W) float32, (H, W) int32
            (the mesh's face numbers: ``ids[k]`` for face k when ``ids`` is
            set) and a dict; with ``record_culls``, a fourth item: a list of
            (h, w) int64 arrays, one per pyramid level.

        Raises
        ------
        ValueError, TypeError
            What the core's checks of the arrays and arguments refuse.
        """
        from . import _core

        # The core checks the arrays, then reads them without the GIL: an
        # array another thread could still write is passed as a copy (a
        # Mesh's own arrays are read-only, and passed as they are).
        return _core.render(_settled(self.vertices), _settled(self.faces), mvp, width, height,
                            algo, bool(cull_backfaces), face_ids=_settled(self.ids),
                            cell_start=_settled(self.cell_start),
                            cell_centre=_settled(self.cell_centre), **options)


def _settled(a):
    """``a`` if it is None or a read-only array, else a copy of it."""
    if a is None or (isinstance(a, np.ndarray) and not a.flags.writeable):
        return a
    return np.array(a, copy=True)


class Mesh:
    """A triangle mesh, checked once and ready to render.

    Parameters
    ----------
    vertices : (N, 3) array_like of float
        Positions in world space. Every coordinate must be finite.
    faces : (M, 3) array_like of int
        Vertex indices of each triangle, each in ``[0, N)``.
    vertex_colors, face_colors : (N, 3|4) or (M, 3|4) array_like, optional
        RGB(A) as integers 0-255 or floats 0-1; alpha is ignored. At most one.
    name : str, optional
    face_polygon : (M,) array_like of int, optional
        For meshes triangulated from polygons: the polygon (in file order)
        each triangle came from (numbers >= 0; with ``polygons``, exactly
        theirs).
    polygons : ((P,) array_like of int, (K,) array_like of int), optional
        The polygon faces as written, as (sizes, concatenated vertex
        indices); ``faces`` must then be their triangulation in polygon order,
        ``size - 2`` triangles each (as :func:`zbuffer.polygons.triangulate_polygons`
        makes it). Algorithms that draw polygons natively (``"scanline"``)
        draw these; the others draw ``faces``.

    Attributes
    ----------
    vertices : (N, 3) float64, read-only
    faces : (M, 3) int32, read-only
    vertex_colors : (N, 3) float32 or None
    face_colors : (M, 3) float32 or None
    face_polygon : (M,) int64 or None
    polygon_sizes : (P,) int64 or None
    polygon_indices : (K,) int32 or None
    polygon_offsets : (P + 1,) int64 or None
        Where each polygon's indices start (and the last one ends).

    Raises
    ------
    TypeError
        Non-numeric arrays, or faces that are not integers.
    ValueError
        Wrong shapes, a NaN or infinite coordinate, or a face index outside
        ``[0, N)`` (the message names the first offending vertex or face).

    Notes
    -----
    Vertices are not copied when they already are C-contiguous float64 (nor
    colours given as C-contiguous (N, 3) float32); modifying them afterwards
    invalidates the cached bounding sphere, normals, visiting order and the
    shading pass's renumbered copies, and any :class:`~zbuffer.Scene` built
    from the mesh (its trees hold copies: it
    would draw the old mesh with some algorithms and the new with others),
    so build a new Mesh instead. Faces are always copied.
    """

    def __init__(self, vertices, faces, vertex_colors=None, face_colors=None,
                 name: Optional[str] = None, face_polygon=None, polygons=None):
        v = _array(vertices, "vertices")
        f = _array(faces, "faces")
        if not number_dtype(v.dtype):
            raise TypeError(f"vertices must be numbers, got dtype {v.dtype}")
        if v.size == 0 and v.ndim < 2:
            v = v.reshape(0, 3)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"vertices must have shape (N, 3), got {v.shape}")
        if f.size == 0:  # no faces: of any number type (np.zeros((0, 3)) is float)
            f = f.reshape(0, 3) if f.ndim < 2 else f
            if number_dtype(f.dtype):
                f = f.astype(np.int32)
        if not integer_dtype(f.dtype):
            raise TypeError(f"faces must be integer vertex indices, got dtype {f.dtype}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(
                f"faces must have shape (M, 3) (triangles), got {f.shape}"
            )
        v = np.ascontiguousarray(v, dtype=np.float64)
        n = v.shape[0]
        if n > _INT32_MAX or f.shape[0] > _INT32_MAX:
            raise ValueError("meshes are limited to 2**31 - 1 vertices and faces")

        # Value checks, with the same messages as the compiled core's.
        finite = np.isfinite(v).all(axis=1)
        if not finite.all():
            raise ValueError(f"vertex {int(np.argmin(finite))} has a NaN or infinite coordinate")
        if f.size:
            flat = f.reshape(-1)
            bad = (flat < 0) | (flat >= n)
            if bad.any():
                k = int(np.argmax(bad))
                raise ValueError(
                    f"face {k // 3} has vertex index {int(flat[k])}, outside [0, {n})"
                )
        # Faces are always copied: the compiled core reads them without the
        # GIL after checking them once, so nobody else may hold a writable
        # reference to them. (Vertices need no such care: any value is safe.)
        f = np.array(f, dtype=np.int32, order="C", copy=True)

        if vertex_colors is not None and face_colors is not None:
            raise ValueError("give vertex_colors or face_colors, not both")
        self._vertices = _readonly(v)
        self._faces = _readonly(f)
        self._vertex_colors = self._face_colors = None
        self.vertex_colors = vertex_colors
        self.face_colors = face_colors
        self.name = name
        self.face_polygon = None
        if face_polygon is not None:
            fp = _array(face_polygon, "face_polygon")
            if fp.size and not integer_dtype(fp.dtype):
                raise TypeError(f"face_polygon must be integers, got dtype {fp.dtype}")
            if fp.size and fp.dtype.kind == "u" and fp.max() > np.iinfo(np.int64).max:
                raise ValueError(f"face_polygon must be polygon numbers, got {int(fp.max())}")
            fp = fp.astype(np.int64)
            if fp.shape != (f.shape[0],):
                raise ValueError(f"face_polygon must have shape ({f.shape[0]},), got {fp.shape}")
            if fp.size and fp.min() < 0:
                raise ValueError(f"face_polygon must be polygon numbers >= 0, got {int(fp.min())}")
            self.face_polygon = _readonly(fp)
        self.polygon_sizes = self.polygon_indices = self.polygon_offsets = None
        if polygons is not None:
            self._set_polygons(polygons, n, f.shape[0])
            if self.face_polygon is not None and not np.array_equal(
                    self.face_polygon, np.repeat(np.arange(len(self.polygon_sizes)),
                                                 self.polygon_sizes - 2)):
                raise ValueError("face_polygon must give each triangle its polygon as polygons "
                                 "has them (size - 2 triangles each, in polygon order)")
        self._renders = 0
        self._visit = None  # Visit: faces in a cache-friendly order, their ids, cells

    def _set_polygons(self, polygons, n_vertices: int, n_faces: int) -> None:
        # (The core checks the offsets and indices it is given the same way:
        # src/bind_render.cpp, polygon_view.)
        try:
            sizes, indices = polygons
        except (TypeError, ValueError):
            raise TypeError("polygons must be a (sizes, indices) pair of arrays") from None
        sizes = np.asarray(sizes)
        indices = np.asarray(indices)
        for a, what in ((sizes, "polygon sizes"), (indices, "polygon indices")):
            if a.ndim != 1:
                raise ValueError(f"{what} must be one-dimensional, got shape {a.shape}")
            if a.size and not integer_dtype(a.dtype):
                raise TypeError(f"{what} must be integers, got dtype {a.dtype}")
        sizes = sizes.astype(np.int64)
        if sizes.size and sizes.min() < 3:
            raise ValueError(f"polygon {int(np.argmax(sizes < 3))} has fewer than 3 corners")
        if sizes.size and sizes.max() > len(indices):  # (and the sums below cannot wrap)
            k = int(np.argmax(sizes > len(indices)))
            raise ValueError(f"polygon {k} has {int(sizes[k])} corners, more than the "
                             f"{len(indices)} polygon indices")
        if int(sizes.sum()) != len(indices):
            raise ValueError(f"polygon sizes add up to {int(sizes.sum())}, "
                             f"but there are {len(indices)} polygon indices")
        if int((sizes - 2).sum()) != n_faces:
            raise ValueError(f"the polygons have {int((sizes - 2).sum())} triangles (size - 2 "
                             f"each), but faces has {n_faces} rows")
        if indices.size and (indices.min() < 0 or indices.max() >= n_vertices):
            k = int(np.argmax((indices < 0) | (indices >= n_vertices)))
            raise ValueError(f"polygon index {int(indices[k])} is outside [0, {n_vertices})")
        offsets = np.zeros(len(sizes) + 1, np.int64)
        np.cumsum(sizes, out=offsets[1:])
        self.polygon_sizes = _readonly(sizes)
        self.polygon_indices = _readonly(np.array(indices, dtype=np.int32, order="C", copy=True))
        self.polygon_offsets = _readonly(offsets)

    # The positions and faces are fixed for a Mesh's life (caches, prepared
    # orders and Scenes' trees are made from them): read-only arrays, and
    # attributes that cannot be set anew (a Scene's tree over other faces
    # than the ones shaded would read out of bounds).
    @property
    def vertices(self) -> np.ndarray:
        """(N, 3) float64 positions, read-only."""
        return self._vertices

    @property
    def faces(self) -> np.ndarray:
        """(M, 3) int32 vertex indices, read-only."""
        return self._faces

    # The colours may be set anew (the prepared copies follow), checked as
    # the constructor checks them: the core reads float32 RGB of the right
    # length, and face colours would hide vertex colours set beside them.
    @property
    def vertex_colors(self) -> Optional[np.ndarray]:
        """(N, 3) float32 RGB in [0, 1], or None. Settable: RGB(A) as
        integers 0-255 or floats 0-1 (as the constructor takes them), or None."""
        return self._vertex_colors

    @vertex_colors.setter
    def vertex_colors(self, colors) -> None:
        self._set_colors("vertex_colors", colors, len(self._vertices), "face_colors")

    @property
    def face_colors(self) -> Optional[np.ndarray]:
        """(M, 3) float32 RGB in [0, 1], or None. Settable as
        :attr:`vertex_colors` is."""
        return self._face_colors

    @face_colors.setter
    def face_colors(self, colors) -> None:
        self._set_colors("face_colors", colors, len(self._faces), "vertex_colors")

    def _set_colors(self, which: str, colors, n: int, other: str) -> None:
        c = _as_colors(colors, n, which)
        if c is not None and getattr(self, "_" + other, None) is not None:
            raise ValueError(f"give vertex_colors or face_colors, not both (set {other} "
                             f"to None first)")
        setattr(self, "_" + which, c)

    def __repr__(self) -> str:
        name = f" {self.name!r}" if self.name else ""
        return f"<zbuffer.Mesh{name}: {len(self.vertices)} vertices, {len(self.faces)} faces>"

    def __len__(self) -> int:
        return len(self.faces)

    @cached_property
    def bounding_sphere(self) -> Tuple[np.ndarray, float]:
        """Centre of the bounding box and radius of the sphere around it
        holding every vertex that a face uses: ((3,) float64, float)."""
        from .camera import bounding_sphere

        used = np.zeros(len(self.vertices), bool)
        used[self.faces.reshape(-1)] = True
        return bounding_sphere(self.vertices if used.all() else self.vertices[used])

    @cached_property
    def vertex_normals(self) -> np.ndarray:
        """(N, 3) float64 unit normals: the area-weighted sum of the normals
        of the faces around each vertex (zero for unused vertices); computed
        by the compiled core, the same bits as
        :func:`zbuffer.reference.vertex_normals`."""
        from . import _core

        return _readonly(_core.vertex_normals(self.vertices, self.faces))

    def for_shading(self, normals: bool, vertex_colors: bool) -> tuple:
        """The arrays the shading pass reads: the mesh's own arrays, or, once
        it is prepared, its prepared vertices (and their normals and colours,
        in the same numbering) with the faces in the mesh's own order
        renumbered to them.
        Triangle ids index both the same way and the images are the same
        bits; the pass reads the corners of neighbouring pixels' faces from
        neighbouring memory (bunny_69k and armadillo_86k at 1024x1024:
        5-13% faster, flat and smooth). Cached per mesh, each array with the
        one it was made from (vertex colours set anew are seen; edited in
        place they are not, see the class notes).

        Parameters
        ----------
        normals : bool
            Include the vertex normals (smooth shading).
        vertex_colors : bool
            Include the vertex colours (for a mesh that has them).

        Returns
        -------
        tuple
            ``(vertices, faces, normals, colors)``: (N, 3) float64,
            (M, 3) int32 (row f is the mesh's face f, in the returned
            vertices' numbering), (N, 3) float64 or None, (N, 3) float32 or
            None.
        """
        visit = self._visit
        if visit is None or visit.vertex_order is None:
            return (self.vertices, self.faces, self.vertex_normals if normals else None,
                    self.vertex_colors if vertex_colors else None)
        cache = self.__dict__.setdefault("_shading", {})

        def cached(name, source, make):
            entry = cache.get(name)
            if entry is None or entry[0] is not source:
                entry = cache[name] = (source, _readonly(make()))
            return entry[1]

        def renumbered_faces():  # row f: the prepared face whose id is f
            row_of_id = np.empty_like(visit.ids)
            row_of_id[visit.ids] = np.arange(len(visit.ids), dtype=visit.ids.dtype)
            return np.take(visit.faces, row_of_id, axis=0)

        # (np.take: about 3x faster than indexing rows with an array)
        order = visit.vertex_order
        return (visit.vertices, cached("faces", visit.faces, renumbered_faces),
                cached("vertex_normals", self.vertex_normals,
                       lambda: np.take(self.vertex_normals, order, axis=0)) if normals else None,
                cached("vertex_colors", self.vertex_colors,
                       lambda: np.take(self.vertex_colors, order, axis=0))
                if vertex_colors else None)

    def resolved_camera(self, camera):
        """``camera.resolve(self)``, remembered per camera (cameras are
        immutable), so that rendering one mesh from one camera again does
        not fit the clip planes and build the matrices again.

        Parameters
        ----------
        camera : Camera

        Returns
        -------
        Camera
            The resolved camera (the cache holds up to 64 cameras, and is
            emptied when full).

        Raises
        ------
        ValueError, TypeError
            As :meth:`Camera.resolve`.
        """
        cache = self.__dict__.setdefault("_resolved_cameras", {})
        resolved = cache.get(camera)
        if resolved is None:
            resolved = camera.resolve(self)
            if len(cache) >= 64:
                cache.clear()
            cache[camera] = resolved
        return resolved

    def auto_camera(self, aspect: float):
        """The camera ``render(camera=None)`` uses: :meth:`Camera.fit` from
        +z, resolved (cached per aspect ratio).

        Parameters
        ----------
        aspect : float
            Image width / height.

        Returns
        -------
        Camera
            Perspective, 45 degrees, looking down -z at the mesh's bounding
            sphere, ``near`` and ``far`` fitted (the cache holds up to 64
            aspect ratios, and is emptied when full).

        Raises
        ------
        TypeError
            ``aspect`` is not a number.
        ValueError
            As :meth:`Camera.fit` and :meth:`Camera.resolve`.
        """
        aspect = as_number("aspect", aspect)  # (a key for the cache; Camera.fit checks the value)
        cache = self.__dict__.setdefault("_auto_cameras", {})
        camera = cache.get(aspect)
        if camera is None:
            from .camera import Camera

            camera = Camera.fit(self, aspect=aspect).resolve(self)
            if len(cache) >= 64:
                cache.clear()
            cache[aspect] = camera
        return camera

    # Meshes at least this large get a cache-friendly visiting order.
    _ORDER_MIN_FACES = 2048

    def arrays(self):
        """Every numpy array this Mesh holds -- its own, its colours, its
        polygons, cached normals, its prepared visit's copies and the
        shading pass's (:meth:`for_shading`) --, for checks that an array
        the caller writes into is none of them.

        Yields
        ------
        (str, ndarray)
            A name (the attribute's, without a leading underscore, or
            ``"prepared ..."``, ``"shading ..."``) and the array.
        """
        # (Snapshots: a render in another thread may be filling the caches.)
        for name, value in list(vars(self).items()):
            if isinstance(value, np.ndarray):
                yield name.lstrip("_"), value
            elif isinstance(value, Visit):
                for field, array in value._asdict().items():
                    if isinstance(array, np.ndarray):
                        yield f"prepared {field}", array
            elif name == "_shading":
                for field, (_, array) in list(value.items()):
                    yield f"shading {field}", array

    def prepare(self) -> "Mesh":
        """Compute the cache-friendly order the compiled algorithms visit the
        faces in (a Z-order curve through their centroids, in cells of a
        coarse grid that the image-space algorithms visit nearest first, and
        the vertices renumbered in the order those faces first use them: a
        second copy of the positions; 4-7 ms per 100k faces on the benchmark
        machine of benchmarks/results) now rather than at the second render.
        Results never depend on it: only speed (and the counters that depend
        on order: pixels written, triangles culled) does. Meshes of fewer
        than 2048 faces get no order (they are visited as they are), and a
        mesh prepared once is not prepared again.

        Returns
        -------
        Mesh
            The mesh itself.
        """
        if self._visit is None and len(self.faces) >= self._ORDER_MIN_FACES:
            from . import _core

            order, cell_start, cell_centre = _core.spatial_order(self.vertices, self.faces)
            # (np.take: about 3x faster than indexing rows with an array)
            faces, vertex_order = _core.first_use_order(np.take(self.faces, order, axis=0),
                                                        len(self.vertices))
            self._visit = Visit(_readonly(np.take(self.vertices, vertex_order, axis=0)),
                                _readonly(faces),
                                _readonly(order), _readonly(cell_start), _readonly(cell_centre),
                                _readonly(vertex_order))
        return self

    def faces_for_render(self) -> "Visit":
        """The vertices and faces as the compiled algorithms visit them.

        Called once per render by :func:`zbuffer.render` (any algorithm)
        and by :meth:`Scene.render` with an algorithm other than
        ``hiz_octree`` and ``hiz_bvh`` (whose prebuilt trees hold their own
        copies of the mesh) -- except ``scanline`` on a mesh with polygon
        faces, which draws the polygons as written, from the mesh's own
        arrays. :func:`zbuffer.reference.render` never calls it. The order is
        computed (:meth:`prepare`) on the second call for the same Mesh, or
        by an earlier :meth:`prepare`, so that one-off renders of temporary
        meshes do not pay for it.

        Returns
        -------
        Visit
            The mesh's own vertices and faces while it is not prepared (and
            always below 2048 faces); once prepared, the prepared visit,
            whose faces index its own renumbered vertices, not
            ``self.vertices``.
        """
        self._renders += 1
        if self._visit is None and self._renders >= 2:
            self.prepare()
        if self._visit is None:
            return Visit(self.vertices, self.faces)
        return self._visit

    @classmethod
    def from_trimesh(cls, tm, name: Optional[str] = None) -> "Mesh":
        """A Mesh from a ``trimesh.Trimesh``, keeping its vertex or face colours.

        Parameters
        ----------
        tm : trimesh.Trimesh
        name : str, optional

        Returns
        -------
        Mesh
            ``tm``'s vertices and faces (in its order: triangle ids are its
            face numbers), with its vertex colours where its visual kind is
            ``"vertex"``, its face colours where it is ``"face"``, and no
            colours otherwise (textures among them). Not prepared.

        Raises
        ------
        ValueError, TypeError
            As :class:`Mesh` (a NaN vertex, say).
        """
        vertex_colors = face_colors = None
        kind = getattr(tm.visual, "kind", None)
        if kind == "vertex":
            vertex_colors = tm.visual.vertex_colors
        elif kind == "face":
            face_colors = tm.visual.face_colors
        return cls(tm.vertices, tm.faces, vertex_colors=vertex_colors,
                   face_colors=face_colors, name=name)

    def merged(self) -> "Mesh":
        """The same mesh with vertices of identical position (and colour)
        shared. Faces keep their order, so triangle ids are unchanged, and
        polygon faces (``polygon_sizes``, ``polygon_indices``,
        ``face_polygon``) are kept, renumbered.

        Returns
        -------
        Mesh
            ``self`` when it has no vertices or no two alike; otherwise a
            new, unprepared Mesh whose vertices are the distinct ones in
            ``np.unique``'s order (sorted), with the same name and face
            colours. Unused vertices are kept.
        """
        if len(self.vertices) == 0:
            return self
        key = self.vertices
        if self.vertex_colors is not None:
            key = np.hstack([key, self.vertex_colors.astype(np.float64)])
        unique, first, inverse = _unique_rows(key)
        if len(unique) == len(key):
            return self
        polygons = None
        if self.polygon_sizes is not None:
            polygons = (self.polygon_sizes, inverse[self.polygon_indices].astype(np.int32))
        return Mesh(
            self.vertices[first], inverse[self.faces].astype(np.int32),
            vertex_colors=None if self.vertex_colors is None else self.vertex_colors[first],
            face_colors=self.face_colors, name=self.name, face_polygon=self.face_polygon,
            polygons=polygons,
        )


def _unique_rows(key: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``np.unique(key, axis=0, return_index=True, return_inverse=True)``
    for a 2D float array, the same three arrays, about 3x faster.

    np.unique sorts the rows as records, comparing them field by field in a
    generic loop; this sorts them with ``np.lexsort`` on the columns (first
    column first), also stable and with the same comparisons (-0.0 equals
    0.0), so the order, the first index of each distinct row and the
    inverse are the same (tests hold the two to that).

    Parameters
    ----------
    key : (n, k) float64, n >= 1

    Returns
    -------
    unique : (m, k) float64
        The distinct rows, sorted.
    first : (m,) intp
        The index in ``key`` of each one's first occurrence.
    inverse : (n,) intp
        Each row's index in ``unique``.
    """
    order = np.lexsort(key.T[::-1])
    rows = key[order]
    starts = np.empty(len(key), dtype=bool)
    starts[0] = True
    np.any(rows[1:] != rows[:-1], axis=1, out=starts[1:])
    inverse = np.empty(len(key), dtype=np.intp)
    inverse[order] = np.cumsum(starts) - 1
    return rows[starts], order[starts], inverse
