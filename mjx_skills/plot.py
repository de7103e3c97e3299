"""The learning curve of one or more training runs, as the report draws them: eval success
of the frozen policy per epoch (the mean over a run's seeds, each seed a thin line) over
env steps, read from each run's metrics.jsonl, so a run still training can be plotted.

    python -m mjx_skills.plot RUN_DIR                  # writes RUN_DIR/curve.png
    python -m mjx_skills.plot RUN_A RUN_B --out ab.png # several runs in one figure
    python -m mjx_skills.plot RUN_DIR --metric train_success --x epoch

Only the figure is written (`--out`; for one run by default RUN_DIR/curve.png).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from mjx_skills.analysis import stats
from mjx_skills.training.metrics_log import read_metrics

X_AXES = ("env_steps", "epoch")
"""What the x-axis counts: task env steps (evaluation not counted) or epochs."""


def curves(run_dir: Path, metric: str = "eval_success") -> tuple[np.ndarray, np.ndarray]:
    """(epochs,) env steps at each epoch's end and (seeds, epochs) `metric` of a run.
    ValueError naming the run for a missing or empty metrics.jsonl or an unknown metric
    (listing those logged)."""
    path = Path(run_dir) / "metrics.jsonl"
    if not path.exists():
        raise ValueError(f"{run_dir}: no metrics.jsonl (not a run directory, or no epoch yet)")
    rows = read_metrics(run_dir)
    if not rows:
        raise ValueError(f"{run_dir}: metrics.jsonl has no epoch yet")
    if metric not in rows[0]:
        valid = ", ".join(sorted(k for k, v in rows[0].items() if isinstance(v, (int, float))))
        raise ValueError(f"{run_dir}: unknown metric {metric!r}; logged: {valid}")
    done = min(max(r["epoch"] for r in rows if r["seed"] == s) for s in {r["seed"] for r in rows})
    rows = [r for r in rows if r["epoch"] <= done]  # a run mid-epoch: the epochs every seed has
    steps = {r["epoch"]: r["env_steps"] for r in rows}
    return np.array([steps[e] for e in sorted(steps)]), stats.scores_from_rows(rows, metric)


def plot(runs: list[Path], out: Path, metric: str = "eval_success", x: str = "env_steps") -> Path:
    """Draw the runs' curves into `out` (PNG) and return it. ValueError: see `curves`, or an
    x-axis not in `X_AXES`."""
    if x not in X_AXES:
        raise ValueError(f"unknown x-axis {x!r}; valid: {', '.join(X_AXES)}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for i, run in enumerate(runs):
        steps, scores = curves(run, metric)
        at = steps if x == "env_steps" else np.arange(1, len(steps) + 1)
        for seed in scores:
            ax.plot(at, seed, color=f"C{i}", alpha=0.25, linewidth=0.8)
        label = f"{Path(run).name} ({len(scores)} seed{'s' if len(scores) > 1 else ''})"
        ax.plot(at, scores.mean(axis=0), color=f"C{i}", linewidth=2, label=label)
    ax.set_xlabel("env steps" if x == "env_steps" else "epoch")
    ax.set_ylabel(metric.replace("_", " "))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("runs", nargs="+", type=Path, help="run directories")
    parser.add_argument("--out", type=Path, help="PNG to write (default: RUN_DIR/curve.png)")
    parser.add_argument("--metric", default="eval_success", help="a logged metric")
    parser.add_argument("--x", default="env_steps", choices=X_AXES)
    args = parser.parse_args(argv)
    if args.out is None and len(args.runs) > 1:
        parser.error("several runs: say where the figure goes with --out FILE.png")
    out = args.out or args.runs[0] / "curve.png"
    try:
        print(plot(args.runs, out, args.metric, args.x))
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
