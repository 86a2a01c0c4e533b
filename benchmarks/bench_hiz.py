"""The hierarchical Z-buffer family on the 5 x 5 x N grid of spot.obj.

    python benchmarks/bench_hiz.py            # full run -> benchmarks/results/hiz.{json,md}
    python benchmarks/bench_hiz.py --quick    # CI smoke mode: tiny grids and images, 3 runs

The scene of the course report that first ran these algorithms (issue 4):
5 x 5 x N copies of ``spot.obj`` (5,856 triangles each), boxes 10% apart
(``zbuffer.scenes.instance_grid``), the camera on the grid's axis in front
of it looking down the long axis (perspective: 50 degrees, from 1.2 grid
widths in front of the first layer; orthographic: the same axis, a view
1.1 grid widths high), 1024 x 1024, depth only, one thread.

Per case, the median of --runs renders after a warm-up:

- per frame: ``zbuffer.render`` -- the tree algorithms build their tree in
  the call (``build_ms`` is part of the time);
- built once: ``zbuffer.Scene`` -- the tree is built once (build time
  reported apart), then every frame only renders.

On each grid and camera (and each single mesh), the cases render in
interleaved rounds -- each in turn, --runs times, twice in a row with the
second frame timed (common.rounds) -- so that ratios to ``zbuffer`` are of
times measured side by side, each with its own data in the caches. Also: the octree's
three rules for placing triangles, a leaf-size sweep, and temporal coherence over
an orbit. Nothing here asserts a speed.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time

import numpy as np

import zbuffer
from common import MODELS, Progress, add_out_argument, new_report, out_folder, rounds, write_report

ALGOS = ["zbuffer", "hiz", "hiz_octree", "hiz_bvh"]
TREES = ["hiz_octree", "hiz_bvh"]


def spot(quick: bool):
    path = MODELS / "spot.obj"
    if path.is_file():
        return zbuffer.load(path), "spot.obj"
    if not quick:
        raise SystemExit(f"{path} not found: the full benchmark needs the shared models")
    return zbuffer.scenes.default_scene(), "default scene (spot.obj missing)"


def grid_camera(mesh, projection: str) -> zbuffer.Camera:
    v = mesh.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre = (lo + hi) / 2
    width = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    eye = (centre[0], centre[1], hi[2] + 1.2 * width)
    target = (centre[0], centre[1], hi[2] - 1.0)
    return zbuffer.Camera.look_at(eye, target, fov_y=50, projection=projection,
                                  ortho_height=1.1 * width).resolve(mesh)


COUNTERS = ("rasterized", "culled_hidden", "culled_in_nodes", "nodes_visited", "nodes_hidden",
            "nodes_outside", "pyramid_cells_updated", "pixels_tested")


def summary(times, stats, triangles):
    out = {"ms_median": statistics.median(times), "ms_min": min(times), "ms_max": max(times),
           "runs": len(times), "times_ms": times}
    out.update({k: int(stats[k]) for k in COUNTERS})
    out["cull_ratio"] = 1.0 - stats["rasterized"] / triangles
    for key in ("build_ms", "traversal_ms", "vertex_ms", "raster_ms", "pyramid_ms"):
        out[key] = stats[key]
    return out


def tree_fields(scene, algo, build_wall_ms) -> dict:
    """A built tree's entries in a case: build times (the core's and the
    wall clock's), nodes and bytes."""
    info = scene.tree_info(algo)
    return {"build_ms": info["build_ms"], "build_wall_ms": build_wall_ms,
            "tree_nodes": info["nodes"], "tree_bytes": info["memory_bytes"]}


def build_trees(mesh):
    """A Scene of ``mesh`` with both trees built, and each build's wall-clock
    time (ms) by algorithm."""
    scene, wall_ms = zbuffer.Scene(mesh), {}
    for algo in TREES:
        t0 = time.perf_counter()
        scene.build(algo)
        wall_ms[algo] = (time.perf_counter() - t0) * 1e3
    return scene, wall_ms


