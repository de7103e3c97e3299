"""Time `make train TASK=pick_move` as a user runs it, and keep its learning curve.

    python benchmarks/make_train_time.py
    python benchmarks/make_train_time.py --method ddpg_her_sl_fast --epochs 40

Runs the command (`METHOD=...`, `EPOCHS=...` when given) with OUT in a fresh directory,
copies the run's metrics to benchmarks/results/pick_move_METHOD_make_train.jsonl, measures the final policy on
100 fresh episodes (`python -m mjx_skills.evaluate`) and prints one JSON line: {"command",
"method", "wall_s", "curve", "fresh_success", "load_before", "commit"} (load_before: the 1-minute load
average when it started, after waiting up to 3 min for it to settle below 0.5, since it lags
behind runs that have just ended; above ~0.5 on 2 cores the time is not an idle machine's). docs/benchmarks.md's "Speed" section (benchmarks/speed_report.py)
computes from the curve when the 5-epoch rolling mean of eval success first reaches 0.90
and how long after the command's start that was.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = "ddpg_her_sl"


def settled_load(below: float = 0.5, wait_s: float = 180.0) -> float:
    """The 1-minute load average once it falls below `below`, waiting at most `wait_s`: it
    lags about a minute behind runs that have just ended, which would read as contention."""
    deadline = time.monotonic() + wait_s
    while os.getloadavg()[0] >= below and time.monotonic() < deadline:
        time.sleep(5)
    return os.getloadavg()[0]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--method", default=DEFAULT, help="METHOD= (default: make's, ddpg_her_sl)")
    p.add_argument("--epochs", type=int, help="EPOCHS= (default: make's, 100)")
    args = p.parse_args()
    curve = f"benchmarks/results/pick_move_{args.method}_make_train.jsonl"
    make = ["make", "train", "TASK=pick_move"]
    make += [] if args.method == DEFAULT else [f"METHOD={args.method}"]
    make += [] if args.epochs is None else [f"EPOCHS={args.epochs}"]
    load = settled_load()
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True, capture_output=True
    ).stdout.strip()
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        subprocess.run([*make, f"OUT={out}"], cwd=ROOT, check=True)
        wall = time.perf_counter() - t0
        (metrics,) = Path(out).glob(f"pick_move/{args.method}/*/metrics.jsonl")
        shutil.copy(metrics, ROOT / curve)
        evaluated = subprocess.run(
            [
                str(ROOT / ".venv" / "bin" / "python"),
                "-m",
                "mjx_skills.evaluate",
                str(metrics.parent),
                "--episodes",
                "100",
            ],
            cwd=ROOT,
            check=True,
            capture_output=True,
            text=True,
        )
        fresh = json.loads(evaluated.stdout.strip().splitlines()[-1])["success"]
    print(
        json.dumps(
            {
                "command": " ".join(make),
                "method": args.method,
                "wall_s": round(wall, 1),
                "curve": curve,
                "fresh_success": fresh,
                "load_before": round(load, 2),
                "commit": commit,
            }
        )
    )


if __name__ == "__main__":
    main()
