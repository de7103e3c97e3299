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