def interleaved(mesh, camera, trees, size, runs) -> list:
    """Every algorithm per frame (``zbuffer.render``, trees built in the
    call) and every tree of ``trees`` (build_trees) built once, on one mesh and camera, in
    rounds (common.rounds: each case in turn renders twice, the second frame
    timed), so that the machine's drift hits them all alike and the ratios
    to ``zbuffer`` compare like with like. One summary per case."""
    scene, wall_ms = trees
    cases = [("per frame", algo) for algo in ALGOS] + [("built once", algo) for algo in TREES]

    def render(mode, algo):
        if mode == "per frame":
            return zbuffer.render(mesh, algo=algo, camera=camera, width=size, height=size,
                                  shading="none")
        return scene.render(camera, algo=algo, width=size, height=size, shading="none")

    times, last = rounds(cases, lambda case: render(*case), runs)
    out = []
    for mode, algo in cases:
        c = {"algo": algo, "mode": mode,
             **summary(times[mode, algo], last[mode, algo].stats, len(mesh.faces))}
        if mode == "built once":
            c.update(tree_fields(scene, algo, wall_ms[algo]))
        out.append(c)
    return out


def built_once(mesh, camera, algo, size, runs, **options):
    scene = zbuffer.Scene(mesh, **options)
    t0 = time.perf_counter()
    scene.build(algo)
    build_wall = (time.perf_counter() - t0) * 1e3
    scene.render(camera, algo=algo, width=size, height=size, shading="none")  # warm-up
    times, res = [], None
    for _ in range(runs):
        res = scene.render(camera, algo=algo, width=size, height=size, shading="none")
        times.append(res.stats["render_ms"])
    return {**summary(times, res.stats, len(mesh.faces)), **tree_fields(scene, algo, build_wall)}


def submission_order(detail, occluder, size, runs):
    """Every algorithm on an occluder (a copy of `occluder` scaled to hide
    most of `detail`, in front of it) plus `detail`, with the occluder's
    faces listed first or last."""
    from zbuffer import _core

    lo, hi = detail.vertices.min(axis=0), detail.vertices.max(axis=0)
    olo, ohi = occluder.vertices.min(axis=0), occluder.vertices.max(axis=0)
    # Wider and taller than the detailed mesh, just in front of it; the
    # camera frames the detailed mesh, from the occluder's side.
    scale = 1.3 * float(((hi - lo)[:2] / (ohi - olo)[:2]).max())
    cover = (occluder.vertices - (olo + ohi) / 2) * scale
    cover += np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2] - cover[:, 2].min()
                       + 0.05 * float((hi - lo).max())])
    camera = zbuffer.Camera.fit(detail, aspect=1.0)
    n = len(detail.vertices)
    orders = {
        "front to back": (np.vstack([cover, detail.vertices]),
                          np.vstack([occluder.faces, detail.faces + len(cover)])),
        "back to front": (np.vstack([detail.vertices, cover]),
                          np.vstack([detail.faces, occluder.faces + n])),
    }
    rows = []
    for order, (v, f) in orders.items():
        mesh = zbuffer.Mesh(v, f)
        mvp = camera.resolve(mesh).mvp(size, size)
        faces = np.ascontiguousarray(mesh.faces)
        for algo in zbuffer.algorithms():
            _core.render(mesh.vertices, faces, mvp, size, size, algo)  # warm-up
            stats = [_core.render(mesh.vertices, faces, mvp, size, size, algo)[2] for _ in range(runs)]
            times = [s["render_ms"] for s in stats]
            rows.append({"order": order, "algo": algo, "triangles": len(f),
                         "ms_median": statistics.median(times), "ms_min": min(times),
                         "ms_max": max(times), "rasterized": int(stats[-1]["rasterized"]),
                         "culled_hidden": int(stats[-1]["culled_hidden"]),
                         "culled_in_nodes": int(stats[-1]["culled_in_nodes"])})
    return rows


