"""Reading mesh files: ``zbuffer.load`` against trimesh, and zbuffer's text
readers with and without their compiled fast paths.

    python benchmarks/bench_load.py            # -> benchmarks/results/load.{json,md}
    python benchmarks/bench_load.py --quick    # smoke mode

For each shared model (OBJ, as distributed) and the same mesh written as
ASCII OFF (polygons as in the OBJ file), ASCII and binary PLY (its
triangles, by trimesh), in a temporary folder:

- ``zbuffer.load(path)``: the whole call (parse, triangulate, merge
  repeated vertices for OFF and PLY, prepare for rendering);
- ``trimesh.load(path, process=False)``, which parses and little else
  (it fan-triangulates polygons, neither merges nor prepares);
- for OBJ and OFF, the parse alone: the compiled fast path
  (``_core.read_obj_records``, ``read_off_records``) and the Python reader
  it stands in for (``obj._read_obj_text``, ``off._read_off_text``, the
  bytes decoded first), on the file's bytes already in memory; for ASCII
  PLY, ``ply.read_ply`` from the file with and without its fast path
  (``_core.read_ascii_ply_tables``).

Times are medians of --runs calls after one warm-up, in one process; the
file is in the page cache. The *fast* and *Python* columns compare like
with like within a format, not across formats (for ASCII PLY they time the
whole of ``read_ply``, header and properties included). Nothing here
asserts a speed.
"""

from __future__ import annotations

import argparse
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import zbuffer
from common import MODELS, Progress, add_out_argument, new_report, out_folder, write_report
from zbuffer import _core, ply
from zbuffer.obj import _read_obj_text
from zbuffer.off import _read_off_text

MODELS_READ = ["bunny_10k.obj", "bunny_69k.obj", "armadillo_86k.obj", "venus_43k.obj",
               "beast_quads.obj"]


def median_ms(call, runs: int) -> float:
    call()
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        call()
        times.append((time.perf_counter() - start) * 1e3)
    return statistics.median(times)


def write_off(mesh: zbuffer.Mesh, path: Path) -> None:
    """The mesh as ASCII OFF, its polygons as the OBJ file had them."""
    if mesh.polygon_sizes is not None:
        sizes, indices = mesh.polygon_sizes, mesh.polygon_indices
    else:
        sizes, indices = np.full(len(mesh.faces), 3), mesh.faces.reshape(-1)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    with open(path, "w") as fh:
        fh.write(f"OFF\n{len(mesh.vertices)} {len(sizes)} 0\n")
        np.savetxt(fh, mesh.vertices, fmt="%.9g")
        fh.writelines(f"{n} {' '.join(map(str, indices[s:s + n]))}\n"
                      for n, s in zip(sizes.tolist(), starts.tolist()))


def cases_for(path: Path, folder: Path):
    """[(format, path)]: the OBJ file and its OFF, ASCII PLY and binary PLY
    copies."""
    import trimesh

    mesh = zbuffer.load(path)
    off = folder / (path.stem + ".off")
    write_off(mesh, off)
    cases = [("obj", path), ("off", off)]
    for encoding in ("ascii", "binary"):
        ply = folder / f"{path.stem}_{encoding}.ply"
        ply.write_bytes(trimesh.exchange.ply.export_ply(
            trimesh.Trimesh(mesh.vertices, mesh.faces, process=False), encoding=encoding))
        cases.append((f"ply ({encoding})", ply))
    return cases


