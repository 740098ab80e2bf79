"""The notebook in examples/ runs from top to bottom and draws its figures (docs/python.md)."""
import os

import nbformat
from nbclient import NotebookClient

NOTEBOOK = "examples/crosslink.ipynb"
FIGURES = ["coupler_curve.png", "engine_errors.png", "coupler_length.png"]


def test_the_notebook_runs_and_draws_each_figure(tmp_path, monkeypatch):
    monkeypatch.setenv("CROSSLINK_FIGURES", str(tmp_path))
    # The kernel imports the module from an absolute path: it starts in the repository's root.
    monkeypatch.setenv("PYTHONPATH", os.path.abspath(os.environ.get("PYTHONPATH", "build/python")))
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    assert all(not cell.get("outputs") for cell in notebook.cells if cell.cell_type == "code"), (
        "the notebook is kept without outputs")
    NotebookClient(notebook, timeout=600, kernel_name="python3",
                   resources={"metadata": {"path": os.getcwd()}}).execute()
    drawn = [
        cell for cell in notebook.cells
        if cell.cell_type == "code"
        and any("image/png" in output.get("data", {}) for output in cell.outputs)
    ]
    assert len(drawn) == len(FIGURES)
    for name in FIGURES:
        with open(tmp_path / name, "rb") as png:
            assert png.read(8) == b"\x89PNG\r\n\x1a\n", name
    for cell in notebook.cells:
        if cell.cell_type == "code":
            assert not [o for o in cell.outputs if o.output_type == "error"], cell.source[:80]
