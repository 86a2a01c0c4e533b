"""What each suite's numbers mean, and where each speed target named in the
issues stands, read from a run's JSON (never typed in by hand).

`paragraph(name, report, quick)` returns the markdown paragraph that
`run.py` puts above a suite's tables in RESULTS.md.
"""

from __future__ import annotations

import statistics

MEANING = {
    "models": "Every algorithm on each shared model, per frame through `zbuffer.render` "
              "(the tree algorithms build their tree in the call), culling off and on, "
              "measured in interleaved rounds so that the ratios to `zbuffer` compare like "
              "with like. A single mesh hides only its own back: `hiz`, visiting its cells "
              "nearest first, culls much of that; the tree algorithms, building a tree "
              "every frame, mostly pay for their bookkeeping here.",
    "render": "The foundation's cases: the plain Z-buffer's frame time on the course size "
              "and its triangle rate on the large scans, shaded frames for reference, the "
              "scanline's and HiZ's time as ratios to the plain Z-buffer in the same run, "
              "and each algorithm's depth storage at 4096 x 4096.",
    "hiz": "The 5 x 5 x N grid of spot.obj, camera down the long axis: occlusion grows "
           "with N. Per frame includes the tree build; built once is `zbuffer.Scene`. The "
           "cull ratio is the share of input triangles never rasterized.",
    "scaling": "Time against image size and triangle count, and the peak memory of a fresh "
               "process rendering the largest grid once with each algorithm.",
    "peers": "The tools people use instead, on the same meshes, camera and pixels, with the "
             "agreement of their depth maps and ours (a fast wrong answer is no answer).",
    "load": "Reading mesh files: `zbuffer.load` against `trimesh.load`, the OBJ and OFF "
            "readers' compiled fast paths against the Python readers they stand in for, and "
            "`read_ply` of ASCII files with and without its fast path. No issue names a "
            "target here.",
}


def verdict(ok: bool, text: str) -> str:
    return f"- **{'met' if ok else 'not met'}**: {text}"


def _render(report):
    lines = []
    cases = [c for c in report.get("cases", []) if "skipped" not in c]

    def find(mesh, algo, shading="none"):
        return next((c for c in cases if c["mesh"] == mesh and c["algo"] == algo
                     and c["shading"] == shading), None)

    c = find("bunny_10k.obj", "zbuffer")
    if c:
        ms = c["core_ms_median"]
        lines.append(verdict(ms <= 0.30, f"bunny_10k.obj at {c['size']}, depth only: "
                             f"{ms:.3f} ms per frame against the 0.30 ms target "
                             f"({ms / 0.30:.2f}x the target; issue 2)."))
    for mesh in ("bunny_69k.obj", "armadillo_86k.obj"):
        c = find(mesh, "zbuffer")
        if c:
            lines.append(verdict(c["mtris_per_s"] >= 30, f"{mesh} at {c['size']}: "
                                 f"{c['mtris_per_s']:.1f} M triangles/s against 30 (issue 2)."))
    for shading in ("flat", "smooth"):
        c = find("bunny_69k.obj", "zbuffer", shading)
        if c and c.get("shade_ms_median") is not None:
            shade = c["shade_ms_median"]
            # (the render's own median where recorded; older reports: the difference)
            render = c.get("render_ms_median", c["core_ms_median"] - shade)
            text = (f"`shading=\"{shading}\"` on bunny_69k.obj at {c['size']}: the shading pass "
                    f"takes {shade:.2f} ms of the frame's {c['core_ms_median']:.2f} ms "
                    f"({shade / c['core_ms_median']:.0%}; the render {render:.2f} ms)")
            lines.append(verdict(shade <= render, text + "; issue 2: shading never dominates "
                                 "a frame."))
    for algo, limit, issue in (("scanline", 1.5, 3), ("hiz", 1.25, 4)):
        for mesh in ("bunny_69k.obj", "armadillo_86k.obj"):
            c = find(mesh, algo)
            if c and c.get("x_zbuffer"):
                lines.append(verdict(c["x_zbuffer"] <= limit, f"`{algo}` on {mesh}: "
                                     f"{c['x_zbuffer']:.2f}x the plain Z-buffer's time, target "
                                     f"<= {limit}x (issue {issue})."))
    memory = report.get("depth_storage")
    if memory:
        rows = {r["algo"]: r["depth_storage_bytes"] for r in memory["algorithms"]}
        if "scanline" in rows and "zbuffer" in rows:
            width = int(memory["size"].split("x")[0])
            lines.append(verdict(rows["scanline"] <= 64 * width,
                                 f"scanline depth storage at {memory['size']}: "
                                 f"{rows['scanline']:,} bytes (one row: O(width)), against "
                                 f"{rows['zbuffer']:,} for the plain Z-buffer (issue 3)."))
    return lines


def _models(report):
    lines = []
    algos = [a for a in report.get("algorithms", []) if a != "zbuffer"]
    for size in dict.fromkeys(c["size"] for c in report.get("cases", [])):
        for cull in (False, True):
            rows = [c for c in report["cases"] if c["size"] == size and c["cull"] == cull
                    and "algorithms" in c]
            if not rows:
                continue
            ratios = ", ".join(
                f"`{a}` {statistics.median(c['algorithms'][a]['x_zbuffer'] for c in rows):.2f}x"
                for a in algos)
            lines.append(f"- {size}, culling {'on' if cull else 'off'}, median over "
                         f"{len(rows)} models of the time as a multiple of `zbuffer`'s: {ratios}.")
    return lines


