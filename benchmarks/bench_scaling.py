"""How every algorithm scales: with the image size, with the triangle count,
and in memory.

    python benchmarks/bench_scaling.py            # -> benchmarks/results/scaling.{json,md}
    python benchmarks/bench_scaling.py --quick    # smoke mode

- resolution: ``bunny_69k.obj`` framed at 256^2 ... 4096^2;
- triangles: the grid of ``spot.obj`` from one copy (5,856 triangles) to
  5 x 5 x 70 copies (10.2 million), 1024^2, the camera of ``bench_hiz.py``;
- memory: for the largest grid, the peak resident set of a fresh process
  while it renders the grid once with each algorithm, above what it held
  just before (Linux: the peak is reset through /proc/self/clear_refs after
  loading), and the algorithm's own depth storage
  (``stats["depth_storage_bytes"]``).

Times are medians of --runs renders through ``zbuffer.render`` (per frame:
tree algorithms build their tree in the call), one thread, depth only.
Nothing here asserts a speed.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

import zbuffer
from bench_hiz import grid_camera, spot
from common import HERE, MODELS, Progress, add_out_argument, new_report, out_folder, write_report

SIZES = [256, 512, 1024, 2048, 4096]
GRIDS = [(1, 1, 1), (2, 2, 3), (5, 5, 4), (5, 5, 20), (5, 5, 70)]


def median_ms(mesh, camera, algo, size, runs):
    render = lambda: zbuffer.render(mesh, algo=algo, camera=camera, width=size, height=size,
                                    shading="none")
    render()
    # Only the stats are kept: results kept alive would each hold new planes
    # (128 MiB at 4096 x 4096), and the first algorithm timed would pay for
    # memory the process has never touched (~300 ms a frame here, not ~40).
    runs_stats = [render().stats for _ in range(runs)]
    stats = runs_stats[-1]
    return {"ms_median": statistics.median(s["render_ms"] for s in runs_stats),
            "depth_storage_bytes": int(stats["depth_storage_bytes"]),
            "rasterized": int(stats["rasterized"])}


PEAK = r"""
import json, sys
sys.path.insert(0, {here!r})
import zbuffer
from bench_hiz import grid_camera, spot

def status(key):  # kiB, from /proc/self/status
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith(key + ":"))

base, _ = spot({quick})
mesh = zbuffer.scenes.instance_grid(base, {grid})
camera = grid_camera(mesh, "perspective")
mesh.prepare()  # the visiting order, computed before the peak is reset
with open("/proc/self/clear_refs", "w") as fh:  # peak resident set := current (Linux)
    fh.write("5")
before = status("VmRSS")
res = zbuffer.render(mesh, algo={algo!r}, camera=camera, width={size}, height={size}, shading="none")
print(json.dumps({{"before_kib": before, "peak_kib": status("VmHWM"),
                  "depth_storage_bytes": int(res.stats["depth_storage_bytes"])}}))
