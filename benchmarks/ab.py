"""A/B: the C++ cores of two source trees in one process, frame by frame.

    python benchmarks/ab.py 598c1dd                 # that commit against the working tree
    python benchmarks/ab.py HEAD~3 HEAD --algo zbuffer hiz
    python benchmarks/ab.py HEAD . --march haswell  # the AVX2 loops (any x86-64 with AVX2)
    python benchmarks/ab.py HEAD HEAD --march-b haswell  # one tree's AVX-512 loops against its AVX2 ones
    python benchmarks/ab.py HEAD . --cases bunny_69k.obj@1024x1024 --frames 400
    python benchmarks/ab.py HEAD . --algo hiz_bvh --cases grid20-orthographic@1024x1024
    python benchmarks/ab.py HEAD . --algo hiz_octree@once   # zbuffer.Scene's tree, built once
    python benchmarks/ab.py HEAD . --shading flat smooth  # the shading pass after each render

The machines these benchmarks run on are shared and noisy: the same frame
takes 2.4 ms in one minute and 3.5 ms in the next, so two builds timed one
after the other, even in alternating processes, differ by more than most
changes are worth. This script builds the core (``cpp/``) of each tree --
a git revision, or ``.`` for the working tree -- under its own namespace
(``-Dzbuffer=zb_a`` / ``zb_b``), links both into one runner
(``benchmarks/ab/``), and renders every case with A and B in alternating
turns (A B, B A, ...), each turn two frames of its side with the second
timed, so that every timed frame follows one of its own (as frame after
frame of one build would; timing every frame of A B B A ... gave each side
two modes, 7-15% apart at 1024 x 1024, and the median fell between them):
both see the same noise, and the ratio of their medians is stable to about
one percent (an A/A run of one tree against itself gave 0.990-1.004, 100
frames a side: results/ab-aa-warm.md). It also checks that the two drew the
same bits, in the first frame and in the last.

The inputs are the Python side's, made once by the installed ``zbuffer``
(the mesh's prepared visiting order, the fitted camera's matrix): the
comparison is of the compiled core alone, from the vertex stage to the last
pixel, with the output planes cleared in the call (``render_ms``). With
``--shading flat`` or ``smooth``, every frame is also shaded (the mesh, its
normals and the default light as ``zbuffer.render`` passes them), and the
time compared is the shading call's alone; the images are compared too
(shading is allowed to differ by a level between builds: the report gives
the largest difference).
Builds go to ``build/ab/``; the report (every frame's time, medians,
ratios, machine, command, date) to ``--out`` (default
``benchmarks/results``) as ``--name`` ``.json`` and ``.md`` (default ``ab``).
Nothing is asserted.
"""

from __future__ import annotations

import argparse
import io
import itertools
import json
import os
import shutil
import statistics
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np

import zbuffer
from common import HERE, MODELS, new_report, write_report

ROOT = HERE.parent
BUILD = ROOT / "build" / "ab"
DEFAULT_CASES = ["bunny_10k.obj@666x500", "bunny_69k.obj@1024x1024", "armadillo_86k.obj@1024x1024"]
MARCH = {  # --march: (CMake options of the core, compiler flag of the runner)
    "native": (["-DZBUFFER_NATIVE=ON"], ["-march=native"]),
    "haswell": (["-DZBUFFER_MARCH=haswell"], ["-march=haswell"]),
    "portable": (["-DZBUFFER_NATIVE=OFF"], []),
}


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, **kw)


