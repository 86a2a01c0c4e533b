"""Procedural scenes: the built-in default scene and the test scenes.

Everything here is generated with numpy alone, deterministically (random
scenes take a seed), so tests and benchmarks run without any model files.
"""

from __future__ import annotations

from typing import List, Sequence, Tuple

import numpy as np

from .checks import as_finite, as_finite_reals, check_int
from .load import as_mesh
from .mesh import Mesh, one_rgb

__all__ = [
    "box", "uv_sphere", "torus", "grid", "combine", "default_scene", "default_camera",
    "overlapping_boxes", "interpenetrating_triangles", "coplanar_faces", "fan",
    "random_soup", "tessellated_square", "instance_grid",
]

Part = Tuple[np.ndarray, np.ndarray]

# The most triangles one call may make (about 1.6 GB of faces and vertices
# at its largest): a bound on what a typo in a count can ask for.
_MAX_TRIANGLES = 2**26


def _count(name: str, value, least: int) -> int:
    """A count: an integer of at least ``least`` (checks.check_int) that
    alone would not pass _MAX_TRIANGLES."""
    return check_int(name, value, least, _MAX_TRIANGLES)


def _counts(name: str, value, k: int, check) -> Tuple[int, ...]:
    """``value`` as ``k`` counts, each ``check(f"{name}[i]", count)``-ed."""
    try:
        given = tuple(value)
    except TypeError:
        raise TypeError(f"{name} must be {k} positive integers, got {value!r}") from None
    if len(given) != k:
        raise ValueError(f"{name} must be {k} positive integers, got {value!r}")
    return tuple(check(f"{name}[{i}]", c) for i, c in enumerate(given))


def _triangles(what: str, n: int) -> None:
    """ValueError if ``what`` would make more than _MAX_TRIANGLES triangles."""
    if n > _MAX_TRIANGLES:
        raise ValueError(f"{what} would make {n:,} triangles; at most {_MAX_TRIANGLES:,}")


def _numbers(name: str, value, size: int = 1, broadcast: bool = False):
    """``value`` as a finite float (``size`` 1) or ``size`` finite floats
    (``broadcast``: one number stands for all), checked as Camera's are
    (checks.as_finite, as_finite_reals)."""
    return as_finite(name, value) if size == 1 else as_finite_reals(name, value, size, broadcast)


def box(center=(0.0, 0.0, 0.0), size=(1.0, 1.0, 1.0)) -> Part:
    """An axis-aligned box, 12 triangles wound counter-clockwise seen from outside.

    Parameters
    ----------
    center : (3,) array_like of float, or float
        A single number stands for all three coordinates.
    size : (3,) array_like of float, or float
        Edge lengths along x, y and z (a single number: a cube).

    Returns
    -------
    vertices : (8, 3) float64
    faces : (12, 3) int

    Raises
    ------
    TypeError
        Values that are not real numbers.
    ValueError
        The wrong count of numbers, or a NaN or infinite one.
    """
    c, s = _numbers("center", center, 3, True), _numbers("size", size, 3, True) * 0.5
    corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float)
    faces = np.array([
        [0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6],  # -z, +z
        [0, 1, 5], [0, 5, 4], [2, 6, 7], [2, 7, 3],  # -y, +y
        [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5],  # -x, +x
    ])
    return c + corners * s, faces


