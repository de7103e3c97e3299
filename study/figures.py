"""The report's figures: eval success per epoch, one panel per task."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mjx_skills.config import LIBRARIES
from study import faster, two_cubes
from study.claims import LABEL
from study.results import Results
from study.sections import VARIANTS, baseline


def figure(r: Results, experiment: str, out: Path, draw: bool = True) -> Path | None:
    """Eval success per epoch, mean over seeds with the 95 % interval shaded, one panel per
    task -> `out` (None: no cell finished yet). `draw=False` only says where it would be."""
    done = [(c, s) for c, s in r.cells[experiment] if s is not None]
    if not done or not draw:
        return out if done else None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = list(dict.fromkeys(c.task for c, _ in r.cells[experiment]))
    fig, axes = plt.subplots(1, len(tasks), figsize=(4.2 * len(tasks), 3.4), squeeze=False)
    libraries = LIBRARIES
    for ax, task in zip(axes[0], tasks, strict=True):
        # (cell, summary, tag, dashed): a variant's cell is drawn dashed beside its baseline.
        pairs = [(c, s, "", False) for c, s in done if c.task == task]
        if experiment in VARIANTS:
            tag = VARIANTS[experiment][0]
            pairs = [
                x
                for c, s, *_ in pairs
                for x in ((*baseline(r, experiment, c), "", False), (c, s, tag, True))
            ]
        if experiment == "fast":  # the oracle explorer's curve, the target to beat; today's
            pairs += faster.dashed(r, task)
        if experiment == two_cubes.EXPERIMENT:  # DDPG+HER+SL+Fast and its variants, dashed
            pairs += two_cubes.dashed(r, task)
        for cell, s, tag, dashed in pairs:
            if s is None:
                continue
            label = LABEL[cell.method] + (f" {cell.library}" if experiment == "fig6_4" else "")
            label += f" ({tag})" if tag else ""
            index = (
                libraries.index(cell.library)
                if experiment == "fig6_4"
                else len(LABEL) + two_cubes.colour(tag)
                if experiment == two_cubes.EXPERIMENT and tag
                else list(LABEL).index(cell.method)
            )
            x = np.arange(1, s.epochs + 1)
            ax.plot(x, s.curve, label=label, lw=1.4, color=f"C{index}", ls="--" if dashed else "-")
            ax.fill_between(x, s.curve_low, s.curve_high, color=f"C{index}", alpha=0.2, lw=0)
        ax.set(title=task, xlabel="epoch (16 episodes)", ylim=(-0.02, 1.02))
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("eval success (20 episodes)")
    handles = {}
    for ax in axes[0]:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, handle)
    fig.legend(
        handles.values(),
        handles.keys(),
        loc="lower center",
        ncol=len(handles),
        fontsize=8,
        frameon=False,
    )
    fig.subplots_adjust(bottom=0.25)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


PROFILE_TAUS = np.linspace(0.0, 1.0, 21)
"""The success levels a performance profile is read at."""


def profiles(r: Results, out: Path, draw: bool = True) -> Path | None:
    """Fig. 6.3's methods as performance profiles over its four tasks (rliable): the share of
    runs x tasks whose last-5 success is above each level, with 95 % stratified bootstrap
    bands -> `out` (None until every cell is in)."""
    from mjx_skills.analysis import stats
    from study.claims import THESIS_METHODS

    tasks = list(dict.fromkeys(c.task for c, _ in r.cells["fig6_3"]))
    cells = {m: [r.get("fig6_3", t, m) for t in tasks] for m in THESIS_METHODS}
    if any(s is None for row in cells.values() for s in row):
        return None
    if not draw:
        return out
    scores = {}
    for method in THESIS_METHODS:
        per_task = []
        for task in tasks:
            cell, _ = r.find("fig6_3", task, method)
            s = stats.scores_from_rows(r.metrics[cell.name])
            per_task.append(s[:, -stats.LAST :].mean(axis=1))
        scores[method] = np.stack(per_task, axis=1)  # (seeds, tasks)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.2, 3.6))
    for method, (profile, low, high) in stats.performance_profile(scores, PROFILE_TAUS).items():
        colour = f"C{list(LABEL).index(method)}"
        ax.plot(PROFILE_TAUS, profile, color=colour, lw=1.6, label=LABEL[method])
        ax.fill_between(PROFILE_TAUS, low, high, color=colour, alpha=0.2, lw=0)
    ax.set(
        xlabel="eval success, last 5 epochs (tau)",
        ylabel="share of runs x tasks above tau",
        ylim=(-0.02, 1.02),
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, frameon=False)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
