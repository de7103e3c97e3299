"""What a Fetch headline's explorer showed its learner, from the headline cell's own metrics:
how often its training episodes reached the goal while the look-ahead search explored (eps
decaying over `--search.eps-decay-epochs`), how far the frozen policy had come when the
exploration ended, and when it reached the target's level on its own afterwards."""

from __future__ import annotations

from mjx_skills.analysis import stats
from study.headlines import experiments


def paragraph(found) -> list[str]:
    """One sentence per DDPG+HER+SL headline on a Fetch task among `found` ((label, cell,
    metrics rows) of the section's stored cells)."""
    headlines = {exp.name: exp for exp in experiments()}
    out = []
    for label, cell, rows in found:
        if label not in headlines or cell.method != "ddpg_her_sl":
            continue
        level, target = headlines[label].target["level"], headlines[label].target["epoch"]
        end = cell.run_args(out="", progress=False).full_options()["search"].eps_decay_epochs
        train = stats.scores_from_rows(rows, "train_success").mean(axis=0)
        evals = stats.scores_from_rows(rows).mean(axis=0)
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
