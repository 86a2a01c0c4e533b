"""Time zbuffer.render on real meshes; write JSON and a markdown table.

    python benchmarks/bench_render.py            # full run -> benchmarks/results/
    python benchmarks/bench_render.py --quick    # CI smoke mode: few runs, small sizes

Each case renders an already loaded mesh in-process, single-threaded, with a
fixed camera; the time is the median of --runs renders (after one warm-up),
taken from the core's own render_ms (the C++ call with its output buffers)
and from the whole Python call (total_ms). Nothing here asserts a speed.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import zbuffer
from common import (MODELS, Progress, add_out_argument, load_model, new_report, out_folder,
                    write_report)

# (model file, width, height, shading, algorithm, what the issues ask of it)
CASES = [
    ("bunny_10k.obj", 666, 500, "none", "zbuffer", "target <= 0.30 ms per frame"),
    ("bunny_10k.obj", 666, 500, "flat", "zbuffer", "shaded frame, for reference"),
    ("bunny_69k.obj", 1024, 1024, "none", "zbuffer", "target >= 30 M triangles/s"),
    ("armadillo_86k.obj", 1024, 1024, "none", "zbuffer", "target >= 30 M triangles/s"),
    ("bunny_69k.obj", 1024, 1024, "flat", "zbuffer", "shaded frame (the default shading)"),
    ("bunny_69k.obj", 1024, 1024, "smooth", "zbuffer", "shaded frame, for reference"),
    ("bunny_69k.obj", 1024, 1024, "none", "hiz", "target <= 1.25x zbuffer (issue 4)"),
    ("armadillo_86k.obj", 1024, 1024, "none", "hiz", "target <= 1.25x zbuffer (issue 4)"),
    ("bunny_69k.obj", 1024, 1024, "none", "scanline", "target <= 1.5x zbuffer (issue 3)"),
    ("armadillo_86k.obj", 1024, 1024, "none", "scanline", "target <= 1.5x zbuffer (issue 3)"),
    ("cornell_box_original.obj", 1024, 1024, "none", "zbuffer",
     "large triangles (drawn by exact spans)"),
    ("cornell_box_original.obj", 1024, 1024, "none", "hiz", "large triangles, by tiles"),
    ("cornell_box_original.obj", 1024, 1024, "none", "scanline", "large triangles"),
    ("flowers.obj", 1024, 1024, "none", "zbuffer", "polygon mesh (12-gons) as triangles"),
    ("flowers.obj", 1024, 1024, "none", "scanline", "polygon mesh, polygons drawn natively"),
]

# Depth storage per algorithm: one render of this mesh at this size each.
MEMORY_CASE = ("bunny_69k.obj", 4096, 4096)

# Rendering into the caller's arrays (out=) against new arrays each frame.
OUT_CASE = ("bunny_69k.obj", (1024, 2048, 4096))


def bench_out(mesh, size, runs):
    """Median total_ms of depth-only zbuffer renders into new arrays and,
    alternating with them, into the arrays of one earlier result (out=)."""
    camera = zbuffer.Camera.fit(mesh, aspect=1.0).resolve(mesh)
    render = lambda **kw: zbuffer.render(mesh, camera=camera, width=size,  # noqa: E731
                                         height=size, shading="none", **kw)
    kept = render()
    own = (np.empty((size, size), np.float32), np.empty((size, size), np.int32))
    render(out=kept), render(out=own)  # warm up
    fresh, into, into_own = [], [], []
    for _ in range(runs):
        fresh.append(render().stats["total_ms"])
        into.append(render(out=kept).stats["total_ms"])
        into_own.append(render(out=own).stats["total_ms"])
    return {"size": f"{size}x{size}", "new_ms_median": statistics.median(fresh),
            "out_ms_median": statistics.median(into),
            "ratio": statistics.median(into) / statistics.median(fresh),
            "own_ms_median": statistics.median(into_own),
            "own_ratio": statistics.median(into_own) / statistics.median(fresh), "runs": runs}


def bench(mesh, width, height, shading, algo, runs):
    """Median times of `runs` renders; for an algorithm other than zbuffer,
    zbuffer renders alternate with its own (the ratio of the two medians is
    then one of times taken together, not minutes apart), two frames of each
    in turn and the second timed, as common.rounds does."""
    camera = zbuffer.Camera.fit(mesh, aspect=width / height).resolve(mesh)
    render = lambda a: zbuffer.render(mesh, algo=a, camera=camera, width=width,  # noqa: E731
                                      height=height, shading=shading)
    render(algo)  # warm up
    core, total, wall, paired, shade, rendered = [], [], [], [], [], []
    stats = None
    for _ in range(runs):
        if algo != "zbuffer":
            render("zbuffer")
            base = render("zbuffer")
            paired.append(base.stats["render_ms"] + base.stats["shade_ms"])
            render(algo)  # its own arrays back in the caches
        t0 = time.perf_counter()
        res = render(algo)
        wall.append((time.perf_counter() - t0) * 1e3)
        core.append(res.stats["render_ms"] + res.stats["shade_ms"])
        shade.append(res.stats["shade_ms"])
        rendered.append(res.stats["render_ms"])
        total.append(res.stats["total_ms"])
        stats = res.stats
    extra = {"x_zbuffer": statistics.median(core) / statistics.median(paired)} if paired else {}
    return {
        **extra,
        "core_ms_median": statistics.median(core),
        "shade_ms_median": statistics.median(shade),
        "render_ms_median": statistics.median(rendered),
        "total_ms_median": statistics.median(total),
        "wall_ms_median": statistics.median(wall),
        "core_ms_min": min(core),
        "runs": runs,
        "triangles": len(mesh.faces),
        "mtris_per_s": len(mesh.faces) / statistics.median(core) / 1e3,
        "mtris_per_s_total": len(mesh.faces) / statistics.median(total) / 1e3,
        "pixels_covered": stats["pixels_covered"],
        "depth_storage_bytes": stats.get("depth_storage_bytes"),
        "backend": zbuffer._core.RASTER_BACKEND,
    }


def bench_vtk(path: Path, width: int, height: int, runs: int):
    """VTK offscreen depth maps through pyvista (render + get_image_depth), for
    scale: median ms per frame, or None where pyvista cannot render here."""
    try:
        import pyvista as pv

        pv.OFF_SCREEN = True
        mesh = pv.read(str(path))
        plotter = pv.Plotter(off_screen=True, window_size=(width, height))
        plotter.add_mesh(mesh)
        plotter.show(auto_close=False)
        times = []
        for _ in range(runs + 1):
            t0 = time.perf_counter()
            plotter.render()
            plotter.get_image_depth()
            times.append((time.perf_counter() - t0) * 1e3)
        plotter.close()
        return statistics.median(times[1:])
    except Exception as err:  # no OpenGL context on this machine, no pyvista...
        print(f"VTK comparison skipped: {err}", file=sys.stderr)
        return None


def markdown(report: dict) -> str:
    m = report["machine"]
    lines = [
        "# zbuffer.render benchmark",
        "",
        f"- date: {report['date']}",
        f"- machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}",
        f"- commit: {m['commit']}; raster backend: {report['cases'][0].get('backend', '?')}",
        f"- command: `{report['command']}`",
        "- times: median of the runs; *core* is the compiled render call's `render_ms`, plus",
        "  for shaded frames `shade_ms` (the shading call, timed in Python with its image's",
        "  allocation); *total* the whole `zbuffer.render` call from Python. Single thread.",
        "",
        "  *x zbuffer*: median core time over the median core time of plain Z-buffer",
        "  renders of the same mesh, size and shading alternating with this case's (two",
        "  frames of each in turn, the second timed).",
        "",
        "| mesh | size | shading | algo | triangles | core ms | total ms | M tri/s (core) "
        "| M tri/s (total) | x zbuffer | target |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for c in report["cases"]:
        if "skipped" in c:
            lines.append(f"| {c['mesh']} | {c['size']} | {c['shading']} | {c['algo']} | | | | | "
                         f"| | skipped: {c['skipped']} |")
            continue
        ratio = f"{c['x_zbuffer']:.2f}" if c.get("x_zbuffer") else ""
        lines.append(
            f"| {c['mesh']} | {c['size']} | {c['shading']} | {c['algo']} | {c['triangles']:,} | "
            f"{c['core_ms_median']:.3f} | {c['total_ms_median']:.3f} | "
            f"{c['mtris_per_s']:.1f} | {c['mtris_per_s_total']:.1f} | {ratio} | {c['target']} |")
    memory = report.get("depth_storage")
    if memory:
        lines += ["", f"Depth storage while rendering {memory['mesh']} at {memory['size']} "
                  "(`stats['depth_storage_bytes']`: the depth values an algorithm keeps while it "
                  "works; the output arrays come on top for every algorithm), with the core "
                  "time, median of 5 runs after a warm-up:", "",
                  "| algo | depth storage bytes | MiB | core ms |", "|---|---:|---:|---:|"]
        for row in memory["algorithms"]:
            lines.append(f"| {row['algo']} | {row['depth_storage_bytes']:,} | "
                         f"{row['depth_storage_bytes'] / 2**20:.3f} | {row['core_ms']:.1f} |")
    out = report.get("out")
    if out:
        lines += ["", f"Rendering into the caller's arrays (`out=`), {out['mesh']}, depth only, "
                  "`zbuffer`: median `total_ms` of new arrays every frame and, alternating "
                  "with them, of the arrays of one earlier result and of two `np.empty` "
                  "planes of one's own (ratios to new arrays):", "",
                  "| size | new arrays ms | out=result ms | ratio | out=(np.empty, np.empty) ms "
                  "| ratio |", "|---|---:|---:|---:|---:|---:|"]
        for row in out["sizes"]:
            lines.append(f"| {row['size']} | {row['new_ms_median']:.2f} | "
                         f"{row['out_ms_median']:.2f} | {row['ratio']:.2f} | "
                         f"{row['own_ms_median']:.2f} | {row['own_ratio']:.2f} |")
    vtk = [c for c in report["cases"] if c.get("vtk_ms_median")]
    if vtk:
        lines += ["", "Same run, VTK offscreen depth (pyvista `render()` + `get_image_depth()`, "
                  "median of 5 frames; software OpenGL on this machine):", "",
                  "| mesh | size | VTK ms | zbuffer total ms | zbuffer speed-up |",
                  "|---|---|---:|---:|---:|"]
        for c in vtk:
            lines.append(f"| {c['mesh']} | {c['size']} | {c['vtk_ms_median']:.1f} | "
                         f"{c['total_ms_median']:.3f} | {c['vtk_ms_median'] / c['total_ms_median']:.0f}x |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke mode: 3 runs, small images")
    parser.add_argument("--runs", type=int, default=None, help="renders per case (default 21)")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    runs = args.runs or (3 if args.quick else 21)

    report = {**new_report("bench_render.py", argv), "cases": []}
    progress = Progress("render", len(CASES) + len(zbuffer.algorithms()) + len(OUT_CASE[1]))
    for name, width, height, shading, algo, target in CASES:
        if args.quick:
            width, height = width // 4, height // 4
        mesh, label = load_model(name, args.quick)
        case = {"mesh": label, "size": f"{width}x{height}", "shading": shading, "algo": algo,
                "target": target}
        if mesh is None:
            case["skipped"] = f"{MODELS / name} not found"
            progress(f"{name}: skipped, not found")
        else:
            case.update(bench(mesh, width, height, shading, algo, runs))
            if not args.quick and shading == "none" and width >= 1024 and algo == "zbuffer":
                vtk = bench_vtk(MODELS / name, width, height, 5)
                if vtk is not None:
                    case["vtk_ms_median"] = vtk
            progress(f"{label} {width}x{height} {shading} {algo}: "
                     f"core {case['core_ms_median']:.3f} ms, total {case['total_ms_median']:.3f} ms, "
                     f"{case['mtris_per_s']:.1f} Mtri/s")
        report["cases"].append(case)

    name, width, height = MEMORY_CASE
    if args.quick:
        width, height = width // 8, height // 8
    mesh, label = load_model(name, args.quick)
    if mesh is not None:
        rows = []
        camera = zbuffer.Camera.fit(mesh, aspect=width / height).resolve(mesh)
        for algo in zbuffer.algorithms():
            times = []
            for _ in range(1 + (1 if args.quick else 5)):  # a warm-up, then the runs
                res = zbuffer.render(mesh, algo=algo, camera=camera, width=width,
                                     height=height, shading="none")
                times.append(res.stats["render_ms"])
            rows.append({"algo": algo, "depth_storage_bytes": res.stats["depth_storage_bytes"],
                         "core_ms": statistics.median(times[1:])})
            progress(f"{label} {width}x{height} {algo}: depth storage "
                     f"{res.stats['depth_storage_bytes']:,} bytes")
        report["depth_storage"] = {"mesh": label, "size": f"{width}x{height}", "algorithms": rows}

    name, sizes = OUT_CASE
    mesh, label = load_model(name, args.quick)
    if mesh is not None:
        rows = []
        for size in sizes:
            size = size // 8 if args.quick else size
            rows.append(bench_out(mesh, size, 3 if args.quick else 11))
            progress(f"{label} {size}x{size} out=: {rows[-1]['out_ms_median']:.2f} ms against "
                     f"{rows[-1]['new_ms_median']:.2f} ms")
        report["out"] = {"mesh": label, "sizes": rows}

    write_report(out_folder(args), "render", report, markdown(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
