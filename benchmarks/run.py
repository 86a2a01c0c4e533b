"""Run the benchmark suites and record them: one command.

    python benchmarks/run.py                     # every suite -> benchmarks/results/
    python benchmarks/run.py hiz peers           # some suites (render hiz scaling peers)
    python benchmarks/run.py --quick --out DIR   # smoke mode (CI), somewhere else

Suites (each also runs alone, see its docstring):

- ``render``: ``zbuffer.render`` on the shared models, every algorithm,
  depth only and shaded, with VTK offscreen for scale (``bench_render.py``);
- ``hiz``: the 5 x 5 x N spot grid, per frame and built once, octree rules,
  leaf sizes, temporal coherence, unoccluded meshes (``bench_hiz.py``);
- ``scaling``: image size 256^2 ... 4096^2, triangle count 6 k ... 10 M, peak
  memory (``bench_scaling.py``);
- ``peers``: Open3D ray casting and VTK offscreen rendering on the same
  meshes, camera and pixels, with the agreement of their depth maps and ours
  (``bench_peers.py``).

Each suite writes ``<suite>.json`` and ``<suite>.md`` into the output folder;
this script adds ``<date>-<host>.json`` (all of them, with the machine, the
versions and the git revision) and regenerates ``RESULTS.md`` (every table,
and figures drawn from the JSON as PNG files) next to them. Nothing here
asserts a speed.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import platform
import sys
import time
from pathlib import Path

import bench_hiz
import bench_peers
import bench_render
import bench_scaling
from bench_render import HERE, new_report

SUITES = {"render": bench_render, "hiz": bench_hiz, "scaling": bench_scaling, "peers": bench_peers}


def results_markdown(out: Path, names) -> str:
    """RESULTS.md: each suite's tables, and the figures of the grid suite."""
    lines = ["# Benchmark results", "",
             "Written by `python benchmarks/run.py`; each section is a suite's own table "
             "(`<suite>.md`), with its machine, command and date.", ""]
    for name in names:
        md = out / f"{name}.md"
        if md.is_file():
            lines += [md.read_text().replace("\n# ", "\n## ").replace("# ", "## ", 1), ""]
        if name == "hiz" and (out / "hiz.json").is_file():
            figures = write_hiz_figures(out)
            lines += [f"![{title}](figures/{path.name})" for title, path in figures] + [""]
    return "\n".join(lines)


def write_hiz_figures(out: Path):
    """The grid suite's figures as PNG files in <out>/figures/."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from zbuffer import viz

    report = viz.load_benchmark(out / "hiz.json")
    folder = out / "figures"
    folder.mkdir(exist_ok=True)
    figures = []
    for title, fig, stem in (("frame time against N", viz.plot_grid_times(report), "grid_times"),
                             ("where the triangles went", viz.plot_grid_culling(report),
                              "grid_culling")):
        path = folder / f"{stem}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        figures.append((title, path))
    return figures


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("suites", nargs="*", choices=[[], *SUITES], default=[],
                        help=f"suites to run (default all: {', '.join(SUITES)})")
    parser.add_argument("--quick", action="store_true", help="smoke mode: small inputs, few runs")
    parser.add_argument("--out", default=str(HERE / "results"), help="output folder")
    args = parser.parse_args(argv)
    names = args.suites or list(SUITES)
    out = Path(args.out)
    record = {**new_report("run.py", argv), "suites": {}}
    started = time.perf_counter()
    for k, name in enumerate(names, 1):
        print(f"[{k}/{len(names)}] {name} ({time.perf_counter() - started:.0f} s so far)", flush=True)
        SUITES[name].main([*(["--quick"] if args.quick else []), "--out", str(out)])
        record["suites"][name] = json.loads((out / f"{name}.json").read_text())
    host = platform.node() or "host"
    stamp = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d")
    (out / f"{stamp}-{host}.json").write_text(json.dumps(record, indent=2) + "\n")
    (out / "RESULTS.md").write_text(results_markdown(out, names))
    print(f"wrote {out / (stamp + '-' + host + '.json')} and {out / 'RESULTS.md'} "
          f"in {time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
