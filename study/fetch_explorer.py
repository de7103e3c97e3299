"""What a Fetch headline's explorer showed its learner, from the headline cell's own metrics:
how often its training episodes reached the goal while the look-ahead search explored (eps
decaying over `--search.eps-decay-epochs`), how far the frozen policy had come when the
exploration ended, and when it reached the target's level on its own afterwards."""

from __future__ import annotations

import numpy as np

from mjx_skills.analysis import stats
from mjx_skills.sweeps.experiment_file import names, raw


def _by_epoch(rows: list[dict], key: str) -> np.ndarray:
    """(epochs,) the seeds' mean of `key` per epoch, epoch 1 first."""
    epochs = max(r["epoch"] for r in rows)
    total, count = np.zeros(epochs), np.zeros(epochs)
    for r in rows:
        total[r["epoch"] - 1] += r[key]
        count[r["epoch"] - 1] += 1
    return total / count


def paragraph(found) -> list[str]:
    """One sentence per DDPG+HER+SL headline on a Fetch task among `found` ((label, cell,
    metrics rows) of the section's stored cells)."""
    out = []
    for label, cell, rows in found:
        if label not in names() or cell.method != "ddpg_her_sl":
            continue
        exp = raw(label)
        if exp.get("role") != "headline" or not exp.get("target"):
            continue
        level, target = exp["target"]["level"], exp["target"]["epoch"]
        end = cell.run_args(out="", progress=False).full_options()["search"].eps_decay_epochs
        train, evals = _by_epoch(rows, "train_success"), _by_epoch(rows, "eval_success")
        window = slice(max(0, end - stats.WINDOW), end)
        hit = stats.first_reaching(evals, level)
        after = f"reached {level} at epoch {hit}" if hit else f"never reached {level}"
        out.append(
            f"What {label}'s explorer showed its learner: while the search explored (eps "
            f"decaying over epochs 1-{end}), {train[:end].mean():.2f} of its training "
            f"episodes reached the goal, but its frozen policy succeeded on "
            f"{evals[window].mean():.2f} of its evaluations over epochs "
            f"{window.start + 1}-{end}; on its own after that, the policy {after} (the "
            f"target: epoch {target}). Whether a learner that takes more from each episode "
            "(DDPG+HER+SL+Fast) absorbs more of it before the explorer stops is what "
            "fetch_pick_and_place_fast measures."
        )
    return ["", *out] if out else []
