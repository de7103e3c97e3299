"""Time `make train TASK=pick_move` as a user runs it, and keep its learning curve.

    python benchmarks/make_train_time.py

Runs the command with OUT in a fresh directory, copies the run's metrics to
experiments/results/pick_move_ddpg_her_sl_make_train.jsonl, measures the final policy on
100 fresh episodes (`python -m mjx_skills.evaluate`) and prints one JSON line: {"command",
"wall_s", "curve", "fresh_success", "load_before", "commit"} (load_before: the 1-minute load
average when it started; above ~0.5 on 2 cores the time is not an idle machine's). docs/benchmarks.md's "Speed" section (benchmarks/speed_report.py)
computes from the curve when the 5-epoch rolling mean of eval success first reaches 0.90
and how long after the command's start that was.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CURVE = "experiments/results/pick_move_ddpg_her_sl_make_train.jsonl"


def main() -> None:
    load = os.getloadavg()[0]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True,
                            capture_output=True).stdout.strip()  # fmt: skip
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        subprocess.run(["make", "train", "TASK=pick_move", f"OUT={out}"], cwd=ROOT, check=True)
        wall = time.perf_counter() - t0
        (metrics,) = Path(out).glob("pick_move/ddpg_her_sl/*/metrics.jsonl")
        shutil.copy(metrics, ROOT / CURVE)
        evaluated = subprocess.run(
            [str(ROOT / ".venv" / "bin" / "python"), "-m", "mjx_skills.evaluate", str(metrics.parent),
             "--episodes", "100"], cwd=ROOT, check=True, capture_output=True, text=True)  # fmt: skip
        fresh = json.loads(evaluated.stdout.strip().splitlines()[-1])["success"]
    print(json.dumps({"command": "make train TASK=pick_move", "wall_s": round(wall, 1),
                      "curve": CURVE, "fresh_success": fresh, "load_before": round(load, 2),
                      "commit": commit}))  # fmt: skip


if __name__ == "__main__":
    main()