def tree_of(rev: str) -> tuple[Path, str]:
    """(source folder, label) of a revision: the working tree for '.', else
    the revision's cpp/ exported into build/ab/tree-<sha>."""
    if rev == ".":
        return ROOT, "working tree"
    found = subprocess.run(["git", "rev-parse", "--short", "--verify", f"{rev}^{{commit}}"],
                           cwd=ROOT, capture_output=True, text=True)
    if found.returncode != 0:
        raise SystemExit(f"ab.py: {rev!r} is not a revision of {ROOT} (or . for the working tree)")
    sha = found.stdout.strip()
    dest = BUILD / f"tree-{sha}"
    if not (dest / "cpp" / "CMakeLists.txt").is_file():
        archive = run(["git", "archive", "--format=tar", sha, "cpp"], cwd=ROOT,
                      capture_output=True).stdout
        dest.mkdir(parents=True, exist_ok=True)
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            tar.extractall(dest)
    return dest, sha


def build_side(src: Path, side: str, march: str) -> list[Path]:
    """The core of `src` under namespace zb_<side>, and side.cpp against it:
    the object and library to link."""
    out = BUILD / f"{side}-{march}"
    cmake_opts, flags = MARCH[march]
    if out.exists():
        shutil.rmtree(out)
    run(["cmake", "-S", str(src / "cpp"), "-B", str(out), "-DCMAKE_BUILD_TYPE=Release",
         "-DZBUFFER_BUILD_TESTS=OFF", "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON",
         f"-DCMAKE_CXX_FLAGS=-Dzbuffer=zb_{side}", *cmake_opts],
        stdout=subprocess.DEVNULL)
    run(["cmake", "--build", str(out), "-j", str(os.cpu_count() or 2)], stdout=subprocess.DEVNULL)
    check_march(out, side, march)
    obj = out / "side.o"
    run([os.environ.get("CXX", "c++"), "-O2", "-std=c++17", *flags, f"-Dzbuffer=zb_{side}",
         f"-DAB_SIDE=ab_render_{side}", "-I", str(src / "cpp" / "include"), "-c",
         str(HERE / "ab" / "side.cpp"), "-o", str(obj)])
    return [obj, out / "libzbuffer_core.a"]


def check_march(out: Path, side: str, march: str) -> None:
    """Exit unless every source of the core in build folder `out` was
    compiled for `march`: an older revision's CMakeLists.txt may not know an
    option (ZBUFFER_MARCH came later), and CMake then builds it for the
    build machine without a word."""
    want = {"native": "-march=native", "haswell": "-march=haswell", "portable": None}[march]
    commands = json.loads((out / "compile_commands.json").read_text())
    flags = [c.get("command") or " ".join(c.get("arguments", [])) for c in commands
             if "/cpp/src/" in c["file"].replace("\\", "/")]
    marches = {f for cmd in flags for f in cmd.split() if f.startswith("-march=")}
    if not flags or marches != ({want} if want else set()):
        raise SystemExit(f"ab.py: side {side.upper()}'s core was compiled with "
                         f"{sorted(marches) or 'no -march'}, not for --march {march} "
                         f"(its cpp/CMakeLists.txt does not take {' '.join(MARCH[march][0])}?)")


def model_file(model: str):
    """The file a case's model is made from (None for the built-in scene);
    ValueError for a grid case that is not gridN-perspective or
    gridN-orthographic."""
    if model == "default":
        return None
    if model.startswith("grid"):
        n, _, projection = model[4:].partition("-")
        if not (n.isdigit() and int(n) >= 1 and projection in ("perspective", "orthographic")):
            raise ValueError("expected gridN-perspective or gridN-orthographic")
        return MODELS / "spot.obj"
    return MODELS / model


def case_mesh(model: str, width: int, height: int):
    """(prepared mesh, camera) of a case: a shared model framed by
    Camera.fit, gridN-PROJECTION (the 5 x 5 x N spot grid and camera of
    bench_hiz.py), or ``default`` (the built-in scene of ``zbuffer render``)."""
    if model == "default":
        mesh = zbuffer.scenes.default_scene().prepare()
        return mesh, zbuffer.scenes.default_camera(aspect=width / height).resolve(mesh)
    if model.startswith("grid"):
        from bench_hiz import grid_camera

        n, _, projection = model[4:].partition("-")
        mesh = zbuffer.scenes.instance_grid(zbuffer.load(MODELS / "spot.obj"), (5, 5, int(n)))
        return mesh.prepare(), grid_camera(mesh, projection)
    mesh = zbuffer.load(MODELS / model).prepare()
    return mesh, zbuffer.Camera.fit(mesh, aspect=width / height).resolve(mesh)