def uv_sphere(center=(0.0, 0.0, 0.0), radius=1.0, n_lat=16, n_lon=32) -> Part:
    """A latitude-longitude sphere with poles on the y axis (n_lat >= 2
    bands of latitude, n_lon >= 3 of longitude).

    Parameters
    ----------
    center : (3,) array_like of float
    radius : float
    n_lat, n_lon : int

    Returns
    -------
    vertices : (2 + (n_lat - 1) n_lon, 3) float64
        The north pole (+y) first, the rings from north to south, the
        south pole last.
    faces : (2 (n_lat - 1) n_lon, 3) int

    Raises
    ------
    TypeError
        Counts that are not integers, or numbers that are not real numbers.
    ValueError
        Counts out of range (or making more than 2**26 triangles), the
        wrong count of numbers, or a NaN or infinite one.
    """
    n_lat, n_lon = _count("n_lat", n_lat, 2), _count("n_lon", n_lon, 3)
    _triangles(f"uv_sphere(n_lat={n_lat}, n_lon={n_lon})", 2 * (n_lat - 1) * n_lon)
    center, radius = _numbers("center", center, 3), _numbers("radius", radius)
    theta = np.linspace(0.0, np.pi, n_lat + 1)[1:-1]
    phi = np.linspace(0.0, 2.0 * np.pi, n_lon, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.cos(t), -np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    v = np.vstack([[0, 1, 0], ring, [0, -1, 0]]) * radius + center
    faces = []
    south = len(v) - 1
    for k in range(n_lon):
        k1 = (k + 1) % n_lon
        faces.append([0, 1 + k, 1 + k1])
        base = 1 + (n_lat - 2) * n_lon
        faces.append([south, base + k1, base + k])
    for r in range(n_lat - 2):
        for k in range(n_lon):
            k1 = (k + 1) % n_lon
            a, b = 1 + r * n_lon + k, 1 + r * n_lon + k1
            c, d = a + n_lon, b + n_lon
            faces += [[a, c, d], [a, d, b]]
    return v, np.array(faces)


def torus(center=(0.0, 0.0, 0.0), major=1.0, minor=0.3, n_major=32, n_minor=16) -> Part:
    """A torus around the y axis (n_major, n_minor >= 3 segments).

    Parameters
    ----------
    center : (3,) array_like of float
    major : float
        Radius of the tube's centre circle (in the xz plane).
    minor : float
        Radius of the tube.
    n_major, n_minor : int
        Segments around the centre circle and around the tube.

    Returns
    -------
    vertices : (n_major n_minor, 3) float64
    faces : (2 n_major n_minor, 3) int

    Raises
    ------
    TypeError
        Counts that are not integers, or numbers that are not real numbers.
    ValueError
        Counts out of range (or making more than 2**26 triangles), the
        wrong count of numbers, or a NaN or infinite one.
    """
    n_major, n_minor = _count("n_major", n_major, 3), _count("n_minor", n_minor, 3)
    _triangles(f"torus(n_major={n_major}, n_minor={n_minor})", 2 * n_major * n_minor)
    center = _numbers("center", center, 3)
    major, minor = _numbers("major", major), _numbers("minor", minor)
    u = np.linspace(0.0, 2.0 * np.pi, n_major, endpoint=False)
    w = np.linspace(0.0, 2.0 * np.pi, n_minor, endpoint=False)
    uu, ww = np.meshgrid(u, w, indexing="ij")
    r = major + minor * np.cos(ww)
    v = np.stack([r * np.cos(uu), minor * np.sin(ww), -r * np.sin(uu)], -1).reshape(-1, 3)
    faces = []
    for i in range(n_major):
        for j in range(n_minor):
            a = i * n_minor + j
            b = ((i + 1) % n_major) * n_minor + j
            c = ((i + 1) % n_major) * n_minor + (j + 1) % n_minor
            d = i * n_minor + (j + 1) % n_minor
            faces += [[a, b, c], [a, c, d]]
    return v + center, np.array(faces)


def grid(center=(0.0, 0.0, 0.0), size=(4.0, 4.0), n=(8, 8)) -> Part:
    """A flat rectangle in the xz plane (normal +y), n[0] x n[1] quads.

    Parameters
    ----------
    center : (3,) array_like of float
    size : (2,) array_like of float
        Extent along x and along z.
    n : (2,) sequence of int
        Quads along x and along z, each at least 1; two triangles each.

    Returns
    -------
    vertices : ((n[0] + 1) (n[1] + 1), 3) float64
    faces : (2 n[0] n[1], 3) int

    Raises
    ------
    TypeError
        Counts that are not integers, or numbers that are not real numbers.
    ValueError
        Counts out of range (or making more than 2**26 triangles), the
        wrong count of numbers, or a NaN or infinite one.
    """
    n = _counts("n", n, 2, lambda name, c: _count(name, c, 1))
    _triangles(f"grid(n={n})", 2 * n[0] * n[1])
    center, size = _numbers("center", center, 3), _numbers("size", size, 2)
    xs = np.linspace(-0.5, 0.5, n[0] + 1) * size[0]
    zs = np.linspace(-0.5, 0.5, n[1] + 1) * size[1]
    x, z = np.meshgrid(xs, zs, indexing="ij")
    v = np.stack([x, np.zeros_like(x), z], -1).reshape(-1, 3) + center
    faces = []
    m = n[1] + 1
    for i in range(n[0]):
        for j in range(n[1]):
            a, b, c, d = i * m + j, (i + 1) * m + j, (i + 1) * m + j + 1, i * m + j + 1
            faces += [[a, d, c], [a, c, b]]
    return v, np.array(faces)


def combine(parts: Sequence[Part], colors: Sequence[Sequence[float]] = (),
            name: str = "scene") -> Mesh:
    """One Mesh from several (vertices, faces) parts, optionally one colour each.

    Parameters
    ----------
    parts : sequence of ((N_i, 3) array_like of float, (M_i, 3) array_like of int)
        Each part's faces index its own vertices.
    colors : sequence of (3,) array_like of int (0-255) or float (0-1), optional
        One RGB colour per part, given to all its faces; empty or None: no colours.
    name : str

    Returns
    -------
    Mesh
        The parts' vertices and faces concatenated in order (faces
        renumbered), with face colours when ``colors`` is given.

    Raises
    ------
    ValueError, TypeError
        What :class:`~zbuffer.Mesh` refuses, in the whole or in a part (a
        part's faces must index its own vertices; the message names the
        part); colours out of range, or not one per part.
    """
    verts: List[np.ndarray] = []
    faces: List[np.ndarray] = []
    offset = 0
    for k, (v, f) in enumerate(parts):
        try:  # each part checked as a mesh of its own (indices into its own vertices)
            part = Mesh(v, f)
        except (ValueError, TypeError) as err:
            raise type(err)(f"parts[{k}]: {err}") from None
        verts.append(part.vertices)
        faces.append(part.faces.astype(np.int64) + offset)
        offset += len(part.vertices)
    face_colors = None
    if colors is not None and len(colors):
        if len(colors) != len(parts):
            raise ValueError(f"colors: one per part, got {len(colors)} for {len(parts)} parts")
        rgb = [one_rgb(c, f"colors[{k}]") for k, c in enumerate(colors)]
        face_colors = np.vstack([np.tile(c, (len(f), 1)) for c, f in zip(rgb, faces)])
    v = np.vstack(verts) if verts else np.zeros((0, 3))
    f = np.vstack(faces) if faces else np.zeros((0, 3), np.int64)
    return Mesh(v, f, face_colors=face_colors, name=name)


def default_scene() -> Mesh:
    """The scene ``zbuffer render`` draws without a file: a box pierced by a
    sphere, a torus sunk into the floor, and the floor (2,028 triangles, with
    occlusion and interpenetration). See :func:`default_camera`.

    Returns
    -------
    Mesh
        Named "default scene", with one face colour per part (floor, box,
        sphere, torus, in that order).
    """
    parts = [
        grid((0.0, -1.0, 0.0), (4.5, 3.5), (12, 12)),
        box((-0.8, -0.3, 0.0), (1.4, 1.4, 1.4)),
        uv_sphere((-0.2, 0.1, 0.4), 0.75, 16, 32),
        torus((1.4, -0.4, -0.3), 0.8, 0.25, 32, 12),
    ]
    colors = [(0.75, 0.75, 0.72), (0.85, 0.45, 0.25), (0.30, 0.55, 0.85), (0.45, 0.75, 0.35)]
    return combine(parts, colors, name="default scene")


def default_camera(aspect: float = 4.0 / 3.0, up=(0.0, 1.0, 0.0)):
    """A camera looking at :func:`default_scene` from the front, above and right
    (``up``: the world direction shown upwards), the scene filling 90% of
    the picture's width or height.

    Parameters
    ----------
    aspect : float
        Width / height of the picture it is meant for.
    up : (3,) array_like of float

    Returns
    -------
    Camera
        Perspective, 45 degrees; ``near`` and ``far`` unset (fitted when
        rendering).

    Raises
    ------
    ValueError
        ``aspect`` outside [1/32768, 32768] (what images can have).
    TypeError
        ``aspect`` not a number.
    """
    from .camera import Camera
    from .conventions import MAX_IMAGE_SIDE

    aspect = as_finite("aspect", aspect)
    if not 1.0 / MAX_IMAGE_SIDE <= aspect <= MAX_IMAGE_SIDE:  # (an image's width / height)
        raise ValueError(f"aspect must lie in [1/{MAX_IMAGE_SIDE}, {MAX_IMAGE_SIDE}], got {aspect!r}")
    mesh = default_scene()
    camera = Camera.fit(mesh, direction=(0.45, 0.55, 1.0), up=up, aspect=aspect)
    # Fitted to the bounding sphere, the scene (low and wide) would sit in
    # the lower part of the picture: aim at the middle of its projection and
    # come closer until its larger extent spans 90% of the picture, in a few
    # steps.
    points = np.c_[mesh.vertices, np.ones(len(mesh.vertices))]
    for _ in range(4):
        resolved = camera.resolve(mesh)
        clip = points @ (resolved.projection_matrix(aspect) @ resolved.view_matrix()).T
        ndc = clip[:, :2] / clip[:, 3:]
        centre = (ndc.min(axis=0) + ndc.max(axis=0)) / 2
        half = float(np.max((ndc.max(axis=0) - ndc.min(axis=0)) / 2))
        eye, target = np.array(camera.eye), np.array(camera.target)
        back = eye - target
        distance = float(np.linalg.norm(back))
        right = np.cross(np.asarray(camera.up), back)
        right /= np.linalg.norm(right)
        upward = np.cross(back, right) / distance  # (the picture's up, unit)
        tan = np.tan(np.radians(camera.fov_y) / 2)
        shift = distance * tan * (centre[0] * aspect * right + centre[1] * upward)
        target = target + shift
        eye = target + back * (half / 0.9)
        camera = Camera.look_at(tuple(eye), tuple(target), up=camera.up, fov_y=camera.fov_y)
    return camera


# Test Scenes

def overlapping_boxes(n: int = 6, seed: int = 0) -> Mesh:
    """n boxes of random size and position, overlapping each other.

    Parameters
    ----------
    n : int
        At least 1.
    seed : int
        For ``np.random.default_rng``.

    Returns
    -------
    Mesh
        12 n faces: box k's centre uniform in [-1, 1]^3, its edge lengths
        uniform in [0.3, 1.2], all from one generator.

    Raises
    ------
    TypeError
        ``n`` is not an integer.
    ValueError
        ``n`` below 1 or above 2**26 / 12.
    """
    n = _count("n", n, 1)
    _triangles(f"overlapping_boxes({n})", 12 * n)
    rng = np.random.default_rng(seed)
    parts = [box(rng.uniform(-1, 1, 3), rng.uniform(0.3, 1.2, 3)) for _ in range(n)]
    return combine(parts, name=f"overlapping_boxes({n}, seed={seed})")


def interpenetrating_triangles() -> Mesh:
    """Three large triangles that pierce each other pairwise (no depth order).

    Returns
    -------
    Mesh
        9 vertices (none shared), 3 faces.
    """
    v = np.array([
        [-1.0, -0.6, -0.5], [1.0, -0.6, 0.5], [0.0, 0.9, 0.0],
        [-1.0, -0.5, 0.5], [1.0, -0.5, -0.5], [0.2, 1.0, 0.3],
        [-0.8, 0.6, 0.0], [0.9, 0.5, 0.1], [0.0, -1.0, -0.2],
    ])
    return Mesh(v, np.arange(9).reshape(3, 3), name="interpenetrating_triangles")


def coplanar_faces() -> Mesh:
    """Overlapping triangles in one plane (exact depth ties everywhere they
    overlap; the smaller id must win), plus a fan sharing their vertices.

    Returns
    -------
    Mesh
        6 vertices in the plane z = 0, 6 faces.
    """
    v = np.array([
        [-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0],
        [0.0, -1.0, 0.0], [0.0, 1.0, 0.0],
    ])
    f = np.array([[0, 1, 2], [0, 2, 3], [4, 2, 5], [0, 1, 3], [4, 1, 2], [0, 4, 5]])
    return Mesh(v, f, name="coplanar_faces")


def fan(n: int = 24, tilt: float = 0.3) -> Mesh:
    """A triangle fan around a centre vertex: n thin triangles meeting at one
    point, every inner edge shared by two of them (n >= 3).

    Parameters
    ----------
    n : int
    tilt : float
        The rim, a unit circle around the z axis, rises and falls by
        ``tilt * cos(3 angle)`` in z.

    Returns
    -------
    Mesh
        The centre (the origin) and n rim vertices; n faces.

    Raises
    ------
    TypeError
        A count that is not an integer, or a number that is not a real one.
    ValueError
        ``n`` out of 3 .. 2**26, or a NaN or infinite ``tilt``.
    """
    n, tilt = _count("n", n, 3), _numbers("tilt", tilt)
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    rim = np.stack([np.cos(a), np.sin(a), tilt * np.cos(3 * a)], -1)
    v = np.vstack([[0.0, 0.0, 0.0], rim])
    f = np.array([[0, 1 + k, 1 + (k + 1) % n] for k in range(n)])
    return Mesh(v, f, name=f"fan({n})")


def random_soup(n: int = 200, seed: int = 0, scale: float = 0.5) -> Mesh:
    """n independent random triangles of any size and orientation.

    Each triangle's centre is uniform in [-1, 1]^3, and each of its corners
    is that centre plus normal random offsets of standard deviation
    ``scale`` in x, y and z (so corners may lie outside the cube).

    Parameters
    ----------
    n : int
        At least 1.
    seed : int
        For ``np.random.default_rng``.
    scale : float
        Standard deviation of the corners' offsets.

    Returns
    -------
    Mesh
        3 n vertices (none shared) and n faces.

    Raises
    ------
    TypeError
        A count that is not an integer, or a number that is not a real one.
    ValueError
        ``n`` out of 1 .. 2**26, a NaN or infinite ``scale``, or a
        negative one (numpy's).
    """
    n, scale = _count("n", n, 1), _numbers("scale", scale)
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-1, 1, (n, 1, 3))
    v = (centres + rng.normal(0, scale, (n, 3, 3))).reshape(-1, 3)
    return Mesh(v, np.arange(3 * n).reshape(n, 3), name=f"random_soup({n}, seed={seed})")


