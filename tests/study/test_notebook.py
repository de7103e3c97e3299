"""experiments/analysis.ipynb runs top to bottom headless and draws the figures of the
results it finds (here a small committed results folder)."""

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"
SMALL_RESULTS = Path(__file__).resolve().parents[1] / "data" / "results"


def test_analysis_notebook_draws_the_figures_it_has_results_for(tmp_path, monkeypatch):
    monkeypatch.setenv("MJX_SKILLS_RESULTS", str(SMALL_RESULTS))
    monkeypatch.setenv("MJX_SKILLS_FIGURES", str(tmp_path))
    notebook = nbformat.read(EXPERIMENTS / "analysis.ipynb", as_version=4)
    nbclient.NotebookClient(
        notebook, timeout=300, resources={"metadata": {"path": str(EXPERIMENTS)}}
    ).execute()
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["fig6_3.png", "table5_1.png"]
    assert all(p.stat().st_size > 10_000 for p in tmp_path.glob("*.png"))  # drawn, not blank
    text = "".join(str(o) for o in outputs)
    assert "fig6_4.csv not found" in text  # a missing result says how to make it
    assert "thesis" in text  # the thesis's outcomes are shown beside ours
