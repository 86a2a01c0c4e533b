"""Run the benchmark suites and record them: one command.

    python benchmarks/run.py                     # every suite -> benchmarks/results/
    python benchmarks/run.py hiz peers           # some suites (render hiz scaling peers load)
    python benchmarks/run.py --quick             # smoke mode (CI) -> build/bench-quick/

Suites (each also runs alone, see its docstring):

- ``models``: every algorithm on the shared models at 666x500 and
  1024x1024, back-face culling off and on (``bench_models.py``);
- ``render``: the foundation's cases (``zbuffer`` on the course size and
  the large scans, shaded frames, scanline and HiZ ratios, depth storage),
  with VTK offscreen for scale (``bench_render.py``);
- ``hiz``: the 5 x 5 x N spot grid, per frame and built once, octree rules,
  leaf sizes, submission order, temporal coherence, unoccluded meshes
  (``bench_hiz.py``);
- ``scaling``: image size 256^2 ... 4096^2, triangle count 6 k ... 10 M, peak
  memory (``bench_scaling.py``);
- ``peers``: Open3D ray casting, VTK and pyrender offscreen rendering on the
  same meshes, camera and pixels, with the agreement of their depth maps and
  ours (``bench_peers.py``; each peer only where it is installed);
- ``load``: reading mesh files, ``zbuffer.load`` against trimesh, and the
  text readers with and without their compiled fast paths (``bench_load.py``).

Each suite writes ``<suite>.json`` and ``<suite>.md`` into the output folder
and prints a progress bar; this script adds ``<date>-<host>.json`` (all of
them, with the machine, the versions and the git revision; a later run of
some suites the same day keeps the others' earlier entries) and regenerates
``RESULTS.md``: per suite, what its numbers mean, where each speed target
named in the issues stands in this run (read from the JSON by
``targets.py``), its tables, and figures drawn from the JSON. Nothing here
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
import bench_load
import bench_models
import bench_peers
import bench_render
import bench_scaling
import targets
from common import add_out_argument, new_report, out_folder

SUITES = {"models": bench_models, "render": bench_render, "hiz": bench_hiz,
          "scaling": bench_scaling, "peers": bench_peers, "load": bench_load}


def results_markdown(out: Path, record: dict) -> str:
    """RESULTS.md: the run's header, then per suite what it measures, where
    its targets stand, its tables and figures."""
    m = record["machine"]
    lines = ["# Benchmark results", "",
             f"- date: {record['date']}",
             f"- machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy "
             f"{m['numpy']}; raster backend {m['raster_backend']}",
             f"- revision: {m['commit']}",
             f"- command: `{record['command']}`",
             "",
             "Written by `benchmarks/run.py` from the JSON of this run (every repeat is in "
             "`<date>-<host>.json`, and every run of a suite, kept, in `runs/`); each suite's "
             "section repeats its own table "
             "(`<suite>.md`). Times are in-process medians; machines like this one are "
             "shared and noisy, so compare algorithms by their ratios within one run.", ""]
    kept = set(record.get("kept_from_earlier_runs", ()))
    for name in SUITES:
        if name in record["suites"] and name not in kept:
            report, note = record["suites"][name], []
        else:
            # Not run this time: the suite's run kept from earlier the same
            # day, or else its latest recorded one; either with its own date.
            if name in record["suites"]:
                report = record["suites"][name]
            elif (out / f"{name}.json").is_file():
                report = json.loads((out / f"{name}.json").read_text())
            else:
                continue
            note = [f"*Not run by this command: the section below (and \"this run\" in it) "
                    f"is from an earlier run ({report['date']}, `{report['command']}`).*", ""]
        # The tables made again from the report judged (the suite's <name>.md may
        # be another run's: one of the suite alone since the kept one).
        md = SUITES[name].markdown(report).splitlines()
        title = md[0].lstrip("# ").strip() if md and md[0].startswith("#") else name
        lines += [f"## {title}", "", *note,
                  targets.paragraph(name, report, "--quick" in report["command"]), "",
                  *md[1:], ""]
        lines += [f"![{caption}](figures/{path.name})"
                  for caption, path in write_figures(out, name, report)] + [""]
    return "\n".join(lines)


def write_figures(out: Path, name: str, report: dict):
    """A suite's figures (zbuffer.viz, drawn from its JSON) as PNG files in
    <out>/figures/: [(caption, path)]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from zbuffer import viz

    if name == "hiz" and report.get("grid"):
        drawings = [("frame time against N", viz.plot_grid_times, "grid_times"),
                    ("where the triangles went", viz.plot_grid_culling, "grid_culling")]
    elif name == "models" and any("algorithms" in c for c in report.get("cases", [])):
        drawings = [("every algorithm against zbuffer, per model", viz.plot_models, "models")]
    else:
        return []
    folder = out / "figures"
    folder.mkdir(exist_ok=True)
    figures = []
    for caption, draw, stem in drawings:
        fig = draw(report)
        path = folder / f"{stem}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        figures.append((caption, path))
    return figures


