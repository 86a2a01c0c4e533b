"""The notebooks run: their code cells, executed in order without Jupyter."""

import json
import os
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_code_cells_run(path, monkeypatch):
    nb = json.loads(path.read_text())
    monkeypatch.chdir(path.parent)  # notebooks use paths relative to themselves
    namespace = {"__name__": "__main__", "display": lambda *args, **kwargs: None}
    for k, cell in enumerate(c for c in nb["cells"] if c["cell_type"] == "code"):
        source = "".join(cell["source"])
        exec(compile(source, f"{path.name}[{k}]", "exec"), namespace)


def test_there_are_notebooks():
    assert NOTEBOOKS, "notebooks/ holds no notebook"
    assert all(os.path.getsize(p) > 0 for p in NOTEBOOKS)