def write_scene(path: Path, model: str, width: int, height: int) -> None:
    """A case as the runner reads it: the prepared mesh and its camera."""
    mesh, camera = case_mesh(model, width, height)
    visit = mesh.faces_for_render()
    mvp = camera.mvp(width, height)
    normals = mesh.vertex_normals
    ids = visit.ids if visit.ids is not None else np.arange(len(visit.faces), dtype=np.int32)
    cells = visit.cell_start is not None
    with open(path, "wb") as fh:
        n_cells = len(visit.cell_start) - 1 if cells else 0
        np.array([len(visit.vertices), len(visit.faces), n_cells, width, height],
                 np.int64).tofile(fh)
        np.ascontiguousarray(mvp, np.float64).tofile(fh)
        np.ascontiguousarray(visit.vertices, np.float64).tofile(fh)
        np.ascontiguousarray(visit.faces, np.int32).tofile(fh)
        np.ascontiguousarray(ids, np.int32).tofile(fh)
        if cells:
            np.ascontiguousarray(visit.cell_start, np.int32).tofile(fh)
            np.ascontiguousarray(visit.cell_centre, np.float64).tofile(fh)
        # For shading: the viewer, the default light, and the mesh the ids index.
        np.ascontiguousarray(camera.viewer(), np.float64).tofile(fh)
        np.ascontiguousarray(camera.forward(), np.float64).tofile(fh)
        np.array([len(mesh.vertices), len(mesh.faces)], np.int64).tofile(fh)
        np.ascontiguousarray(mesh.vertices, np.float64).tofile(fh)
        np.ascontiguousarray(mesh.faces, np.int32).tofile(fh)
        np.ascontiguousarray(normals, np.float64).tofile(fh)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("base", help="revision A (a git revision, or . for the working tree)")
    ap.add_argument("head", nargs="?", default=".", help="revision B (default: the working tree)")
    ap.add_argument("--algo", nargs="+", default=["zbuffer"],
                    choices=zbuffer.algorithms() + ["hiz_octree@once", "hiz_bvh@once"],
                    help="registry algorithms (built per frame), or hiz_octree@once / "
                    "hiz_bvh@once: the tree zbuffer.Scene builds, built at the first frame "
                    "and rendered from then on (default: %(default)s)")
    ap.add_argument("--cases", nargs="+", default=DEFAULT_CASES,
                    help="MODEL@WxH, models from ../shared/models, gridN-perspective / "
                    "gridN-orthographic for bench_hiz.py's 5 x 5 x N spot grid, or "
                    "default@WxH for the built-in scene (default: %(default)s)")
    ap.add_argument("--frames", type=int, default=200, help="frames per side and case")
    ap.add_argument("--shading", nargs="+", choices=["none", "flat", "smooth"], default=["none"],
                    help="none: compare renders; flat, smooth: shade every frame and compare "
                    "the shading call's time")
    ap.add_argument("--march", choices=sorted(MARCH), default="native",
                    help="instruction set of both builds (haswell: the AVX2 loops)")
    ap.add_argument("--march-b", choices=sorted(MARCH), default=None,
                    help="another instruction set for B (A keeps --march): the loops of two "
                    "instruction sets compared frame by frame, e.g. HEAD HEAD --march-b haswell")
    ap.add_argument("--out", default=str(HERE / "results"), help="folder for the report")
    ap.add_argument("--name", default="ab", help="the report's file names: NAME.json, NAME.md")
    args = ap.parse_args(argv)
    if args.frames < 1:
        ap.error("--frames must be at least 1")

    cases = []
    for case in args.cases:
        model, _, size = case.partition("@")
        try:
            width, height = (int(v) for v in size.split("x"))
        except ValueError:
            ap.error(f"case {case!r}: expected MODEL@WIDTHxHEIGHT")
        if not (0 < width <= 16384 and 0 < height <= 16384):
            ap.error(f"case {case!r}: width and height must be in 1 .. 16384")
        try:
            path = model_file(model)
        except ValueError as err:
            ap.error(f"case {case!r}: {err}")
        if path is not None and not path.is_file():
            ap.error(f"case {case!r}: {path} does not exist")
        cases.append((model, width, height))

    BUILD.mkdir(parents=True, exist_ok=True)
    src_a, label_a = tree_of(args.base)
    src_b, label_b = tree_of(args.head)
    march_b = args.march_b or args.march
    marches = args.march if march_b == args.march else f"{args.march} (A), {march_b} (B)"
    print(f"A = {label_a}, B = {label_b}, --march {marches}: building ...", flush=True)
    link = build_side(src_a, "a", args.march) + build_side(src_b, "b", march_b)
    runner = BUILD / f"runner-{args.march}" if march_b == args.march else \
        BUILD / f"runner-{args.march}-{march_b}"
    # (The runner itself has no vector loops: A's flags.)
    run([os.environ.get("CXX", "c++"), "-O2", "-std=c++17", *MARCH[args.march][1],
         str(HERE / "ab" / "runner.cpp"), *map(str, link), "-o", str(runner)])

    scenes = []
    for k, (model, width, height) in enumerate(cases):
        path = BUILD / f"case{k}-{Path(model).stem}-{width}x{height}.bin"  # rewritten each run
        write_scene(path, model, width, height)
        scenes.append(path)

    report = new_report("ab.py", argv)
    # (The runner's loops are those of --march, not the installed package's.)
    report["machine"]["raster_backend"] = f"the runner's, --march {marches}"
    report.update({"a": label_a, "b": label_b, "march": args.march, "march_b": march_b,
                   "frames": args.frames,
                   "shading": args.shading, "results": []})
    rows = []
    for algo, shading in itertools.product(args.algo, args.shading):
        done = subprocess.run([str(runner), str(args.frames), algo, shading, *map(str, scenes)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"ab.py: the runner failed on {algo}, shading {shading}:\n{done.stderr}")
        out = done.stdout
        for (model, width, height), line in zip(cases, out.splitlines()):
            r = json.loads(line)
            a, b = (statistics.median(ms) for ms in r["ms"])
            r.update({"model": model, "a_ms_median": a, "b_ms_median": b, "ratio": b / a})
            report["results"].append(r)
            same = "yes" if r["same_bits"] else "**no**"
            if shading != "none":
                same += f" ({r['image_max_diff']})"
            rows.append(f"| {model} | {width}x{height} | {algo} | {shading} | {a:.3f} | {b:.3f} | "
                        f"**{b / a:.3f}** | {same} |")
            print(rows[-1], flush=True)

    m = report["machine"]
    text = "\n".join([
        "# A/B: two builds of the core in one process", "",
        f"- date: {report['date']}",
        f"- machine: {m['cpu']}, {m['cores']} cores; --march {marches}",
        f"- A: {label_a}; B: {label_b}",
        f"- command: `{report['command']}`",
        f"- each cell: median of {args.frames} timed frames per side, A and B in "
        "alternating turns (A B, B A, ...) of two frames each, the second timed (each "
        "timed frame follows one of its own side); one thread. Shading none: ms is the core's "
        "`render_ms` (clearing the planes included), depth only; flat or smooth: ms is "
        "the shading call alone, after each render, and *same bits* compares the image "
        "too (the largest difference of a channel in brackets)", "",
        "| model | size | algo | shading | A ms | B ms | B / A | same bits |",
        "|---|---|---|---|---:|---:|---:|---|",
        *rows, ""])
    write_report(args.out, args.name, report, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