def keep_run(out: Path, name: str, report: dict, text: str, quick: bool) -> Path:
    """A copy (``text``, the suite's JSON) of one run of a suite that later
    runs do not overwrite: <out>/runs/<date>-<HHMM>-<suite>[-quick][-k].json
    (``<suite>.json`` and the dated file hold only the latest run, and the
    README's ranges span several; -k numbers runs within one minute)."""
    stamp = report["date"].replace(" UTC", "").replace(":", "").replace(" ", "-")
    folder = out / "runs"
    folder.mkdir(exist_ok=True)
    base = f"{stamp}-{name}{'-quick' if quick else ''}"
    for k in range(1, 1000):
        path = folder / f"{base}{'' if k == 1 else f'-{k}'}.json"
        try:
            with open(path, "x") as fh:
                fh.write(text)
            return path
        except FileExistsError:
            continue
    raise RuntimeError(f"too many runs of {name} in one minute in {folder}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("suites", nargs="*", default=[], metavar="SUITE",
                        help=f"suites to run, of {', '.join(SUITES)} (default: all)")
    parser.add_argument("--quick", action="store_true", help="smoke mode: small inputs, few runs")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    unknown = [name for name in args.suites if name not in SUITES]
    if unknown:
        parser.error(f"unknown suite {unknown[0]!r}; valid suites are {', '.join(SUITES)}")
    names = args.suites or list(SUITES)
    out = out_folder(args)
    record = {**new_report("run.py", argv), "quick": args.quick, "suites": {}}
    started = time.perf_counter()
    for k, name in enumerate(names, 1):
        print(f"[{k}/{len(names)}] {name} ({time.perf_counter() - started:.0f} s so far)", flush=True)
        SUITES[name].main([*(["--quick"] if args.quick else []), "--out", str(out)])
        text = (out / f"{name}.json").read_text()
        record["suites"][name] = report = json.loads(text)
        keep_run(out, name, report, text, args.quick)
    host = platform.node() or "host"
    stamp = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d")
    dated = out / f"{stamp}-{host}.json"
    if dated.is_file():
        # A run of some suites the same day keeps what an earlier run of
        # the others recorded there (each suite's report has its own date,
        # revision and command).
        earlier = json.loads(dated.read_text()).get("suites", {})
        kept = {k: v for k, v in earlier.items() if k not in record["suites"]}
        if kept:
            record["suites"] = {**kept, **record["suites"]}
            record["kept_from_earlier_runs"] = sorted(kept)
    dated.write_text(json.dumps(record, indent=2) + "\n")
    (out / "RESULTS.md").write_text(results_markdown(out, record))
    print(f"wrote {out / (stamp + '-' + host + '.json')} and {out / 'RESULTS.md'} "
          f"in {time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