def tessellated_square(n: int = 8, jitter: float = 0.0, seed: int = 0) -> Mesh:
    """The square [-1, 1]^2 at z = 0 cut into 2 n^2 triangles (n >= 1); inner
    grid vertices may be jittered by up to ``jitter`` (0 <= jitter < 0.5) of
    a cell in x and y, so that no vertex reaches a neighbour's place. Under
    0.25 every triangle also keeps its orientation, so the square stays
    covered exactly once; from 0.25 a triangle may fold over (with a seed's
    bad luck).

    Parameters
    ----------
    n : int
    jitter : float
    seed : int
        For ``np.random.default_rng``.

    Returns
    -------
    Mesh
        (n + 1)^2 vertices, 2 n^2 faces.

    Raises
    ------
    TypeError
        A count that is not an integer, or a number that is not a real one.
    ValueError
        ``n`` below 1 (or 2 n^2 above 2**26), or ``jitter`` outside
        [0, 0.5).
    """
    n = _count("n", n, 1)
    _triangles(f"tessellated_square({n})", 2 * n * n)
    jitter = _numbers("jitter", jitter)
    if not 0.0 <= jitter < 0.5:
        raise ValueError(f"jitter must be in [0, 0.5), got {jitter!r}")
    rng = np.random.default_rng(seed)
    g = np.linspace(-1.0, 1.0, n + 1)
    x, y = np.meshgrid(g, g, indexing="ij")
    inner = np.zeros_like(x, bool)
    inner[1:-1, 1:-1] = True
    step = 2.0 / n
    x = x + np.where(inner, rng.uniform(-jitter, jitter, x.shape) * step, 0.0)
    y = y + np.where(inner, rng.uniform(-jitter, jitter, y.shape) * step, 0.0)
    v = np.stack([x, y, np.zeros_like(x)], -1).reshape(-1, 3)
    faces = []
    m = n + 1
    for i in range(n):
        for j in range(n):
            a, b, c, d = i * m + j, (i + 1) * m + j, (i + 1) * m + j + 1, i * m + j + 1
            faces += [[a, b, c], [a, c, d]] if (i + j) % 2 else [[a, b, d], [b, c, d]]
    return Mesh(v, np.array(faces), name=f"tessellated_square({n})")


