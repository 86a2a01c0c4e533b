"""zbuffer.viz's benchmark figures, drawn from a benchmark report (matplotlib,
no screen needed)."""

import json

import pytest

from zbuffer import viz

plt = pytest.importorskip("matplotlib.pyplot")


def report():
    grid = []
    for n in (1, 2, 4):
        for projection in ("perspective", "orthographic"):
            for algo, mode in (("zbuffer", "per frame"), ("hiz_octree", "per frame"),
                               ("hiz_octree", "built once")):
                grid.append({"N": n, "projection": projection, "algo": algo, "mode": mode,
                             "triangles": 100 * n, "ms_median": float(n * (1 + len(algo))),
                             "rasterized": 100 * n if algo == "zbuffer" else 50 * n,
                             "culled_hidden": 0 if algo == "zbuffer" else 30 * n,
                             "culled_in_nodes": 0 if algo == "zbuffer" else 20 * n})
    return {"size": 64, "grid": grid}


def test_grid_figures(tmp_path):
    path = tmp_path / "hiz.json"
    path.write_text(json.dumps(report()))
    data = viz.load_benchmark(path)
    fig = viz.plot_grid_times(data)
    assert len(fig.axes) == 2
    assert len(fig.axes[0].get_lines()) == 3  # one per algorithm and mode
    fig.savefig(tmp_path / "times.png")
    fig = viz.plot_grid_culling(data)
    bars = fig.axes[0].patches
    assert len(bars) == 3 * 4  # three parts for each (algorithm, projection) per frame
    heights = {round(sum(b.get_height() for b in bars[k::4]), 9) for k in range(4)}
    assert heights == {1.0}  # the parts add up to all triangles
    plt.close("all")


def test_models_figure(tmp_path):
    algos = ["zbuffer", "hiz", "scanline"]
    cases = []
    for model in ("a.obj", "b.obj"):
        for size in ("16x12", "32x32"):
            for cull in (False, True):
                cases.append({"model": model, "size": size, "cull": cull, "algorithms": {
                    a: {"x_zbuffer": 1.0 + k + (size == "32x32")} for k, a in enumerate(algos)}})
    cases.append({"model": "missing.obj", "size": "32x32", "cull": False, "skipped": "not found"})
    fig = viz.plot_models({"algorithms": algos, "cases": cases})
    bars = fig.axes[0].patches
    assert len(bars) == 2 * 2  # two models, one bar per algorithm other than zbuffer
    assert sorted(b.get_height() for b in bars) == [3.0, 3.0, 4.0, 4.0]  # the largest size
    fig.savefig(tmp_path / "models.png")
    plt.close("all")
