"""Plot eval success per epoch (mean and range over seeds) from runs' metrics.jsonl files.

python experiments/plot.py RUN_DIR_OR_JSONL [...] --out curve.png [--x env_steps|epoch|wall_s]
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load(path: Path) -> list[dict]:
    path = path / "metrics.jsonl" if path.is_dir() else path
    return [json.loads(line) for line in path.read_text().splitlines() if line]


def curve(rows: list[dict], x: str):
    """-> x values, mean, min, max of eval_success over seeds per epoch."""
    by_epoch = defaultdict(list)
    xs = {}
    for r in rows:
        by_epoch[r["epoch"]].append(r["eval_success"])
        xs[r["epoch"]] = r[x]
    epochs = sorted(by_epoch)
    vals = [np.asarray(by_epoch[e]) for e in epochs]
    return (
        np.asarray([xs[e] for e in epochs]),
        np.asarray([v.mean() for v in vals]),
        np.asarray([v.min() for v in vals]),
        np.asarray([v.max() for v in vals]),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, default=Path("curve.png"))
    parser.add_argument("--x", default="env_steps", choices=["env_steps", "epoch", "wall_s"])
    parser.add_argument("--labels", nargs="*")
    args = parser.parse_args()
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for i, run in enumerate(args.runs):
        rows = load(run)
        label = args.labels[i] if args.labels else f"{rows[0].get('task', '')} {run.name}"
        x, mean, low, high = curve(rows, args.x)
        ax.plot(x, mean, label=label)
        ax.fill_between(x, low, high, alpha=0.2)
    ax.set_xlabel(args.x.replace("_", " "))
    ax.set_ylabel("eval success (20 episodes)")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(args.out)


if __name__ == "__main__":
    main()