def orbit(mesh, algo, size, frames):
    """Frames per second over a circular orbit around the grid's front,
    without and with temporal coherence: a scene for each, the two renders
    of each camera one after the other (which goes first alternating), so
    that the machine's drift weighs on both alike. Also the median over the
    frames of the ratio of the two render times."""
    v = mesh.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre = (lo + hi) / 2
    width = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    target = np.array([centre[0], centre[1], hi[2] - 1.0])
    scenes = {False: zbuffer.Scene(mesh), True: zbuffer.Scene(mesh)}
    for scene in scenes.values():
        scene.build(algo)
    times = {False: [], True: []}
    for k in range(frames):
        a = 2 * math.pi * k / frames
        eye = target + np.array([0.35 * width * math.sin(a), 0.35 * width * math.cos(a),
                                 1.2 * width + 1.0])
        cam = zbuffer.Camera.look_at(eye, target, fov_y=50).resolve(mesh)
        for temporal in ((False, True) if k % 2 else (True, False)):
            res = scenes[temporal].render(cam, algo=algo, width=size, height=size,
                                          shading="none", temporal=temporal)
            times[temporal].append(res.stats["render_ms"])
    out = {key: {"fps": 1e3 * frames / sum(times[t]), "ms_median": statistics.median(times[t]),
                 "ms_total": sum(times[t])}
           for key, t in (("without", False), ("with", True))}
    # (the first frame has no frame before it to draw first)
    out["ratio_median"] = statistics.median(
        b / a for a, b in zip(times[False][1:], times[True][1:]))
    return out


