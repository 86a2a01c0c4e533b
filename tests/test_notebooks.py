"""The notebooks run: their code cells, executed in order without Jupyter."""

import json
import os
from pathlib import Path

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
    namespace = {"__name__": "__main__", "display": lambda *args, **kwargs: None}
    for k, cell in enumerate(c for c in nb["cells"] if c["cell_type"] == "code"):
        source = "".join(cell["source"])
        exec(compile(source, f"{path.name}[{k}]", "exec"), namespace)


def test_there_are_notebooks():
    assert NOTEBOOKS, "notebooks/ holds no notebook"
    assert all(os.path.getsize(p) > 0 for p in NOTEBOOKS)
