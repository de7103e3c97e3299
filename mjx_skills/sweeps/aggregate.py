"""A sweep's results: the stored cells' metrics aggregated over seeds per epoch
(NAME.csv: mean and std of eval success) beside every seed's rows (NAME.jsonl)."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from mjx_skills.core.files import write_text_atomic
from mjx_skills.sweeps.cell import Cell

CSV_FIELDS = (
    "experiment",
    "task",
    "method",
    "library",
    "epoch",
    "episodes",
    "env_steps",
    "eval_success_mean",
    "eval_success_std",
    "seeds",
    "wall_s",
)


def aggregate(experiment: str, cells: list[Cell], run_dirs: list[Path]) -> tuple[list, list]:
    """-> (CSV rows: mean / std over seeds per epoch and cell, JSONL rows: every seed).
    `run_dirs`: the stored cells, verified as read (ValueError naming a damaged file)."""
    from mjx_skills.sweeps.cells import read_stored_metrics

    rows, per_seed = [], []
    for cell, run_dir in zip(cells, run_dirs, strict=True):
        metrics = read_stored_metrics(run_dir)
        tag = {
            "experiment": experiment,
            "task": cell.task,
            "method": cell.method,
            "library": cell.library or "-",
        }
        per_seed += [{**tag, **m} for m in metrics]
        for epoch in sorted({m["epoch"] for m in metrics}):
            at = [m for m in metrics if m["epoch"] == epoch]
            success = np.array([m["eval_success"] for m in at])
            rows.append(
                {
                    **tag,
                    "epoch": epoch,
                    "episodes": at[0]["episodes"],
                    "env_steps": at[0]["env_steps"],
                    "eval_success_mean": round(float(success.mean()), 4),
                    "eval_success_std": round(float(success.std()), 4),
                    "seeds": len(at),
                    "wall_s": round(max(m["wall_s"] for m in at), 1),
                }
            )
    return rows, per_seed


def write_results(name: str, rows: list, per_seed: list, results: Path) -> tuple[Path, Path]:
    """NAME.csv and NAME.jsonl in `results`, each written whole or not at all."""
    results.mkdir(parents=True, exist_ok=True)
    csv_path, jsonl_path = results / f"{name}.csv", results / f"{name}.jsonl"
    table = io.StringIO(newline="")
    writer = csv.DictWriter(table, fieldnames=CSV_FIELDS)
    writer.writeheader()
    writer.writerows(rows)
    write_text_atomic(csv_path, table.getvalue())
    write_text_atomic(jsonl_path, "".join(json.dumps(r) + "\n" for r in per_seed))
    return csv_path, jsonl_path
