"""The notebooks run: their code cells, executed in order without Jupyter;
every picture a cell shows (its last expression, or what it passes to
``display``) has more in it than a background, and every matplotlib figure
it draws has something plotted in each of its panels."""

import ast
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers import can_render_offscreen

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))

# The functions of zbuffer.viz that draw with pyvista (the plots of recorded
# benchmarks need matplotlib only).
PYVISTA_DRAWING = ("show_result", "show_pyramid", "show_pyramid_stack", "compare_algorithms",
                   "tree_grid", "frustum_grid", "show_tree", ".show(")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_code_cells_run(path, monkeypatch):
    nb = json.loads(path.read_text())
    code = "".join("".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code")
    uses_viz = any(name in code for name in PYVISTA_DRAWING)
    if uses_viz and not can_render_offscreen():
        if os.environ.get("ZBUFFER_REQUIRE_VIZ"):  # CI: a skip would hide a failure
            raise RuntimeError("ZBUFFER_REQUIRE_VIZ is set but pyvista cannot render offscreen")
        pytest.skip(f"{path.name} draws with pyvista, which cannot render offscreen here")
    monkeypatch.chdir(path.parent)  # notebooks use paths relative to themselves
    shown = []
    namespace = {"__name__": "__main__", "display": lambda *args, **kwargs: shown.extend(args)}
    for k, cell in enumerate(c for c in nb["cells"] if c["cell_type"] == "code"):
        name = f"{path.name}[{k}]"
        body = ast.parse("".join(cell["source"]), name)
        last = body.body.pop() if body.body and isinstance(body.body[-1], ast.Expr) else None
        exec(compile(body, name, "exec"), namespace)
        if last is not None:  # what Jupyter would show below the cell
            shown.append(eval(compile(ast.Expression(last.value), name, "eval"), namespace))
        for value in shown:
            if type(value).__name__ == "Image" and hasattr(value, "getcolors"):  # PIL
                assert not_blank(np.asarray(value)), f"{name} shows a blank picture"
        shown.clear()
        plt = sys.modules.get("matplotlib.pyplot")
        for number in plt.get_fignums() if plt else []:  # (Jupyter shows every open figure)
            figure = plt.figure(number)
            for ax in figure.axes:
                drawn = [a for a in ax.lines + ax.patches + ax.collections + ax.images
                         if not (hasattr(a, "get_ydata") and np.isnan(a.get_ydata()).all())]
                assert drawn, f"{name} draws an empty panel {ax.get_title()!r}"
            plt.close(figure)


def not_blank(picture: np.ndarray) -> bool:
    """More than a background and a caption: no one colour covers 97% of
    the picture."""
    flat = picture.reshape(-1, picture.shape[-1]) if picture.ndim == 3 else picture.reshape(-1, 1)
    _, counts = np.unique(flat, axis=0, return_counts=True)
    return counts.max() < 0.97 * len(flat)


def test_there_are_notebooks():
    assert NOTEBOOKS, "notebooks/ holds no notebook"
    assert all(os.path.getsize(p) > 0 for p in NOTEBOOKS)
