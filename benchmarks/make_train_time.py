"""Time `make train TASK=pick_move` as a user runs it, and keep its learning curve.

    python benchmarks/make_train_time.py

Runs the command with OUT in a fresh directory, copies the run's metrics to
experiments/results/pick_move_ddpg_her_sl_make_train.jsonl and prints one JSON line:
{"command", "wall_s", "curve"}. docs/benchmarks.md's "Speed" section (benchmarks/speed_report.py)
computes from the curve when the 5-epoch rolling mean of eval success first reaches 0.90
and how long after the command's start that was.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CURVE = "experiments/results/pick_move_ddpg_her_sl_make_train.jsonl"


def main() -> None:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        subprocess.run(["make", "train", "TASK=pick_move", f"OUT={out}"], cwd=ROOT, check=True)
        wall = time.perf_counter() - t0
        (metrics,) = Path(out).glob("pick_move/ddpg_her_sl/*/metrics.jsonl")
        shutil.copy(metrics, ROOT / CURVE)
    print(json.dumps({"command": "make train TASK=pick_move", "wall_s": round(wall, 1),
                      "curve": CURVE}))  # fmt: skip


if __name__ == "__main__":
    main()