def read_ply_without_fast_path(path):
    """ply.read_ply reading an ASCII file line by line, as without
    _core.read_ascii_ply_tables."""
    saved = ply._ascii_fast
    ply._ascii_fast = lambda body, elements: None
    try:
        return ply.read_ply(path)
    finally:
        ply._ascii_fast = saved


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke mode: one small mesh, 2 runs")
    parser.add_argument("--runs", type=int, default=None, help="calls per case (default 7)")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    import trimesh

    runs = args.runs or (2 if args.quick else 7)
    report = {**new_report("bench_load.py", argv), "runs": runs, "cases": []}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        names = MODELS_READ[:1] if args.quick else MODELS_READ
        paths = [MODELS / n for n in names if (MODELS / n).is_file()]
        if not paths and args.quick:  # no shared models: the default scene, as OBJ
            scene = zbuffer.scenes.default_scene()
            paths = [folder / "default_scene.obj"]
            with open(paths[0], "w") as fh:
                np.savetxt(fh, scene.vertices, fmt="v %.9g %.9g %.9g")
                np.savetxt(fh, scene.faces + 1, fmt="f %d %d %d")
        progress = Progress("load", 4 * len(paths))
        for path in paths:
            for fmt, file in cases_for(path, folder):
                raw = file.read_bytes()
                mesh = zbuffer.load(file)
                case = {"mesh": path.name, "format": fmt, "bytes": len(raw),
                        "vertices": len(mesh.vertices), "triangles": len(mesh.faces),
                        "load_ms": median_ms(lambda: zbuffer.load(file), runs)}
                try:
                    case["trimesh_ms"] = median_ms(lambda: trimesh.load(file, process=False), runs)
                except Exception as err:  # (trimesh 4 with numpy 2 fails on some OFF files)
                    case["trimesh_error"] = f"{type(err).__name__}: {err}"
                fast, slow = {"obj": (_core.read_obj_records, _read_obj_text),
                              "off": (_core.read_off_records, _read_off_text)}.get(fmt, (None, None))
                if fast is not None:
                    case["fast_taken"] = fast(raw) is not None
                    case["fast_parse_ms"] = median_ms(lambda: fast(raw), runs)
                    case["python_parse_ms"] = median_ms(
                        lambda: slow(raw.decode("utf-8", errors="replace")), runs)
                elif fmt == "ply (ascii)":
                    fh = io.BytesIO(raw)
                    _, elements = ply._header(fh)
                    case["fast_taken"] = ply._ascii_fast(fh.read(), elements) is not None
                    case["fast_parse_ms"] = median_ms(lambda: ply.read_ply(file), runs)
                    case["python_parse_ms"] = median_ms(
                        lambda: read_ply_without_fast_path(file), runs)
                report["cases"].append(case)
                progress(f"{path.name} as {fmt}: load {case['load_ms']:.1f} ms, trimesh "
                         + (f"{case['trimesh_ms']:.1f} ms" if "trimesh_ms" in case else "failed"))
    write_report(out_folder(args), "load", report, markdown(report))
    return 0


def markdown(report: dict) -> str:
    m = report["machine"]
    lines = ["# Reading mesh files", "",
             f"- date: {report['date']}",
             f"- machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}",
             f"- commit: {m['commit']}",
             f"- command: `{report['command']}`",
             f"- times: median of {report['runs']} calls after a warm-up, file in the page "
             "cache, one process. *load*: `zbuffer.load` (parse, triangulate, merge repeated "
             "vertices for OFF and PLY, prepare); *trimesh*: `trimesh.load(path, "
             "process=False)`; *fast* and *Python parse*: the text reader's compiled fast path "
             "and the Python reader it stands in for, on the bytes in memory (ASCII PLY: "
             "`ply.read_ply` with and without its fast path, from the file).", "",
             "| mesh | format | MB | triangles | load ms | trimesh ms | load / trimesh "
             "| fast parse ms | Python parse ms | Python / fast |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for c in report["cases"]:
        parse = ["", "", ""]
        if "fast_parse_ms" in c:
            parse = [f"{c['fast_parse_ms']:.1f}" + ("" if c["fast_taken"] else " (not taken)"),
                     f"{c['python_parse_ms']:.1f}",
                     f"{c['python_parse_ms'] / c['fast_parse_ms']:.0f}x"]
        trimesh = (f"{c['trimesh_ms']:.1f} | {c['load_ms'] / c['trimesh_ms']:.2f}"
                   if "trimesh_ms" in c else f"failed ({c['trimesh_error'].split(':')[0]}) | ")
        lines.append(f"| {c['mesh']} | {c['format']} | {c['bytes'] / 1e6:.1f} | "
                     f"{c['triangles']:,} | {c['load_ms']:.1f} | {trimesh} | "
                     + " | ".join(parse) + " |")
    failed = [c for c in report["cases"] if "trimesh_error" in c]
    if failed:
        lines += ["", "trimesh failed: " + "; ".join(
            f"{c['mesh']} as {c['format']}, {c['trimesh_error'][:160]}" for c in failed)]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