"""


def peak_memory(grid, algo, size, quick):
    code = PEAK.format(here=str(HERE), quick=quick, grid=grid, algo=algo, size=size)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def markdown(report) -> str:
    m = report["machine"]
    algos = list(dict.fromkeys(c["algo"] for c in report["resolution"]))
    lines = [
        "# Scaling: image size, triangle count, memory",
        "",
        f"- date: {report['date']}",
        f"- machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}",
        f"- commit: {m['commit']}; raster backend: {zbuffer._core.RASTER_BACKEND}",
        f"- command: `{report['command']}`",
        "- ms: median of the runs of `zbuffer.render`'s compiled call, per frame (tree "
        "algorithms build in the call), one thread, depth only.",
        "",
        f"Image size ({report['resolution_mesh']}), ms:",
        "",
        "| size | " + " | ".join(algos) + " |",
        "|---:|" + "---:|" * len(algos),
    ]
    for size in dict.fromkeys(c["size"] for c in report["resolution"]):
        row = {c["algo"]: c for c in report["resolution"] if c["size"] == size}
        lines.append(f"| {size}x{size} | " + " | ".join(f"{row[a]['ms_median']:.1f}" for a in algos) + " |")
    lines += ["", f"Depth storage at the largest size, bytes: " + ", ".join(
        f"{c['algo']} {c['depth_storage_bytes']:,}" for c in report["resolution"]
        if c["size"] == max(d["size"] for d in report["resolution"])), ""]
    lines += [f"Triangle count ({report['grid_mesh']} grid, {report['size']}x{report['size']}), "
              "ms (million triangles per second):", "",
              "| copies | triangles | " + " | ".join(algos) + " |", "|---|---:|" + "---:|" * len(algos)]
    for grid in dict.fromkeys(tuple(c["grid"]) for c in report["triangles"]):
        row = {c["algo"]: c for c in report["triangles"] if tuple(c["grid"]) == grid}
        n = next(iter(row.values()))["triangles"]
        lines.append(f"| {'x'.join(map(str, grid))} | {n:,} | " + " | ".join(
            f"{row[a]['ms_median']:.1f} ({n / row[a]['ms_median'] / 1e3:.0f})" for a in algos) + " |")
    if report.get("memory"):
        g = report["memory"][0]
        lines += ["", f"Memory, {'x'.join(map(str, g['grid']))} grid ({g['triangles']:,} triangles), "
                  f"{report['size']}x{report['size']}: peak resident set of a fresh process while "
                  "rendering, over what it held just before (the mesh loaded), and the "
                  "algorithm's depth storage:", "", "| algorithm | peak RSS added (MiB) | depth storage (MiB) |",
                  "|---|---:|---:|"]
        for c in report["memory"]:
            lines.append(f"| {c['algo']} | {(c['peak_kib'] - c['before_kib']) / 1024:.0f} | "
                         f"{c['depth_storage_bytes'] / 2**20:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke mode: small sizes, 2 runs")
    parser.add_argument("--runs", type=int, default=None, help="renders per case (default 5)")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    runs = args.runs or (2 if args.quick else 5)
    sizes = [64, 128] if args.quick else SIZES
    grids = [(1, 1, 1), (2, 2, 1)] if args.quick else GRIDS
    size = 128 if args.quick else 1024
    algos = zbuffer.algorithms()
    report = {**new_report("bench_scaling.py", argv), "size": size,
              "resolution": [], "triangles": [], "memory": []}
    progress = Progress("scaling", (len(sizes) + len(grids) + 1) * len(algos))

    path = MODELS / "bunny_69k.obj"
    mesh = zbuffer.load(path) if path.is_file() else zbuffer.scenes.default_scene()
    report["resolution_mesh"] = path.name if path.is_file() else "default scene"
    for s in sizes:
        camera = zbuffer.Camera.fit(mesh, aspect=1.0).resolve(mesh)
        for algo in algos:
            report["resolution"].append({"size": s, "algo": algo,
                                         **median_ms(mesh, camera, algo, s, runs)})
            progress(f"{s}x{s} {algo}: {report['resolution'][-1]['ms_median']:.2f} ms")

    base, label = spot(args.quick)
    report["grid_mesh"] = label
    for grid in grids:
        mesh = zbuffer.scenes.instance_grid(base, grid)
        camera = grid_camera(mesh, "perspective")
        for algo in algos:
            case = {"grid": list(grid), "triangles": len(mesh.faces), "algo": algo,
                    **median_ms(mesh, camera, algo, size, runs)}
            report["triangles"].append(case)
            progress(f"grid {'x'.join(map(str, grid))} ({len(mesh.faces):,} triangles) {algo}: "
                     f"{case['ms_median']:.2f} ms")
        del mesh
    for algo in algos:
        peak = peak_memory(grids[-1], algo, size, args.quick)
        report["memory"].append({"grid": list(grids[-1]), "algo": algo,
                                 "triangles": report["triangles"][-1]["triangles"], **peak})
        progress(f"memory {algo}: +{(peak['peak_kib'] - peak['before_kib']) / 1024:.0f} MiB peak")

    write_report(out_folder(args), "scaling", report, markdown(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
