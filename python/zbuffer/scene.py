""":class:`Scene`: a mesh with the object-space trees of the hierarchical
algorithms, built once and rendered from any number of cameras."""

from __future__ import annotations

import threading
import time
from typing import Dict, Optional

import numpy as np

from . import _core
from .api import check_algorithm, claimed, finish, output_arrays, render_visibility
from .camera import Camera
from .checks import check_choice, check_flag, check_int
from .load import as_mesh
from .mesh import _INT32_MAX, Mesh
from .options import DEFAULT_SIZE, prepare
from .result import RenderResult
from .shading import DEFAULT_AMBIENT, DEFAULT_BACKGROUND, DEFAULT_DIFFUSE

__all__ = ["Scene", "TREE_ALGORITHMS", "NODE_FATES", "OCTREE_RULES"]

# The algorithms that render an object-space tree, and the tree each builds.
TREE_ALGORITHMS = {"hiz_octree": "octree", "hiz_bvh": "bvh"}

# Names of the values of ``Scene.nodes(...)["fate"]``.
NODE_FATES = ("not reached", "outside", "hidden", "visited", "drawn")

OCTREE_RULES = ("loose", "smallest", "greene")


class Scene:
    """A mesh prepared for many frames.

    The octree of ``hiz_octree`` and the BVH of ``hiz_bvh`` are built on
    first use (or by :meth:`build`) and reused by every later
    :meth:`render`, whatever the camera and image size. The other algorithms
    need nothing built; a Scene renders them like :func:`zbuffer.render`.

    Parameters
    ----------
    mesh : Mesh, trimesh.Trimesh, trimesh.Scene, pyvista.PolyData, (vertices, faces) or path
        What to draw (see :func:`zbuffer.render`).
    leaf_size : int, optional
        Tree nodes with at most this many triangles are leaves (both trees).
        Default: each tree's own (``zbuffer._core.DEFAULT_OCTREE_LEAF_SIZE``,
        ``DEFAULT_BVH_LEAF_SIZE``; 1024, measured the fastest overall on the
        spot grid and on single meshes, benchmarks/README.md).
    max_depth : int, optional
        Deepest octree level (cells of 1/2**max_depth of the root cube a
        side), 1 .. ``zbuffer._core.MAX_OCTREE_DEPTH`` (10).
    octree_rule : {"loose", "smallest", "greene"}
        Where an octree puts a triangle. "loose" (default, measured fastest;
        a loose octree's rule): in the cell of its centroid at the deepest
        level whose cells are at least as wide as the triangle, so that only
        large triangles live in coarse nodes. "smallest": in the smallest
        node enclosing it, so that one crossing a split plane near the root
        lives there, however small. "greene" (Greene's rule): in each of the
        at most 8 cells it overlaps at the deepest level where it spans at
        most two cells a side, drawn at most once per frame. Node bounds are
        those of the triangles under any rule.

    Raises
    ------
    ValueError, TypeError
        Bad mesh or parameters. (Building a tree raises ValueError for
        more than 715,827,882 triangle references -- a tree's faces index
        its vertex copies with 32-bit integers; Greene's rule references a
        triangle up to 8 times.)

    Examples
    --------
    >>> scene = zbuffer.Scene(mesh)
    >>> for cam in cameras:                       # the octree is built once
    ...     res = scene.render(cam, algo="hiz_octree", temporal=True)
    """

    def __init__(self, mesh, *, leaf_size: Optional[int] = None,
                 max_depth: Optional[int] = None, octree_rule: str = "loose"):
        self._mesh = as_mesh(mesh)
        self.leaf_size = (None if leaf_size is None
                          else check_int("leaf_size", leaf_size, 1, _INT32_MAX))
        self.max_depth = check_int("max_depth", _core.DEFAULT_OCTREE_MAX_DEPTH if max_depth is None
                                   else max_depth, 1, _core.MAX_OCTREE_DEPTH)
        self.octree_rule = check_choice("octree_rule", octree_rule, OCTREE_RULES)
        self._trees: Dict[str, object] = {}
        self._lock = threading.Lock()

    @property
    def mesh(self) -> Mesh:
        """The mesh this Scene draws, for its whole life (its trees hold
        copies of it): for another mesh, make another Scene."""
        return self._mesh

    def __repr__(self) -> str:
        built = ", ".join(sorted(self._trees)) or "nothing"
        return f"Scene({self.mesh!r}, built: {built})"

    def build(self, algo: str = "hiz_octree") -> float:
        """Build the tree ``algo`` renders, if not built yet.

        Parameters
        ----------
        algo : str
            A name from :func:`zbuffer.algorithms`; only ``"hiz_octree"``
            and ``"hiz_bvh"`` have a tree (for the others this does nothing).

        Returns
        -------
        float
            The milliseconds this call spent building (the core's timing of
            the build); 0.0 if the tree was built already or ``algo`` has
            none.

        Raises
        ------
        ValueError
            Unknown ``algo``.
        TypeError
            ``algo`` is not a string.
        MemoryError
            Not enough memory for the tree.
        """
        check_algorithm(algo)
        if algo not in TREE_ALGORITHMS:
            return 0.0
        with self._lock:
            if algo in self._trees:
                return 0.0
            if TREE_ALGORITHMS[algo] == "octree":
                leaf = self.leaf_size or _core.DEFAULT_OCTREE_LEAF_SIZE
                tree = _core.build_octree(self.mesh.vertices, self.mesh.faces, leaf,
                                          self.max_depth, self.octree_rule)
            else:
                leaf = self.leaf_size or _core.DEFAULT_BVH_LEAF_SIZE
                tree = _core.build_bvh(self.mesh.vertices, self.mesh.faces, leaf)
            self._trees[algo] = tree

            return tree.build_ms

    def tree_info(self, algo: str = "hiz_octree") -> dict:
        """Size of ``algo``'s tree (built if needed).

        Parameters
        ----------
        algo : {"hiz_octree", "hiz_bvh"}

        Returns
        -------
        dict
            ``kind`` ("octree" or "bvh"), ``nodes``, ``clusters`` (one per
            node that owns triangles), triangle ``references`` (the face
            ids the clusters hold; the octree's "greene" rule may list a
            face in several), input ``faces``, ``memory_bytes`` and
            ``build_ms``.

        Raises
        ------
        ValueError
            Unknown ``algo``, or one without a tree.
        TypeError
            ``algo`` is not a string.
        """
        self._require_tree(algo)
        tree = self._trees[algo]
        return {"kind": tree.kind, "nodes": tree.n_nodes, "clusters": tree.n_clusters,
                "references": tree.n_references, "faces": tree.n_faces,
                "memory_bytes": tree.memory_bytes, "build_ms": tree.build_ms}

    def nodes(self, algo: str = "hiz_octree") -> Dict[str, np.ndarray]:
        """The nodes of ``algo``'s tree (built if needed), for display.

        Parameters
        ----------
        algo : {"hiz_octree", "hiz_bvh"}

        Returns
        -------
        dict
            ``lo``, ``hi`` : (K, 3) float64 world-space bounds of each node's
            triangles; ``depth``, ``parent``, ``first_child``, ``n_children`` :
            (K,) int32 (parent -1 for the root); ``n_triangles`` (subtree) and
            ``own_triangles`` (drawn with the node itself) : (K,) int64;
            ``fate`` : (K,) uint8 in the last render of this tree, an index
            into :data:`NODE_FATES` (0 if it was never rendered).

        Raises
        ------
        ValueError
            Unknown ``algo``, or one without a tree.
        TypeError
            ``algo`` is not a string.
        """
        self._require_tree(algo)
        return self._trees[algo].nodes()

    def render(self, camera: Optional[Camera] = None, algo: str = "hiz_octree",
               width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1], *,
               temporal: bool = False, cull_backfaces: bool = False, shading: str = "flat",
               light_dir=None, ambient: float = DEFAULT_AMBIENT,
               diffuse: float = DEFAULT_DIFFUSE, color=None,
               background=DEFAULT_BACKGROUND, record_culls: bool = False,
               out=None) -> RenderResult:
        """Render one frame; arguments as for :func:`zbuffer.render`.

        With ``hiz_octree`` or ``hiz_bvh`` the Scene's tree is built (on
        first use) and traversed; other algorithms render as
        :func:`zbuffer.render` renders them.

        Parameters
        ----------
        camera : Camera, optional
            First here (``algo`` is the second argument); as for
            :func:`zbuffer.render`.
        algo : str
            Default ``"hiz_octree"``.
        width, height, cull_backfaces, shading, light_dir
            As for :func:`zbuffer.render`.
        ambient, diffuse, color, background, record_culls, out
            As for :func:`zbuffer.render`.
        temporal : bool
            Temporal coherence (Greene, Kass and Miller, section 6; tree
            algorithms only): if this Scene's previous frame of the same
            algorithm was rendered with ``temporal=True``, first draw the tree
            clusters that were visible in it, then traverse the tree against
            the Z-pyramid they produced (a frame without ``temporal`` in
            between starts afresh). The output is the same bits either way;
            only the work changes (see ``stats``).

        Returns
        -------
        RenderResult
            As :func:`zbuffer.render`; with a tree algorithm,
            ``stats["build_ms"]`` is the time this call spent building the
            tree (0.0 once it is built).

        Raises
        ------
        ValueError, TypeError
            As :func:`zbuffer.render`; also ValueError for ``temporal=True``
            with an algorithm without a tree.
        MemoryError
            Not enough memory to build the tree (a first render builds it).
        """
        start = time.perf_counter()
        check_algorithm(algo)
        temporal = check_flag("temporal", temporal)
        if temporal and algo not in TREE_ALGORITHMS:
            raise ValueError(f"temporal coherence needs a tree algorithm "
                             f"({', '.join(map(repr, TREE_ALGORITHMS))}), got {algo!r}")
        mesh, camera, mvp, width, height, params = prepare(
            self.mesh, camera, width, height, shading, light_dir, ambient, diffuse, color,
            background, cull_backfaces)
        record_culls = check_flag("record_culls", record_culls)
        depth, ids, image = output_arrays(out, width, height, mesh)
        with claimed((depth, ids, image)):
            if algo not in TREE_ALGORITHMS:
                planes = render_visibility(mesh, algo, mvp, width, height, cull_backfaces,
                                           record_culls, out_depth=depth, out_ids=ids)
            else:
                build_ms = self.build(algo)
                planes = self._trees[algo].render(mvp, width, height, bool(cull_backfaces),
                                                  bool(temporal), record_culls,
                                                  out_depth=depth, out_ids=ids)
                planes[2]["build_ms"] = build_ms
            return finish(mesh, camera, mvp, params, algo, *planes, start=start,
                          out_image=image)

    def _require_tree(self, algo: str) -> None:
        check_algorithm(algo)
        if algo not in TREE_ALGORITHMS:
            raise ValueError(f"{algo!r} has no tree; trees belong to "
                             f"{', '.join(map(repr, TREE_ALGORITHMS))}")
        self.build(algo)
