"""What every benchmark script shares: where the models are, the header of a
report (date, machine, versions, git revision, command), writing a report,
timing cases side by side, the scenes a suite falls back on in smoke mode,
and a progress bar."""

from __future__ import annotations

import datetime as dt
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import zbuffer

HERE = Path(__file__).resolve().parent
MODELS = Path(os.environ.get("ZBUFFER_MODELS", HERE.parents[1] / "shared" / "models"))


def machine() -> dict:
    """The CPU, core count, versions, git revision and installed module a report
    was measured with."""
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE,
                                capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "cpp", "src", "python",
                                "CMakeLists.txt", "pyproject.toml"],
                               cwd=HERE.parent, capture_output=True, text=True).stdout.strip()
        if dirty:
            commit += " (with uncommitted changes to the sources or the build)"
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "zbuffer": zbuffer.__version__,
            "raster_backend": zbuffer._core.RASTER_BACKEND,
            "platform": platform.platform(), "commit": commit,
            # What was timed: the installed package, which `commit` (the
            # checkout's) describes only if it was installed from it since.
            "zbuffer_module": zbuffer._core.__file__}


def new_report(script: str, argv) -> dict:
    """The header every benchmark report starts with: date, machine, command."""
    return {
        "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine(),
        "command": " ".join([f"python benchmarks/{script}", *(argv if argv is not None else sys.argv[1:])]),
    }


RESULTS = HERE / "results"                             # the recorded results
QUICK_RESULTS = HERE.parent / "build" / "bench-quick"  # smoke runs' (not kept in git)


def add_out_argument(parser) -> None:
    """The suites' ``--out``: by default the recorded results, or, for a
    smoke run (``--quick``), a scratch folder -- a smoke run's few small
    inputs must not overwrite the record."""
    parser.add_argument("--out", default=None,
                        help="output folder (default: benchmarks/results, the recorded results; "
                             "with --quick, build/bench-quick)")


def out_folder(args) -> Path:
    """Where a suite parsed by a parser with add_out_argument writes."""
    if args.out is not None:
        return Path(args.out)
    return QUICK_RESULTS if args.quick else RESULTS


def write_report(out_dir, stem: str, report: dict, text: str) -> None:
    """Write <out_dir>/<stem>.json (everything measured) and <stem>.md (the tables)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.json").write_text(json.dumps(report, indent=2) + "\n")
    (out / f"{stem}.md").write_text(text)
    print(f"wrote {out / (stem + '.json')} and {out / (stem + '.md')}")


def rounds(cases, render, runs: int):
    """Time every case of `cases` side by side: a warm-up render of each,
    then `runs` rounds in which each case in turn renders twice in a row and
    the second frame is timed (its ``render_ms``). Rounds let the machine's
    drift hit every case alike, so that ratios between cases compare like
    with like; the frame before each timed one puts the case's own arrays
    back in the caches, so that each is timed as a user rendering frame
    after frame sees it, not with the caches full of another case's data (a
    `Scene` tree's faces and vertex copies: armadillo_86k's built-once
    octree measured 1.25x `zbuffer`'s time on first frames, 1.20x on second
    ones, benchmarks/README.md). Returns ({case: [ms, ...]}, {case: the
    last timed result})."""
    for case in cases:
        render(case)  # warm-up (and the cached visiting order of a large mesh)
    times = {case: [] for case in cases}
    last = {}
    for _ in range(runs):
        for case in cases:
            render(case)
            last[case] = render(case)
            times[case].append(last[case].stats["render_ms"])
    return times, last


def load_model(name: str, quick: bool):
    """(mesh, label) for a shared model; in smoke mode a procedural stand-in
    when the model is missing, otherwise (None, name)."""
    path = MODELS / name
    if path.is_file():
        return zbuffer.load(path), name
    if not quick:
        return None, name
    return zbuffer.scenes.default_scene(), f"{name} (missing: default scene instead)"


class Progress:
    """A progress bar for a suite of known length: every finished case prints
    one line behind the bar, e.g.

        [hiz  12/40 ######------------  30%  1m05s left] N=10 perspective hiz 42.1 ms

    One line per case (rather than a bar redrawn in place) so that the same
    output reads in a terminal and in a CI log."""

    WIDTH = 18

    def __init__(self, suite: str, total: int):
        self.suite, self.total, self.done = suite, max(int(total), 1), 0
        self.started = time.perf_counter()

    def __call__(self, message: str) -> None:
        self.done = min(self.done + 1, self.total)
        elapsed = time.perf_counter() - self.started
        fraction = self.done / self.total
        filled = int(round(self.WIDTH * fraction))
        left = elapsed / fraction - elapsed
        print(f"[{self.suite} {self.done:>{len(str(self.total))}}/{self.total} "
              f"{'#' * filled}{'-' * (self.WIDTH - filled)} {fraction:4.0%} "
              f"{_duration(left)} left] {message}", flush=True)


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 60}m{seconds % 60:02d}s" if seconds >= 60 else f"{seconds}s"
