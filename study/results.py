"""The report's data: every stored cell of its experiments, summarised (`Results`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mjx_skills.analysis import stats
from mjx_skills.sweeps import cells
from mjx_skills.sweeps.cell import Cell
from mjx_skills.sweeps.experiments import load_experiment
from mjx_skills.training.metrics_log import wall_seconds
from study import faster, two_cubes

EXPERIMENTS = (
    "fig6_3",
    "fig6_4",
    "fig6_5",
    "thesis_preset",
    "pas_single_goal",
    "take_out_held",
    "oracle",
    "random_explorer",
    "bc",
    "bc_weight",
    *faster.EXPERIMENTS,
    *two_cubes.EXPERIMENTS,
)
"""The report's experiments (`experiments/NAME.toml`), in the order of its sections."""


class Results:
    """Every stored cell of the report's experiments, summarised, by (experiment, key)."""

    def __init__(self, store: Path = cells.STORE):
        self.cells: dict[str, list[tuple[Cell, stats.Summary | None]]] = {}
        self.metrics: dict[str, list[dict]] = {}
        """Every stored cell's metrics.jsonl rows, by cell name."""
        for name in EXPERIMENTS:
            rows = []
            for cell in load_experiment(name).cells():
                where = cells.stored(cell, store)
                summary = None
                if where is not None:
                    metrics = self.metrics[cell.name] = cells.read_stored_metrics(where)
                    summary = stats.summarize(
                        stats.scores_from_rows(metrics), wall_s=wall_seconds(metrics)
                    )
                rows.append((cell, summary))
            self.cells[name] = rows

    def find(self, experiment: str, task: str, method: str, library: str = "SL1"):
        """-> (cell, summary or None while it is not run) of one cell of `experiment`."""
        for cell, summary in self.cells[experiment]:
            if cell.task == task and cell.method == method and cell.library in (library, None):
                return cell, summary
        raise KeyError((experiment, task, method, library))

    def get(self, experiment: str, task: str, method: str, library: str = "SL1"):
        """The cell's Summary, None while it is not run."""
        return self.find(experiment, task, method, library)[1]

    def first_epochs(self, cell: Cell, summary: stats.Summary, epochs: int) -> stats.Summary:
        """A stored cell's summary over its first `epochs` epochs (to compare with a shorter
        cell over the same budget)."""
        if summary.epochs <= epochs:
            return summary
        scores = stats.scores_from_rows(self.metrics[cell.name])[:, :epochs]
        return stats.summarize(scores, summary.wall_s)

    def mean_of(
        self, experiment: str, task: str, method: str, key: str, library: str = "SL1"
    ) -> float:
        """Mean of metric `key` over every epoch and seed of a stored cell."""
        cell, _ = self.find(experiment, task, method, library)
        return float(np.mean([m[key] for m in self.metrics[cell.name]]))