def markdown(report: dict) -> str:
    m = report["machine"]
    lines = [
        "# Hierarchical Z-buffer benchmark: the 5 x 5 x N spot grid",
        "",
        f"- date: {report['date']}",
        f"- machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}",
        f"- commit: {m['commit']}; raster backend: {zbuffer._core.RASTER_BACKEND}",
        f"- command: `{report['command']}`",
        f"- scene: {report['scene']}; {report['size']}x{report['size']}, depth only, one thread",
        "- ms: median of the runs of the compiled call (`render_ms`); *x zbuffer*: that median",
        "  over `zbuffer`'s in the same interleaved rounds, each case's second frame in a row",
        "  timed (below 1 is faster). Per frame:",
        "  `zbuffer.render`, tree built in the call. Built once: `zbuffer.Scene`, build time",
        "  apart.",
        "",
        "| N | triangles | projection | algorithm | mode | ms | x zbuffer | build ms "
        "| rasterized | culled by triangle test | in culled nodes | cull ratio "
        "| nodes visited / hidden | pyramid cells updated | pyramid ms |",
        "|---:|---:|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|",
    ]
    for c in report["grid"]:
        base = next(d for d in report["grid"] if d["N"] == c["N"]
                    and d["projection"] == c["projection"] and d["algo"] == "zbuffer"
                    and d["mode"] == "per frame")
        ratio = c["ms_median"] / base["ms_median"]
        nodes = f"{c['nodes_visited']:,} / {c['nodes_hidden']:,}" if c["algo"] in TREES else ""
        build = f"{c['build_ms']:.0f}" if c["algo"] in TREES else ""
        lines.append(
            f"| {c['N']} | {c['triangles']:,} | {c['projection']} | {c['algo']} | {c['mode']} | "
            f"{c['ms_median']:.1f} | {ratio:.2f} | {build} | {c['rasterized']:,} | "
            f"{c['culled_hidden']:,} | {c['culled_in_nodes']:,} | {c['cull_ratio']:.1%} | {nodes} | "
            + (f"{c['pyramid_cells_updated']:,} | {c['pyramid_ms']:.1f} |" if c["algo"] != "zbuffer"
               else " | |"))
    if report.get("unoccluded"):
        lines += ["", "Single unoccluded meshes (camera framing the mesh), same size, x zbuffer "
                  "per frame in the same run:", "",
                  "| mesh | algorithm | mode | ms | x zbuffer | rasterized | cull ratio "
                  "| pyramid cells updated | pyramid ms |",
                  "|---|---|---|---:|---:|---:|---:|---:|---:|"]
        for c in report["unoccluded"]:
            base = next(d for d in report["unoccluded"] if d["mesh"] == c["mesh"]
                        and d["algo"] == "zbuffer")
            pyramid = (f"{c['pyramid_cells_updated']:,} | {c['pyramid_ms']:.2f}"
                       if c["algo"] != "zbuffer" else " | ")
            lines.append(f"| {c['mesh']} | {c['algo']} | {c['mode']} | {c['ms_median']:.2f} | "
                         f"{c['ms_median'] / base['ms_median']:.2f} | {c['rasterized']:,} | "
                         f"{c['cull_ratio']:.1%} | {pyramid} |")
    lines += ["", "Output sensitivity (built once): time at the largest N over time at the "
              "smallest:", ""]
    for projection in ("perspective", "orthographic"):
        for algo in TREES:
            rows = [c for c in report["grid"] if c["algo"] == algo and c["mode"] == "built once"
                    and c["projection"] == projection]
            if len(rows) >= 2:
                lines.append(f"- {algo}, {projection}: N={rows[-1]['N']} / N={rows[0]['N']} = "
                             f"{rows[-1]['ms_median'] / rows[0]['ms_median']:.2f}")
    if report.get("order"):
        c0 = report["order"][0]
        lines += ["", f"Submission order: a scaled spot.obj in front of bunny_69k.obj "
                  f"({c0['triangles']:,} triangles), its faces listed first (front to back) "
                  "or last (back to front), faces handed to the core in that order:", "",
                  "| algorithm | front to back ms | back to front ms | rasterized (f2b / b2f) |",
                  "|---|---:|---:|---|"]
        for algo in dict.fromkeys(c["algo"] for c in report["order"]):
            f2b = next(c for c in report["order"] if c["algo"] == algo and c["order"] == "front to back")
            b2f = next(c for c in report["order"] if c["algo"] == algo and c["order"] == "back to front")
            lines.append(f"| {algo} | {f2b['ms_median']:.2f} | {b2f['ms_median']:.2f} | "
                         f"{f2b['rasterized']:,} / {b2f['rasterized']:,} |")
    if report.get("rules"):
        lines += ["", f"Octree rule (built once, N={report['rules'][0]['N']}, "
                  "perspective):", "", "| rule | build ms | render ms | references / faces |",
                  "|---|---:|---:|---:|"]
        for r in report["rules"]:
            lines.append(f"| {r['rule']} | {r['build_ms']:.0f} | {r['ms_median']:.1f} | "
                         f"{r['references_per_face']:.2f} |")
    if report.get("leaves"):
        lines += ["", f"Leaf size (built once, N={report['leaves'][0]['N']}, perspective):", "",
                  "| algorithm | leaf size | build ms | render ms | nodes | rasterized | cull ratio |",
                  "|---|---:|---:|---:|---:|---:|---:|"]
        for r in report["leaves"]:
            lines.append(f"| {r['algo']} | {r['leaf_size']} | {r['build_ms']:.0f} | "
                         f"{r['ms_median']:.1f} | {r['tree_nodes']:,} | {r['rasterized']:,} | "
                         f"{r['cull_ratio']:.1%} |")
    if report.get("temporal"):
        t = report["temporal"]
        lines += ["", f"Temporal coherence, `hiz_octree` built once, {t['frames']}-frame orbit of "
                  f"the N={t['N']} grid (perspective), the two alternating camera by camera; "
                  "*x without*: median over the frames of the ratio of the two times:", "",
                  "| temporal | frames/s | median ms | x without |", "|---|---:|---:|---:|"]
        for key in ("without", "with"):
            ratio = f"{t['ratio_median']:.2f}" if key == "with" and "ratio_median" in t else ""
            lines.append(f"| {key} | {t[key]['fps']:.1f} | {t[key]['ms_median']:.1f} | {ratio} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke mode: tiny grids, 3 runs")
    parser.add_argument("--runs", type=int, default=None, help="renders per case (default 7)")
    parser.add_argument("--grid", type=int, nargs="*", default=None,
                        help="values of N (default 10 20 40 80)")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    runs = args.runs or (3 if args.quick else 7)
    sizes = args.grid or ([1, 2] if args.quick else [10, 20, 40, 80])
    size = 128 if args.quick else 1024
    base, label = spot(args.quick)

    unoccluded = ["bunny_69k.obj"] if args.quick else ["bunny_69k.obj", "armadillo_86k.obj"]
    leaves = [8, 128] if args.quick else [8, 16, 32, 64, 128, 256, 512, 1024]
    report = {**new_report("bench_hiz.py", argv),
              "scene": f"5 x 5 x N copies of {label}", "size": size, "grid": []}
    progress = Progress("hiz", len(sizes) * 2 * (len(ALGOS) + len(TREES))
                        + len(unoccluded) * (len(ALGOS) + len(TREES)) + 1 + 2
                        + len(TREES) * len(leaves) + 2)

    def record(case):
        report["grid"].append(case)
        progress(f"N={case['N']} {case['projection']} {case['algo']} {case['mode']}: "
                 f"{case['ms_median']:.2f} ms, build {case.get('build_ms', 0):.1f} ms, "
                 f"rasterized {case['rasterized']:,}")

    for n in sizes:
        mesh = zbuffer.scenes.instance_grid(base, (5, 5, n))
        trees = build_trees(mesh)  # (one Scene for both projections: trees do not depend on the camera)
        for projection in ("perspective", "orthographic"):
            camera = grid_camera(mesh, projection)
            common = {"N": n, "triangles": len(mesh.faces), "projection": projection}
            for case in interleaved(mesh, camera, trees, size, runs):
                record({**common, **case})
        del mesh, trees

    # Single meshes: only a mesh's own back is hidden, what the hierarchy costs shows.
    report["unoccluded"] = []
    for name in unoccluded:
        path = MODELS / name
        if not path.is_file():
            for _ in range(len(ALGOS) + len(TREES)):
                progress(f"{name} not found: unoccluded case skipped")
            continue
        single = zbuffer.load(path)
        camera = zbuffer.Camera.fit(single, aspect=1.0).resolve(single)
        for case in interleaved(single, camera, build_trees(single), size, runs * 3):
            report["unoccluded"].append({"mesh": name, **case})
        for c in report["unoccluded"][-(len(ALGOS) + len(TREES)):]:
            progress(f"{name} {c['algo']} {c['mode']}: {c['ms_median']:.2f} ms")

    # Submission order: a big occluder in front of a detailed mesh, listed
    # first (front to back) or last (back to front). Faces go to the core in
    # the order given (below zbuffer.render, which would visit a large mesh
    # in its cached spatial order instead).
    report["order"] = []
    if (MODELS / "bunny_69k.obj").is_file() or args.quick:
        detail = zbuffer.load(MODELS / "bunny_69k.obj") if (MODELS / "bunny_69k.obj").is_file() \
            else zbuffer.scenes.random_soup(3000, seed=1)
        report["order"] = submission_order(detail, base, size, runs * 3)
    progress("submission order: " + ", ".join(
        f"{c['algo']} {c['order']} {c['ms_median']:.2f} ms" for c in report["order"]))

    # The octree's rules, and leaf sizes, on one grid.
    n_rules = sizes[0]
    mesh = zbuffer.scenes.instance_grid(base, (5, 5, n_rules))
    camera = grid_camera(mesh, "perspective")
    report["rules"] = []
    for rule in zbuffer.scene.OCTREE_RULES:
        r = built_once(mesh, camera, "hiz_octree", size, runs, octree_rule=rule)
        scene = zbuffer.Scene(mesh, octree_rule=rule)
        r.update({"N": n_rules, "rule": rule,
                  "references_per_face": scene.tree_info()["references"] / len(mesh.faces)})
        report["rules"].append(r)
        progress(f"rule {rule}: build {r['build_ms']:.0f} ms, render {r['ms_median']:.1f} ms")
    report["leaves"] = []
    for algo in TREES:
        for leaf in leaves:
            r = built_once(mesh, camera, algo, size, runs, leaf_size=leaf)
            r.update({"N": n_rules, "algo": algo, "leaf_size": leaf})
            report["leaves"].append(r)
            progress(f"{algo} leaf {leaf}: build {r['build_ms']:.0f} ms, render {r['ms_median']:.1f} ms")

    # Temporal coherence over an orbit.
    n_orbit = 2 if args.quick else 20
    frames = 6 if args.quick else 60
    mesh = zbuffer.scenes.instance_grid(base, (5, 5, n_orbit))
    report["temporal"] = {"N": n_orbit, "frames": frames, **orbit(mesh, "hiz_octree", size, frames)}
    t = report["temporal"]
    progress(f"orbit of N={n_orbit}: {t['without']['fps']:.1f} fps without temporal coherence, "
             f"{t['with']['fps']:.1f} with ({t['ratio_median']:.2f}x the time)")

    write_report(out_folder(args), "hiz", report, markdown(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
