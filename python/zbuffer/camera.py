"""Cameras and their matrices (OpenGL conventions).

Eye space is right-handed with the camera looking down -z and y up; the
projection maps the view volume to clip space with z in [-w, w]. The
model-view-projection matrix is built here, in float64, and handed to the C++
core and to the numpy reference alike, so both start from the same bits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Optional, Sequence, Tuple

import numpy as np

from .checks import as_finite_reals, as_number, check_choice, check_index

__all__ = ["Camera"]

Vec3 = Tuple[float, float, float]

PROJECTIONS = ("perspective", "orthographic")
# The smallest perspective near plane: the core treats clip-space w below
# MIN_CLIP_W (1e-300) as at the eye, and w = near on the near plane.
MIN_NEAR = 1e-290


def _unit(v: np.ndarray) -> Tuple[np.ndarray, float]:
    """``v`` scaled to length 1, and its length (0 for the zero vector):
    computed on ``v / max|v|`` so that neither overflows nor underflows
    (np.linalg.norm of (1e200, 0, 0) is inf, of (1e-200, 0, 0) zero)."""
    m = float(np.max(np.abs(v)))
    if m == 0.0:
        return np.zeros(3), 0.0
    w = v / m
    n = float(np.sqrt(w @ w))
    return w / n, m * n


def _fov(value) -> float:
    """A vertical field of view in degrees, in (0, 180): TypeError for a
    non-number, ValueError out of range."""
    fov = as_number("fov_y", value)
    # (Positive but so small that its half in radians is 0: a projection
    # dividing by its tangent would divide by zero.)
    if not 0.0 < fov < 180.0 or math.radians(fov) / 2.0 == 0.0:
        raise ValueError(f"fov_y must be in (0, 180) degrees, got {value!r}")
    return fov


def _tuple3(value, name: str) -> tuple:
    """``tuple(value)``, or TypeError naming ``name`` where it is not a sequence."""
    try:
        return tuple(value)
    except TypeError:
        raise TypeError(f"{name} must be 3 numbers, got {value!r}") from None


def _positive(value, name: str, allow_none: bool = False) -> Optional[float]:
    if value is None and allow_none:
        return None
    x = as_number(name, value)
    if not math.isfinite(x) or x <= 0.0:
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return x


def _clip_planes(projection: str, near, far) -> Tuple[Optional[float], Optional[float]]:
    """``near`` and ``far`` (either may be None: fitted later) as floats,
    checked: finite, ``near < far``, and for a perspective camera both in
    front of the eye (``near`` at least MIN_NEAR)."""
    planes = []
    for name, value in (("near", near), ("far", far)):
        if value is not None and not math.isfinite(as_number(name, value)):
            raise ValueError(f"{name} must be a finite number, got {value!r}")
        planes.append(None if value is None else float(value))
    near, far = planes
    if projection == "perspective":
        if near is not None and near <= 0.0:
            raise ValueError(f"near must be > 0 for a perspective camera, got {near!r}")
        if near is not None and near < MIN_NEAR:
            raise ValueError(f"near must be at least {MIN_NEAR:g} for a perspective camera "
                             f"(clip-space w below that counts as behind the eye), got {near!r}")
        if far is not None and far <= 0.0:
            raise ValueError(f"far must be > 0 for a perspective camera, got {far!r}")
    if near is not None and far is not None and not near < far:
        raise ValueError(f"near must be smaller than far, got near={near!r}, far={far!r}")
    return near, far


@dataclass(frozen=True)
class Camera:
    """A pinhole (perspective) or orthographic camera.

    Build one with :meth:`Camera.look_at` (explicit pose) or
    :meth:`Camera.fit` (frame a mesh). ``near``, ``far`` and, for orthographic
    cameras, ``ortho_height`` may be left ``None``: :meth:`resolve` then fits
    them to the bounding sphere of the mesh being rendered.

    Attributes
    ----------
    eye, target, up : (3,) tuple of float
        Camera position, the point it looks at, and the approximate up vector.
    projection : {"perspective", "orthographic"}
    fov_y : float
        Vertical field of view in degrees (perspective only: an orthographic
        camera keeps it unused, so that ``dataclasses.replace(cam,
        projection=...)`` switches between the two).
    ortho_height : float or None
        Height of the view volume in world units (orthographic only; kept
        unused by a perspective camera, likewise).
    near, far : float or None
        Distances of the clip planes along the viewing direction. For a
        perspective camera ``0 < near < far``; for an orthographic one only
        ``near < far`` is required (planes may lie behind the eye).
    """

    eye: Vec3
    target: Vec3
    up: Vec3 = (0.0, 1.0, 0.0)
    projection: str = "perspective"
    fov_y: float = 45.0
    ortho_height: Optional[float] = None
    near: Optional[float] = None
    far: Optional[float] = None

    def __post_init__(self):
        eye = as_finite_reals("eye", self.eye, 3)
        target = as_finite_reals("target", self.target, 3)
        up = as_finite_reals("up", self.up, 3)
        object.__setattr__(self, "eye", tuple(float(x) for x in eye))
        object.__setattr__(self, "target", tuple(float(x) for x in target))
        object.__setattr__(self, "up", tuple(float(x) for x in up))
        check_choice("projection", self.projection, PROJECTIONS)
        forward, dist = _unit(target - eye)
        if dist == 0.0:
            raise ValueError("degenerate camera: eye and target are the same point")
        if not math.isfinite(dist):
            raise ValueError("degenerate camera: eye and target are too far apart "
                             "(their distance overflows)")
        up_unit, up_length = _unit(up)
        if up_length == 0.0:
            raise ValueError("degenerate camera: up is the zero vector")
        side = _cross(forward, up_unit)
        if np.linalg.norm(side) < 1e-9:
            raise ValueError("degenerate camera: up is parallel to the viewing direction")
        object.__setattr__(self, "fov_y", _fov(self.fov_y))
        object.__setattr__(
            self, "ortho_height", _positive(self.ortho_height, "ortho_height", allow_none=True)
        )
        near, far = _clip_planes(self.projection, self.near, self.far)
        object.__setattr__(self, "near", near)
        object.__setattr__(self, "far", far)
        object.__setattr__(self, "_mvp_cache", {})  # (width, height) -> matrix

    # Construction

    @classmethod
    def look_at(
        cls,
        eye: Sequence[float],
        target: Sequence[float] = (0.0, 0.0, 0.0),
        up: Sequence[float] = (0.0, 1.0, 0.0),
        fov_y: float = 45.0,
        near: Optional[float] = None,
        far: Optional[float] = None,
        projection: str = "perspective",
        ortho_height: Optional[float] = None,
    ) -> "Camera":
        """A camera at ``eye`` looking at ``target``.

        Parameters
        ----------
        eye, target : (3,) array_like of float
        up : (3,) array_like of float
            Any vector not parallel to ``target - eye``.
        fov_y : float
            Vertical field of view in degrees (perspective; an orthographic
            camera keeps it unused).
        near, far : float, optional
            Clip plane distances; fitted to the rendered mesh when omitted.
        projection : {"perspective", "orthographic"}
        ortho_height : float, optional
            View volume height for orthographic cameras; fitted when omitted
            (a perspective camera keeps it unused).

        Returns
        -------
        Camera

        Raises
        ------
        ValueError
            For a degenerate pose (eye == target, up parallel to the view),
            ``near <= 0`` with perspective, ``near >= far``, or a bad ``fov_y``.
        TypeError
            Arguments of the wrong type: not numbers, or a ``projection``
            that is not a string.
        """
        return cls(
            eye=_tuple3(eye, "eye"), target=_tuple3(target, "target"), up=_tuple3(up, "up"),
            projection=projection, fov_y=fov_y, ortho_height=ortho_height, near=near, far=far,
        )

    @classmethod
    def fit(
        cls,
        vertices,
        direction: Sequence[float] = (0.0, 0.0, 1.0),
        up: Sequence[float] = (0.0, 1.0, 0.0),
        fov_y: float = 45.0,
        projection: str = "perspective",
        aspect: float = 1.0,
        margin: float = 1.1,
    ) -> "Camera":
        """A camera that frames a set of points, seen from ``direction``.

        Parameters
        ----------
        vertices : (N, 3) array_like of float, or Mesh
            Points to frame (their whole bounding sphere stays in view).
        direction : (3,) array_like of float
            Direction from the points' centre towards the camera.
        up : (3,) array_like of float
        fov_y : float
            Vertical field of view in degrees (perspective; an orthographic
            camera keeps it unused).
        projection : {"perspective", "orthographic"}
        aspect : float
            Image width / height; the narrower side decides the distance.
        margin : float
            Extra room around the bounding sphere (1.0 = touching).

        Returns
        -------
        Camera
            Looking at the sphere's centre. ``near`` and ``far`` are left
            None (fitted when rendering, :meth:`resolve`); an orthographic
            camera gets the ``ortho_height`` that frames the sphere and
            stands at twice its (margined) radius.

        Raises
        ------
        ValueError
            A zero ``direction``, ``aspect`` or ``margin`` not positive and
            finite, ``fov_y`` outside (0, 180), vertices that are not (N, 3)
            or not finite, or too large to frame, or a degenerate pose
            (``up`` parallel to ``direction``).
        TypeError
            Non-numeric arguments.
        """
        center, radius = bounding_sphere(vertices)
        d, norm = _unit(as_finite_reals("direction", direction, 3))
        if norm == 0.0:
            raise ValueError("direction must not be the zero vector")
        aspect = _positive(aspect, "aspect")
        margin = _positive(margin, "margin")
        fov_y = _fov(fov_y)
        r = radius * margin
        if projection == "orthographic":
            height = 2.0 * r / min(1.0, aspect)
            eye = center + d * (2.0 * r)
            return cls(eye=tuple(eye), target=tuple(center), up=tuple(up),
                       projection=projection, fov_y=fov_y, ortho_height=height)
        half = math.radians(float(fov_y)) / 2.0
        half_narrow = math.atan(math.tan(half) * min(1.0, aspect))
        if half_narrow == 0.0:  # (aspect or fov_y so small that the angle underflows)
            raise ValueError(f"the narrower field of view is 0: fov_y={fov_y!r}, aspect={aspect!r}")
        dist = r / math.sin(half_narrow)
        eye = center + d * dist
        return cls(eye=tuple(eye), target=tuple(center), up=tuple(up),
                   projection=projection, fov_y=fov_y)

    # Matrices

    def resolve(self, vertices=None) -> "Camera":
        """This camera with ``near``, ``far`` and ``ortho_height`` filled in.

        Unset values are fitted to the bounding sphere of ``vertices`` (an
        (N, 3) array or a :class:`zbuffer.Mesh`; a unit sphere at the origin
        when there are none): the clip planes enclose the
        sphere, and a perspective camera inside it gets ``near = far / 1000``.

        Parameters
        ----------
        vertices : (N, 3) array_like of float, Mesh or None

        Returns
        -------
        Camera
            ``self`` when nothing is unset (``near``, ``far`` and, for an
            orthographic camera, ``ortho_height``); otherwise a new Camera.

        Raises
        ------
        ValueError
            Only when something is fitted: vertices of the wrong shape, not
            finite or too large to frame, or fitted clip planes that are not
            valid (out of double precision's reach; the message says what to
            change).
        TypeError
            Only when something is fitted: vertices that are not numbers.
        """
        if self.near is not None and self.far is not None and (
            self.projection == "perspective" or self.ortho_height is not None
        ):
            return self
        unset = [name for name in ("near", "far") if getattr(self, name) is None]
        if self.projection == "orthographic" and self.ortho_height is None:
            unset.append("ortho_height")
        names = " and ".join([", ".join(unset[:-1]), unset[-1]] if len(unset) > 1 else unset)
        center, radius = bounding_sphere(
            vertices, f"give the camera {names} instead of leaving "
                      f"{'them' if len(unset) > 1 else 'it'} to be fitted")
        eye = np.asarray(self.eye)
        forward, _ = _unit(np.asarray(self.target) - eye)
        dist = float(np.dot(center - eye, forward))  # along the view axis
        changes = {}
        far = self.far
        if far is None:
            far = max(dist + radius, 0.0) * 1.01
            if self.projection == "perspective" and far <= 0.0:
                far = radius  # everything is behind the camera: any valid range
            if self.near is not None and far <= self.near:
                far = self.near * 2.0 if self.near > 0 else self.near + 2.0 * radius
            changes["far"] = far
        if self.near is None:
            if self.projection == "perspective":
                near = max((dist - radius) * 0.99, far * 1e-3)
                near = min(near, far * 0.5)
            else:
                near = min(dist - radius * 1.01, far - radius * 1e-3)
            changes["near"] = near
        if self.projection == "orthographic" and self.ortho_height is None:
            changes["ortho_height"] = 2.0 * radius * 1.05
        try:
            return replace(self, **changes)
        except ValueError as err:
            if "near" not in changes or "far" not in changes:
                raise  # a plane the caller gave: the message names it
            # Both planes fitted here: say what is wrong with the scene.
            raise ValueError(f"the mesh (radius {radius:g}, {dist:g} from the eye along the "
                             f"view) cannot be framed automatically by a {self.projection} "
                             f"camera: "
                             f"the clip planes it needs are out of double precision's reach "
                             f"({err}); scale the scene, use an orthographic camera, or "
                             f"pass near and far") from None

    def view_matrix(self) -> np.ndarray:
        """The world-to-eye matrix, as gluLookAt builds it.

        Returns
        -------
        (4, 4) float64
            Rows 0-2 of the rotation: the side, up and backward (-forward)
            unit vectors; the last column moves ``eye`` to the origin.
        """
        eye = np.asarray(self.eye)
        f, _ = _unit(np.asarray(self.target) - eye)
        s, _ = _unit(_cross(f, _unit(np.asarray(self.up))[0]))
        u = _cross(s, f)
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = s, u, -f
        m[:3, 3] = -m[:3, :3] @ eye
        return m

    def projection_matrix(self, aspect: float) -> np.ndarray:
        """The eye-to-clip matrix (the form of OpenGL's gluPerspective or glOrtho).

        Parameters
        ----------
        aspect : float
            Image width / height.

        Returns
        -------
        (4, 4) float64

        Raises
        ------
        ValueError
            ``aspect`` not positive and finite; ``near`` or ``far`` unset,
            or ``ortho_height`` unset for an orthographic camera (see
            :meth:`resolve`); a perspective ``near`` and ``far`` so small
            that the matrix's ``2 far near / (far - near)`` underflows to 0;
            any entry beyond float range (near and far, or
            ``ortho_height``, named).
        TypeError
            ``aspect`` not a number.
        """
        aspect = _positive(aspect, "aspect")
        if self.near is None or self.far is None:
            raise ValueError("near/far are not set: call camera.resolve(vertices) first")
        n, f = self.near, self.far
        m = np.zeros((4, 4))
        if self.projection == "perspective":
            t = 1.0 / math.tan(math.radians(self.fov_y) / 2.0)
            m[0, 0] = t / aspect
            m[1, 1] = t
            m[2, 2] = -(f + n) / (f - n)
            m[2, 3] = -2.0 * f * n / (f - n)
            if not math.isfinite(m[2, 3]):  # (2 far overflowed: the same value, in another order)
                m[2, 3] = -2.0 * n * (f / (f - n))
            m[3, 2] = -1.0
            if m[2, 3] == 0.0:
                raise ValueError(f"near={n!r} and far={f!r} are too small for double precision "
                                 "(2 near far / (far - near) underflows to 0): scale the scene up")
        else:
            if self.ortho_height is None:
                raise ValueError("ortho_height is not set: call camera.resolve(vertices) first")
            h = self.ortho_height
            m[0, 0] = 2.0 / (h * aspect)
            m[1, 1] = 2.0 / h
            m[2, 2] = -2.0 / (f - n)
            m[2, 3] = -(f + n) / (f - n)
            m[3, 3] = 1.0
        if not np.isfinite(m).all():
            shape = (f"fov_y={self.fov_y!r}" if self.projection == "perspective"
                     else f"ortho_height={self.ortho_height!r}")
            raise ValueError(f"this camera's projection matrix has an entry beyond float range "
                             f"(near={n!r}, far={f!r}, {shape}, aspect {aspect!r}): bring them, "
                             "and the scene, into a smaller range")
        return m

    def mvp(self, width: int, height: int) -> np.ndarray:
        """The model-view-projection matrix, ``projection_matrix(width / height)
        @ view_matrix()``, computed once per image size (cameras are
        immutable).

        Parameters
        ----------
        width, height : int
            Image size in pixels.

        Returns
        -------
        (4, 4) float64
            C-contiguous and read-only (the cached array itself). Entries
            may be non-finite for absurd cameras; :func:`zbuffer.render`
            refuses such a matrix.

        Raises
        ------
        TypeError
            ``width`` or ``height`` not an integer (bools included).
        ValueError
            ``width`` or ``height`` not positive, a ratio beyond float
            range, or what :meth:`projection_matrix` raises.
        """
        # Whole numbers only (numpy's too; not bools): the matrix and its cache key agree.
        key = (check_index("width", width), check_index("height", height))
        if key[0] <= 0 or key[1] <= 0:
            raise ValueError(f"width and height must be positive, got {key[0]}x{key[1]}")
        m = self._mvp_cache.get(key)
        if m is None:
            try:
                aspect = key[0] / key[1]
            except OverflowError:  # Python ints whose ratio is beyond float range
                raise ValueError(f"width / height is too large: {key[0]}x{key[1]}") from None
            with np.errstate(all="ignore"):  # absurd parameters: caught as non-finite
                m = np.ascontiguousarray(self.projection_matrix(aspect) @ self.view_matrix())
            m.flags.writeable = False
            if len(self._mvp_cache) > 64:
                self._mvp_cache.clear()
            self._mvp_cache[key] = m
        return m

    def viewer(self) -> np.ndarray:
        """The viewer in homogeneous coordinates, for shading.

        Returns
        -------
        (4,) float64
            ``(eye, 1)`` for a perspective camera; ``(d, 0)`` for an
            orthographic one, ``d`` the unit direction from ``target``
            towards ``eye``.
        """
        if self.projection == "perspective":
            return np.array([*self.eye, 1.0])
        back, _ = _unit(np.asarray(self.eye) - np.asarray(self.target))
        return np.array([*back, 0.0])

    def forward(self) -> np.ndarray:
        """The viewing direction.

        Returns
        -------
        (3,) float64
            Unit vector from ``eye`` towards ``target``.
        """
        return _unit(np.asarray(self.target) - np.asarray(self.eye))[0]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The cross product of two 3-vectors (np.cross costs ~15 us a call,
    a third of a small render's Python time)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


class _TooLargeToFrame(ValueError):
    """Vertex coordinates so large that a camera framing them would
    overflow; the message ends with what the caller can do instead."""

    def __init__(self, advice: str):
        super().__init__("vertex coordinates are too large to frame automatically "
                         f"(the camera's matrices would overflow); {advice}")


def bounding_sphere(vertices, advice: str = "pass a camera") -> Tuple[np.ndarray, float]:
    """Centre of the bounding box and the radius of the sphere around it that
    holds every point; a unit sphere at the origin for no points.

    ``vertices`` may be an (N, 3) array or anything with a ``bounding_sphere``
    attribute (a :class:`zbuffer.Mesh` caches its own). ``advice`` ends the
    message for coordinates too large to frame: what the caller can do
    instead."""
    if hasattr(type(vertices), "bounding_sphere"):  # (not hasattr(vertices): that computes it)
        try:
            return vertices.bounding_sphere
        except _TooLargeToFrame:
            raise _TooLargeToFrame(advice) from None
    if vertices is None:
        return np.zeros(3), 1.0
    try:
        v = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError("vertices must be an (N, 3) array of numbers or a Mesh") from None
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices must have shape (N, 3), got {v.shape}")
    if len(v) == 0:
        return np.zeros(3), 1.0
    if not np.isfinite(v).all():
        k = int(np.argmin(np.isfinite(v).all(axis=1)))
        raise ValueError(f"vertex {k} has a NaN or infinite coordinate: {v[k].tolist()}")
    # Column by column: numpy reduces a strided column ~10x faster than an
    # (N, 3) array along either axis (same values: min and max are exact,
    # and the squares are summed x + y + z, as sum(axis=1) adds them).
    columns = [v[:, a] for a in range(3)]
    lo = np.array([c.min() for c in columns])
    hi = np.array([c.max() for c in columns])
    with np.errstate(over="ignore", invalid="ignore"):
        center = lo * 0.5 + hi * 0.5
        # Scaled by the largest offset, so that tiny meshes do not underflow
        # to a radius of 0 (nor huge ones overflow before the check below).
        offsets = [columns[a] - center[a] for a in range(3)]
        scale = max(float(np.abs(o).max()) for o in offsets)
        if scale > 0.0:
            q = [o / scale for o in offsets]
            radius = scale * float(np.sqrt((q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).max()))
        else:
            radius = 0.0
    # (Beyond ~1e150 the camera's matrices, products of such lengths, overflow.)
    if not (math.isfinite(radius) and radius < 1e150) or not np.all(np.abs(center) < 1e150):
        raise _TooLargeToFrame(advice)
    if radius == 0.0:
        radius = max(1e-6, float(np.abs(center).max()) * 1e-6)
    return center, radius