def _hiz(report):
    lines = []
    grid = report.get("grid", [])

    def case(n, projection, algo, mode):
        return next((c for c in grid if c["N"] == n and c["projection"] == projection
                     and c["algo"] == algo and c["mode"] == mode), None)

    ns = sorted({c["N"] for c in grid})
    if not ns:
        return lines
    top, low = 80, 10  # (issue 4's built-once targets are at N = 80, against N = 10)
    if top not in ns or low not in ns:
        lines.append(f"- **not judged**: issue 4's built-once targets (N = 80, and N = 80 "
                     f"against N = 10): this run has N = {', '.join(map(str, ns))}.")
    # Issue 4 runs the grid in both projections; its built-once targets are
    # checked in both (in orthographic view the copies' silhouettes coincide:
    # benchmarks/README.md says why few nodes are hidden whole there). They
    # name `hiz_octree`; the BVH's figures are given beside them, unjudged.
    for projection in ("perspective", "orthographic"):
        base = case(top, projection, "zbuffer", "per frame")
        for algo in ("hiz_octree", "hiz_bvh"):
            c = case(top, projection, algo, "built once")
            if c and base:
                speedup = base["ms_median"] / c["ms_median"]
                text = (f"`{algo}` built once, N={top}, {projection}: {speedup:.1f}x faster "
                        "than `zbuffer`")
                lines.append(verdict(speedup >= 5, text + " (target >= 5x; issue 4).")
                             if algo == "hiz_octree" else
                             f"- {text} (issue 4 sets no target for the BVH).")
            c0 = case(low, projection, algo, "built once")
            if c and c0 and algo == "hiz_octree":
                growth = c["ms_median"] / c0["ms_median"]
                lines.append(verdict(growth <= 2, f"output sensitivity of `{algo}`, {projection}: "
                                     f"time at N={top} is {growth:.2f}x its time at N={low} "
                                     f"({top // low}x the triangles; target <= 2x; issue 4)."))
    for projection in ("perspective", "orthographic"):
        for n in [n for n in ns if n >= 20]:
            zb = case(n, projection, "zbuffer", "per frame")
            for algo in ("hiz_octree", "hiz_bvh"):
                c = case(n, projection, algo, "per frame")
                if c and zb:
                    ratio = c["ms_median"] / zb["ms_median"]
                    lines.append(verdict(ratio <= 1.0, f"`{algo}` built per frame, N={n}, "
                                         f"{projection}: {ratio:.2f}x `zbuffer`'s time (target "
                                         "no slower from N = 20; issue 4)."))
    for mesh in dict.fromkeys(c["mesh"] for c in report.get("unoccluded", [])):
        rows = [c for c in report["unoccluded"] if c["mesh"] == mesh]
        zb = next(c for c in rows if c["algo"] == "zbuffer")
        worst = max((c for c in rows if c["algo"] != "zbuffer"),
                    key=lambda c: c["ms_median"] / zb["ms_median"])
        ratio = worst["ms_median"] / zb["ms_median"]
        lines.append(verdict(ratio <= 1.25, f"unoccluded {mesh}: the slowest hierarchical "
                             f"variant (`{worst['algo']}`, {worst['mode']}) takes {ratio:.2f}x "
                             "`zbuffer`'s time (target <= 1.25x for every one; issue 4)."))
    t = report.get("temporal")
    if t:
        lines.append(f"- temporal coherence over a {t['frames']}-frame orbit of the N={t['N']} "
                     f"grid: {t['with']['fps']:.1f} frames/s with, {t['without']['fps']:.1f} "
                     "without" + (f" ({t['ratio_median']:.2f}x the time, frame by frame)"
                                  if "ratio_median" in t else "")
                     + " (issue 4 asks for the numbers, not a target).")
    return lines


def _peers(report):
    lines = []
    for c in report.get("cases", []):
        o = c.get("open3d")
        if not o or c["projection"] != "perspective" or not c["scene"].startswith("5x5x"):
            continue
        frame = o["frame_ms_threads_1"] / c["hiz_octree_built_once_ms"]
        build = o["build_ms"] / c["hiz_octree_build_ms"]
        lines.append(verdict(frame > 1 and build >= 10,
                             f"{c['scene']}, perspective: `hiz_octree` built once renders "
                             f"{frame:.1f}x faster than Open3D on one thread and builds "
                             f"{build:.1f}x faster (targets: faster, and >= 10x; issue 4)."))
    if not any(c.get("open3d") for c in report.get("cases", [])):
        lines.append("- Open3D was not installed for this run: its targets are not judged.")
    return lines


JUDGES = {"render": _render, "models": _models, "hiz": _hiz, "peers": _peers}


def paragraph(name: str, report: dict, quick: bool) -> str:
    """What suite `name` measures and, for a full run, where its targets stand."""
    text = [MEANING.get(name, "")]
    if quick:
        text += ["", "*Smoke run (`--quick`): small inputs and few repeats; the targets "
                 "are judged on full runs only.*"]
    elif name in JUDGES:
        lines = JUDGES[name](report)
        if lines:
            text += ["", "Where the targets stand in this run:", "", *lines]
    return "\n".join(text)