def instance_grid(mesh, counts=(5, 5, 10), spacing: float = 1.1) -> Mesh:
    """Copies of a mesh on a regular grid: ``counts[0] x counts[1] x counts[2]``
    copies along x, y and z, ``spacing`` times the mesh's extent along each
    axis apart (1.0: bounding boxes touching), centred on the z axis, the
    first layer in front (largest z) and the others behind it. The occlusion benchmark of the hierarchical algorithms (a
    camera on +z looking down the long axis sees the front layer and little
    else). Faces are numbered copy by copy.

    Parameters
    ----------
    mesh : Mesh or anything :func:`zbuffer.render` accepts
    counts : (3,) sequence of int
        Copies along x, y and z, each at least 1.
    spacing : float
        Distance between neighbouring copies' centres, in units of the
        mesh's extent along that axis (an axis where it is flat counts
        as 1).

    Returns
    -------
    Mesh
        Without the mesh's colours.

    Raises
    ------
    ValueError
        A mesh without vertices, counts below 1, or more than 2**31 - 1
        faces or vertices in all.
    TypeError
        Counts that are not integers, a ``spacing`` that is not a number,
        or a ``mesh`` :func:`~zbuffer.as_mesh` does not take.
    """
    mesh = as_mesh(mesh)
    counts = _counts("counts", counts, 3, lambda name, c: check_int(name, c, 1))
    spacing = _numbers("spacing", spacing)
    if len(mesh.vertices) == 0:
        raise ValueError("instance_grid needs a mesh with vertices (its extent spaces the copies)")
    n_copies = counts[0] * counts[1] * counts[2]
    if n_copies * len(mesh.faces) > 2**31 - 1 or n_copies * len(mesh.vertices) > 2**31 - 1:
        raise ValueError(f"{n_copies} copies of {len(mesh.faces)} faces exceed 2**31 - 1")
    v = mesh.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    extent = hi - lo
    step = spacing * np.where(extent > 0, extent, 1.0)
    centre = (lo + hi) / 2
    ix, iy, iz = np.meshgrid(*(np.arange(c) for c in counts), indexing="ij")
    offsets = np.stack([(ix - (counts[0] - 1) / 2) * step[0],
                        (iy - (counts[1] - 1) / 2) * step[1], -iz * step[2]], -1).reshape(-1, 3)
    offsets -= centre
    verts = (v[None, :, :] + offsets[:, None, :]).reshape(-1, 3)
    faces = (mesh.faces[None, :, :].astype(np.int64)
             + (np.arange(n_copies) * len(v))[:, None, None]).reshape(-1, 3)
    return Mesh(verts, faces.astype(np.int32), name=f"{counts[0]}x{counts[1]}x{counts[2]} grid")

