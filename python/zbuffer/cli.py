"""The ``zbuffer`` command line.

    zbuffer render                              # the built-in scene -> render.png
    zbuffer render bunny.obj --algo zbuffer --size 1024x768 --out bunny.png --depth bunny_depth.png
    zbuffer render bunny.obj --out none --depth depth.npy --ids ids.npy   # exact arrays
    zbuffer view bunny.obj --algo hiz_octree        # a live window (see zbuffer.viewer)
    zbuffer view --screenshot frame.png             # one frame offscreen, then exit
    zbuffer algorithms
    zbuffer bench [SUITE ...] [--quick]             # a source checkout's benchmarks
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Optional, Sequence

import numpy as np

from .camera import PROJECTIONS
from .options import DEFAULT_SIZE
from .scene import TREE_ALGORITHMS
from .shading import SHADINGS

__all__ = ["main", "save_image", "save_depth", "save_ids"]


def _size(text: str):
    try:
        w, h = text.lower().split("x")
        w, h = int(w), int(h)
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 800x600, got {text!r}") from None
    if w <= 0 or h <= 0:
        raise argparse.ArgumentTypeError(f"width and height must be positive, got {text!r}")
    return w, h


# What the images can be written as: any 8-bit RGB format for the image, a
# 16-bit PNG for the depth map.
_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
_DEPTH_SUFFIXES = (".png", ".npy")  # (.npy: the exact values)
_IDS_SUFFIXES = (".png", ".npy")


def _check_output(path: str, what: str, suffixes) -> None:
    """ValueError unless ``path`` names a file of one of ``suffixes`` in an
    existing folder (checked before rendering, so that a bad name costs no
    render and leaves no empty file)."""
    from pathlib import Path

    p = Path(path)
    if not path or p.is_dir():
        raise ValueError(f"{what} {path!r} is not a file name")
    if p.suffix.lower() not in suffixes:
        raise ValueError(f"{what} {path!r}: the file name must end in "
                         f"{', '.join(suffixes)}")
    if not p.resolve().parent.is_dir():
        raise ValueError(f"{what} {path!r}: no folder {str(p.parent)!r} to write it in")


def _write(path: str, what: str, write) -> None:
    """``write(path)``, with an OSError reported as a ValueError naming the
    file (and no half-written file left behind)."""
    try:
        write(path)
    except OSError as err:
        if os.path.isfile(path) and os.path.getsize(path) == 0:
            os.remove(path)
        raise ValueError(f"cannot write {what} {path!r}: {err}") from None


def _vec3(text: str):
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 3:
        raise argparse.ArgumentTypeError(f"expected three comma-separated numbers, got {text!r}")
    return tuple(v)


def save_image(path: str, image: np.ndarray) -> None:
    """Write an (H, W, 3) uint8 image (format from the file name's extension).

    Parameters
    ----------
    path : str
        Any suffix ``skimage.io.imsave`` writes (``zbuffer render --out``
        allows .png, .jpg, .jpeg, .bmp, .tif and .tiff).
    image : (H, W, 3) uint8

    Raises
    ------
    ImportError
        scikit-image is not installed.
    OSError, ValueError
        As ``skimage.io.imsave`` raises them (a file that cannot be
        written, a suffix it does not know).
    """
    import skimage.io

    skimage.io.imsave(path, image, check_contrast=False)


def save_depth(path: str, depth: np.ndarray) -> None:
    """Write a depth map: to a .npy file as it is (exact; +inf where nothing
    was drawn), else as a 16-bit greyscale image -- the nearest drawn depth
    white, the farthest dark grey, empty (+inf) pixels black. Pass
    ``RenderResult.eye_depth()`` for a map linear in distance.

    Parameters
    ----------
    path : str
        Ending in ``.npy`` (any case): the array as it is, C-contiguous.
        Otherwise an image format ``skimage.io.imsave`` writes 16-bit
        greyscale in (``zbuffer render --depth`` allows .png): the drawn
        depths scaled linearly, per image, from 65535 (nearest) to 8192
        (farthest), non-finite pixels 0.
    depth : (H, W) float32 or float64
        ``RenderResult.depth``, or ``eye_depth()``.

    Raises
    ------
    ImportError
        scikit-image is not installed (an image file).
    OSError, ValueError
        As ``np.save`` or ``skimage.io.imsave`` raise them.
    """
    if path.lower().endswith(".npy"):
        np.save(path, np.ascontiguousarray(depth))
        return
    import skimage.io

    from .viz import depth_grey

    skimage.io.imsave(path, depth_grey(depth, 65535, 8192).astype(np.uint16),
                      check_contrast=False)


def save_ids(path: str, triangle_id: np.ndarray) -> None:
    """Write a triangle-id map: to a .npy file as int32 ids (exact; -1 where
    nothing was drawn), else as an RGB image in false colour (each id its
    own colour, :func:`zbuffer.viz.id_colors`; nothing drawn black).

    Parameters
    ----------
    path : str
        Ending in ``.npy`` (any case): the array as it is, C-contiguous.
        Otherwise as for :func:`save_image`.
    triangle_id : (H, W) int32

    Raises
    ------
    ImportError
        scikit-image is not installed (images only).
    OSError, ValueError
        As ``np.save`` or :func:`save_image` raise them.
    """
    if path.lower().endswith(".npy"):
        np.save(path, np.ascontiguousarray(triangle_id))
        return
    from .viz import id_colors

    save_image(path, id_colors(triangle_id))


def _print_stats(stats: dict, out) -> None:
    counters = [k for k, v in stats.items() if isinstance(v, int)]
    times = [k for k, v in stats.items() if isinstance(v, float)]
    width = max(len(k) for k in stats)
    for k in counters:
        print(f"  {k:<{width}}  {stats[k]:>12,}", file=out)
    for k in times:
        print(f"  {k:<{width}}  {stats[k]:>12.3f}", file=out)


def render_camera(args, mesh, width: int, height: int):
    """The camera ``zbuffer render`` uses: from --eye (looking at --target,
    else the mesh's centre; clip planes --near and --far, else fitted), else
    framing the mesh from --view-dir -- for the built-in scene with no view
    options, its own default view -- with --up, --fov and --projection
    throughout."""
    from .camera import Camera
    from .scenes import default_camera

    # (--fov and --projection default to None, so that giving either, even
    # with its default value, takes the built-in scene off its own view.)
    fov = 45.0 if args.fov is None else args.fov
    projection = args.projection or "perspective"
    if args.eye is not None:
        target = args.target if args.target is not None else tuple(mesh.bounding_sphere[0])
        return Camera.look_at(args.eye, target, up=args.up, fov_y=fov,
                              near=args.near, far=args.far, projection=projection)
    if args.mesh is None and args.view_dir is None and args.fov is None and args.projection is None:
        return default_camera(width / height, up=args.up)
    direction = args.view_dir if args.view_dir is not None else (0.0, 0.0, 1.0)
    return Camera.fit(mesh, direction=direction, up=args.up, fov_y=fov,
                      projection=projection, aspect=width / height)


def _cmd_render(args) -> int:
    import zbuffer

    from .camera import _TooLargeToFrame
    from .scenes import default_scene

    width, height = args.size
    if args.target is not None and args.eye is None:
        raise ValueError("--target needs --eye (without it the camera frames the mesh "
                         "from --view-dir)")
    if args.view_dir is not None and args.eye is not None:
        raise ValueError("--view-dir and --eye both place the camera: give one of them")
    if (args.near is not None or args.far is not None) and args.eye is None:
        raise ValueError("--near and --far need --eye (framing the mesh fits the clip planes)")
    if args.out is not None:
        _check_output(args.out, "--out", _IMAGE_SUFFIXES)
    if args.depth is not None:
        _check_output(args.depth, "--depth", _DEPTH_SUFFIXES)
    if args.ids is not None:
        _check_output(args.ids, "--ids", _IDS_SUFFIXES)
    outputs = [(what, path) for what, path in
               (("--out", args.out), ("--depth", args.depth), ("--ids", args.ids)) if path]
    for k, (what, path) in enumerate(outputs):
        for other, other_path in outputs[k + 1:]:
            if os.path.realpath(path) == os.path.realpath(other_path):
                raise ValueError(f"{what} and {other} name the same file {path!r}: "
                                 f"one would overwrite the other")
    mesh = default_scene() if args.mesh is None else zbuffer.load(args.mesh)
    shading = "none" if args.out is None else args.shading
    try:
        camera = render_camera(args, mesh, width, height)
        result = zbuffer.render(mesh, algo=args.algo, camera=camera, width=width, height=height,
                                cull_backfaces=args.cull_backfaces, shading=shading)
    except _TooLargeToFrame as err:  # (its advice in this command's terms)
        placed = args.eye is not None and args.target is not None
        options = "--near and --far" if placed else "--eye, --target, --near and --far"
        raise ValueError(f"{err} (here: {options})") from None
    # The files first: a report cut short (its reader closed standard
    # output: `zbuffer render | head -1`) must not cost them.
    if args.out is not None:
        _write(args.out, "the image", lambda p: save_image(p, result.image))
    if args.depth is not None:
        _write(args.depth, "the depth map", lambda p: save_depth(p, result.eye_depth()))
    if args.ids is not None:
        _write(args.ids, "the triangle ids", lambda p: save_ids(p, result.triangle_id))
    name = mesh.name or "mesh"
    print(f"{name}: {len(mesh.faces):,} triangles, {width}x{height}, algo={args.algo}, "
          f"{int(result.mask.sum()):,} pixels drawn")
    _print_stats(result.stats, sys.stdout)
    for _, path in outputs:
        print(f"wrote {path}")
    return 0


def _cmd_view(args) -> int:
    import zbuffer

    from .scenes import default_scene
    from .viewer import Viewer, run
    from .viz import can_open_window

    width, height = args.size
    if args.screenshot is not None:
        _check_output(args.screenshot, "--screenshot", (".png",))
    mesh = default_scene() if args.mesh is None else zbuffer.load(args.mesh)
    viewer = Viewer(mesh, algo=args.algo, width=width, height=height, shading=args.shading)
    if args.overlay != "none":
        viewer.toggle(args.overlay)
        if viewer.overlay != args.overlay:
            raise ValueError(f"overlay {args.overlay!r} needs a tree algorithm "
                             f"({', '.join(TREE_ALGORITHMS)})")
    if args.screenshot is None and not can_open_window():
        raise ValueError("no display to open a window on; use --screenshot FILE")
    run(viewer, screenshot=args.screenshot)
    if args.screenshot is not None:
        print(viewer.status())
        print(f"wrote {args.screenshot}")
    return 0


def _cmd_algorithms(args) -> int:
    from . import _core

    for name, summary in _core.algorithms():
        print(f"{name:<12} {summary}")
    return 0


def find_benchmarks():
    """The ``benchmarks/`` folder of a zbuffer source checkout, or None: the
    folder named by $ZBUFFER_BENCHMARKS, else the checkout this package runs
    from (an editable install), else ``benchmarks/`` in the current folder or
    one above it."""
    from pathlib import Path

    def is_harness(folder: Path) -> bool:
        return (folder / "run.py").is_file() and (folder / "common.py").is_file()

    named = os.environ.get("ZBUFFER_BENCHMARKS")
    if named:
        if not is_harness(Path(named)):
            raise ValueError(f"ZBUFFER_BENCHMARKS={named} is not a zbuffer benchmarks folder "
                             "(no run.py there)")
        return Path(named)
    cwd = Path.cwd()
    for folder in (Path(__file__).resolve().parents[2] / "benchmarks",
                   *(d / "benchmarks" for d in (cwd, *cwd.parents))):
        if is_harness(folder):
            return folder
    return None


# The suites of benchmarks/run.py.
BENCH_SUITES = ("models", "render", "hiz", "scaling", "peers", "load")


def _cmd_bench(args) -> int:
    import subprocess

    folder = find_benchmarks()
    if folder is None:
        raise ValueError("zbuffer bench runs the benchmark harness of a zbuffer source "
                         "checkout (benchmarks/run.py), which an installed package does not "
                         "include: run it inside the checkout, or set "
                         "ZBUFFER_BENCHMARKS=/path/to/zbuffer/benchmarks")
    unknown = [name for name in args.suites if name not in BENCH_SUITES]
    if unknown:
        raise ValueError(f"unknown benchmark suite {unknown[0]!r}; the suites are "
                         f"{', '.join(BENCH_SUITES)}")
    command = [sys.executable, str(folder / "run.py"), *args.suites]
    if args.quick:
        command.append("--quick")
    if args.out is not None:
        # Checked (and made) before the suites run, not after.
        if not args.out or (os.path.exists(args.out) and not os.path.isdir(args.out)):
            raise ValueError(f"--out {args.out!r} is not a folder")
        try:
            os.makedirs(args.out, exist_ok=True)
        except OSError as err:
            raise ValueError(f"--out {args.out!r}: cannot make that folder ({err})") from None
        if not os.access(args.out, os.W_OK):
            raise ValueError(f"--out {args.out!r}: cannot write there")
        command += ["--out", os.path.abspath(args.out)]
    return subprocess.run(command).returncode


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser: ``zbuffer render | view | algorithms | bench ...``."""
    from . import __version__

    parser = argparse.ArgumentParser(
        prog="zbuffer", description="Exact software Z-buffer renderers for triangle meshes.")
    parser.add_argument("--version", action="version", version=f"zbuffer {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    r = sub.add_parser("render", help="render a mesh file (or the built-in scene) to an image")
    r.add_argument("mesh", nargs="?", help="mesh file (any format zbuffer.load reads); "
                   "omitted: the built-in default scene")
    r.add_argument("--algo", default="zbuffer", help="depth algorithm (see 'zbuffer algorithms')")
    r.add_argument("--size", type=_size, default=DEFAULT_SIZE,
                   help="WIDTHxHEIGHT (default %dx%d)" % DEFAULT_SIZE)
    r.add_argument("--out", default="render.png",
                   help="shaded image to write (default render.png); 'none' to skip")
    r.add_argument("--depth", default=None,
                   help="also write the depth map (distance along the view axis): .npy, the "
                        "exact float64 values (inf where nothing was drawn), or a 16-bit PNG "
                        "scaled per image (nearest white, farthest dark grey, nothing black)")
    r.add_argument("--ids", default=None,
                   help="also write the triangle ids: .npy, the exact int32 ids (-1 where "
                        "nothing was drawn), or a PNG in false colour (nothing drawn black)")
    r.add_argument("--shading", choices=["flat", "smooth"], default="flat",
                   help="Lambert shading from face normals (flat, default) or interpolated "
                        "vertex normals (smooth)")
    r.add_argument("--cull-backfaces", action="store_true", help="skip back-facing triangles")
    r.add_argument("--projection", choices=PROJECTIONS, default=None,
                   help="camera projection (default perspective)")
    r.add_argument("--fov", type=float, default=None,
                   help="vertical field of view in degrees (default 45)")
    r.add_argument("--view-dir", type=_vec3, default=None, metavar="X,Y,Z",
                   help="direction from the mesh towards the camera (default 0,0,1; "
                        "the built-in scene without view options: its own view)")
    r.add_argument("--eye", type=_vec3, default=None, metavar="X,Y,Z", help="camera position")
    r.add_argument("--target", type=_vec3, default=None, metavar="X,Y,Z",
                   help="point looked at (default: the mesh centre)")
    r.add_argument("--near", type=float, default=None,
                   help="near clip distance, with --eye (default: fitted to the mesh)")
    r.add_argument("--far", type=float, default=None,
                   help="far clip distance, with --eye (default: fitted to the mesh)")
    r.add_argument("--up", type=_vec3, default=(0.0, 1.0, 0.0), metavar="X,Y,Z",
                   help="the camera's up direction (default 0,1,0)")
    r.set_defaults(func=_cmd_render)

    v = sub.add_parser("view", help="a live window of zbuffer's own rendering "
                       "(drag: rotate, wheel: zoom, keys a/s/d/p/o/r; see zbuffer.viewer)")
    v.add_argument("mesh", nargs="?", help="mesh file; omitted: the built-in default scene")
    v.add_argument("--algo", default="hiz_octree", help="starting algorithm (key a: next)")
    v.add_argument("--size", type=_size, default=DEFAULT_SIZE,
                   help="WIDTHxHEIGHT (default %dx%d)" % DEFAULT_SIZE)
    v.add_argument("--shading", choices=SHADINGS, default="flat")
    v.add_argument("--overlay", choices=["none", "depth", "pyramid", "tree"], default="none",
                   help="starting overlay (keys d, p, o)")
    v.add_argument("--screenshot", default=None, metavar="FILE",
                   help="render one frame offscreen into FILE (PNG) and exit")
    v.set_defaults(func=_cmd_view)

    b = sub.add_parser("bench", help="run the benchmark suites of a source checkout "
                       "(benchmarks/run.py) and regenerate benchmarks/results/RESULTS.md")
    b.add_argument("suites", nargs="*", metavar="SUITE",
                   help=f"{', '.join(BENCH_SUITES)} (default: all)")
    b.add_argument("--quick", action="store_true", help="smoke mode: small inputs, few runs")
    b.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default benchmarks/results, the recorded results; "
                   "with --quick, build/bench-quick of the checkout)")
    b.set_defaults(func=_cmd_bench)

    a = sub.add_parser("algorithms", help="list the depth algorithms")
    a.set_defaults(func=_cmd_algorithms)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``zbuffer`` command; returns the exit status.

    Errors the commands raise as ValueError, TypeError, OSError or
    MemoryError are printed to standard error as ``zbuffer: error: ...``,
    not raised.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        0 on success; 2 after such an error; 1 when whatever read standard
        output closed it early; for ``bench``, the harness's own status.

    Raises
    ------
    SystemExit
        From argparse: for ``--help`` and ``--version`` (status 0) and for
        arguments it refuses (status 2).
    """
    parser = build_parser()
    args = parser.parse_args(list(argv) if argv is not None else None)
    if args.command == "render" and args.out == "none":
        args.out = None
    try:
        status = args.func(args)
        sys.stdout.flush()  # (so that a closed pipe shows here, not at exit)
        return status
    except BrokenPipeError:
        # Whatever read the output stopped early (`zbuffer render | head -1`):
        # nothing to report. Standard output goes to /dev/null, so that
        # Python's last flush at exit does not fail again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    # (OSError: unreadable files, full disks; MemoryError: a tree too large)
    except (ValueError, TypeError, OSError, MemoryError) as err:
        print(f"zbuffer: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
