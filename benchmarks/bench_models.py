"""Models x algorithms: every algorithm on the shared models, at the course
implementations' size and at 1024 x 1024, back-face culling off and on.

    python benchmarks/bench_models.py            # -> benchmarks/results/models.{json,md}
    python benchmarks/bench_models.py --quick    # smoke mode: quarter-size images, 2 rounds

Per model, size and culling setting, every algorithm renders the loaded mesh
(``zbuffer.render``, camera framing the mesh, depth only, one thread) in
rounds: one warm-up render each, then --runs rounds in which each algorithm
in turn renders twice and the second frame is timed, so that the machine's
drift hits all of them alike and each is timed with its own data in the
caches (common.rounds).
Times are the compiled call's ``render_ms`` (the tree algorithms build their
tree in the call, as a user of ``zbuffer.render`` pays); the table gives
medians and each algorithm's ratio to ``zbuffer`` in the same rounds; the
JSON keeps every repeat. Models that are not in ``../shared/models`` are
recorded as skipped. Nothing here asserts a speed.
"""

from __future__ import annotations

import argparse
import statistics
import sys

import zbuffer
from common import MODELS, Progress, add_out_argument, new_report, out_folder, rounds, write_report

MODELS_LIST = ["cube.obj", "diablo3_pose.obj", "bunny_10k.obj", "knob_4k.obj", "spot.obj",
               "teapot_6k.obj", "dragon_20k.obj", "lucy_20k.obj", "venus_43k.obj",
               "bunny_69k.obj", "armadillo_86k.obj"]
SIZES = [(666, 500), (1024, 1024)]


def measure(mesh, width, height, cull, algos, runs):
    """{algo: case} for one model, size and culling setting, interleaved."""
    camera = zbuffer.Camera.fit(mesh, aspect=width / height).resolve(mesh)

    def render(algo):
        return zbuffer.render(mesh, algo=algo, camera=camera, width=width, height=height,
                              shading="none", cull_backfaces=cull)

    times, last = rounds(algos, render, runs)
    cases = {}
    for algo in algos:
        t, stats = times[algo], last[algo].stats
        median = statistics.median(t)
        cases[algo] = {
            "ms_median": median, "ms_min": min(t), "ms_max": max(t), "times_ms": t,
            "x_zbuffer": median / statistics.median(times["zbuffer"]),
            "mtris_per_s": len(mesh.faces) / median / 1e3,
            "rasterized": int(stats["rasterized"]),
            "culled_backface": int(stats["culled_backface"]),
            "culled_hidden": int(stats["culled_hidden"]),
            "culled_in_nodes": int(stats["culled_in_nodes"]),
            "build_ms": stats["build_ms"],
        }
    return cases


def markdown(report: dict) -> str:
    m = report["machine"]
    algos = report["algorithms"]
    lines = [
        "# Models x algorithms",
        "",
        f"- date: {report['date']}",
        f"- machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}",
        f"- commit: {m['commit']}; raster backend: {m['raster_backend']}",
        f"- command: `{report['command']}`",
        f"- each cell: median `render_ms` of {report['runs']} interleaved rounds (ms; each "
        "algorithm's second frame in a row timed), and in "
        "brackets its ratio to `zbuffer` in the same rounds; one thread, depth only, camera "
        "framing the mesh; tree algorithms build their tree in the call. *M tri/s*: input "
        "triangles per second of `zbuffer`. *drawn*: triangles rasterized by `zbuffer` and by "
        "`hiz_bvh` (the rest culled: back faces, hidden triangles or nodes).",
        "",
        "| model | triangles | size | cull | " + " | ".join(algos) + " | M tri/s | drawn |",
        "|---|---:|---|---|" + "---:|" * len(algos) + "---:|---|",
    ]
    for c in report["cases"]:
        if "skipped" in c:
            lines.append(f"| {c['model']} | | {c['size']} | {c['cull']} | "
                         + " | ".join("" for _ in algos) + f" | | skipped: {c['skipped']} |")
            continue
        a = c["algorithms"]
        cells = [f"{a[x]['ms_median']:.2f} ({a[x]['x_zbuffer']:.2f})" for x in algos]
        drawn = f"{a['zbuffer']['rasterized']:,}"
        if "hiz_bvh" in a:
            drawn += f" / {a['hiz_bvh']['rasterized']:,}"
        lines.append(f"| {c['model']} | {c['triangles']:,} | {c['size']} | "
                     f"{'on' if c['cull'] else 'off'} | " + " | ".join(cells)
                     + f" | {a['zbuffer']['mtris_per_s']:.1f} | {drawn} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke mode: quarter-size images, 2 rounds")
    parser.add_argument("--runs", type=int, default=None, help="rounds per case (default 11)")
    parser.add_argument("--models", nargs="*", default=None, help=f"model files (default: {' '.join(MODELS_LIST)})")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    runs = args.runs or (2 if args.quick else 11)
    names = args.models or MODELS_LIST
    sizes = [(w // 4, h // 4) for w, h in SIZES] if args.quick else SIZES
    algos = zbuffer.algorithms()
    report = {**new_report("bench_models.py", argv), "runs": runs, "algorithms": algos, "cases": []}
    progress = Progress("models", len(names) * len(sizes) * 2)
    for name in names:
        path = MODELS / name
        mesh = zbuffer.load(path) if path.is_file() else None
        for width, height in sizes:
            for cull in (False, True):
                case = {"model": name, "size": f"{width}x{height}", "cull": cull}
                if mesh is None:
                    case["skipped"] = f"{path} not found"
                    progress(f"{name}: skipped, not found")
                else:
                    case["triangles"] = len(mesh.faces)
                    case["algorithms"] = measure(mesh, width, height, cull, algos, runs)
                    progress(f"{name} {width}x{height} cull {'on' if cull else 'off'}: " + ", ".join(
                        f"{x} {c['ms_median']:.2f} ms" for x, c in case["algorithms"].items()))
                report["cases"].append(case)
    write_report(out_folder(args), "models", report, markdown(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
