"""experiments/analysis.ipynb runs top to bottom on the committed results."""

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

EXPERIMENTS = Path(__file__).resolve().parents[1] / "experiments"


def test_analysis_notebook_runs():
    notebook = nbformat.read(EXPERIMENTS / "analysis.ipynb", as_version=4)
    nbclient.NotebookClient(
        notebook, timeout=120, resources={"metadata": {"path": str(EXPERIMENTS)}}
    ).execute()
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert "transit_ddpg_her" in str(outputs[0])  # the committed results were found
