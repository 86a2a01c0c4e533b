"""Type stubs for zbuffer's compiled core (private: use the zbuffer package)."""

from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

SUBPIXEL_BITS: int
MAX_IMAGE_SIDE: int
MAX_IMAGE_PIXELS: int
GUARD_BAND_PX: float
MIN_CLIP_W: float
MAX_CLIP_VERTICES: int
RASTER_BACKEND: str
MAX_OCTREE_DEPTH: int
DEFAULT_OCTREE_LEAF_SIZE: int
DEFAULT_OCTREE_MAX_DEPTH: int
DEFAULT_BVH_LEAF_SIZE: int
MAX_SCANLINE_TRIANGLES: int
def check_scanline_faces(n_faces: int) -> None: ...

class ObjectTree:
    """A built octree or BVH with the state of its last frame."""

    @property
    def kind(self) -> str: ...
    @property
    def build_ms(self) -> float: ...
    @property
    def n_nodes(self) -> int: ...
    @property
    def n_clusters(self) -> int: ...
    @property
    def n_references(self) -> int: ...
    @property
    def n_faces(self) -> int: ...
    @property
    def memory_bytes(self) -> int: ...
    def render(
        self,
        mvp: npt.NDArray[np.float64],
        width: int,
        height: int,
        cull_backfaces: bool = False,
        temporal: bool = False,
        record_culls: bool = False,
        out_depth: Optional[npt.NDArray[np.float32]] = None,
        out_ids: Optional[npt.NDArray[np.int32]] = None,
    ) -> Tuple[Any, ...]: ...  # (depth, triangle_id, stats[, culls per pyramid level])
    def nodes(self) -> Dict[str, np.ndarray]: ...

def build_octree(
    positions: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int32],
    leaf_size: int = ...,
    max_depth: int = ...,
    rule: str = "loose",
) -> ObjectTree: ...
def build_bvh(
    positions: npt.NDArray[np.float64], faces: npt.NDArray[np.int32], leaf_size: int = ...
) -> ObjectTree: ...

def algorithms() -> List[Tuple[str, str]]: ...
def polygon_algorithms() -> List[str]: ...
def pyramid_algorithms() -> List[str]: ...
def render(
    positions: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int32],
    mvp: npt.NDArray[np.float64],
    width: int,
    height: int,
    algo: str = "zbuffer",
    cull_backfaces: bool = False,
    face_ids: Optional[npt.NDArray[np.int32]] = None,
    polygon_offsets: Optional[npt.NDArray[np.int64]] = None,
    polygon_indices: Optional[npt.NDArray[np.int32]] = None,
    record_culls: bool = False,
    cell_start: Optional[npt.NDArray[np.int32]] = None,
    cell_centre: Optional[npt.NDArray[np.float64]] = None,
    out_depth: Optional[npt.NDArray[np.float32]] = None,
    out_ids: Optional[npt.NDArray[np.int32]] = None,
) -> Tuple[Any, ...]: ...  # (depth, triangle_id, stats[, culls per pyramid level])
def pyramid_levels(depth: npt.NDArray[np.float32]) -> List[npt.NDArray[np.float32]]: ...
def spatial_order(
    positions: npt.NDArray[np.float64], faces: npt.NDArray[np.int32]
) -> Tuple[npt.NDArray[np.int32], npt.NDArray[np.int32], npt.NDArray[np.float64]]: ...
# (order, cell_start, cell_centre)
def first_use_order(
    faces: npt.NDArray[np.int32], n_vertices: int
) -> Tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]: ...
# (faces renumbered, vertex_order)
def vertex_normals(
    positions: npt.NDArray[np.float64], faces: npt.NDArray[np.int32]
) -> npt.NDArray[np.float64]: ...
def shade(
    triangle_id: npt.NDArray[np.int32],
    positions: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int32],
    mvp: npt.NDArray[np.float64],
    viewer: npt.NDArray[np.float64],
    light_dir: npt.NDArray[np.float64],
    ambient: float,
    diffuse: float,
    background: npt.NDArray[np.uint8],
    uniform_color: npt.NDArray[np.float32],
    color_source: str = "uniform",
    colors: Optional[npt.NDArray[np.float32]] = None,
    vertex_normals: Optional[npt.NDArray[np.float64]] = None,
    out: Optional[npt.NDArray[np.uint8]] = None,
    pixels_beyond_faces: bool = False,
    ids_below: int = -1,
) -> npt.NDArray[np.uint8]: ...
def read_obj_records(
    text: bytes,
) -> Optional[
    Tuple[
        npt.NDArray[np.float64],
        Optional[npt.NDArray[np.float64]],
        npt.NDArray[np.int64],
        npt.NDArray[np.int64],
    ]
]: ...
# (positions, colours as written or None, polygon sizes, indices), or None
# outside the subset cpp/include/zbuffer/obj_reader.h takes
def read_off_records(
    text: bytes,
) -> Optional[
    Tuple[
        npt.NDArray[np.float64],
        npt.NDArray[np.int64],
        npt.NDArray[np.int64],
        Optional[npt.NDArray[np.float64]],
        bool,
        Optional[npt.NDArray[np.float64]],
        bool,
    ]
]: ...
# (positions, polygon sizes, indices, vertex colours as written or None,
# whether written as floats, face colours or None, whether floats), or None
# outside the subset cpp/include/zbuffer/off_reader.h takes
def read_ascii_ply_tables(
    body: bytes, counts: List[int]
) -> Optional[List[npt.NDArray[np.float64]]]: ...
# (counts[e], words a record) tables of an ASCII PLY body, or None outside
# the subset cpp/include/zbuffer/ply_reader.h takes
