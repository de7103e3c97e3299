"""Run a sweep and set its wall time beside the cost model's estimate for it.

    python benchmarks/confirm_estimate.py --tasks pick_move --methods mpas pas ddpg_her \
        ddpg_her_sl --seeds 5 --epochs 100 --jobs 2 --name fig6_3_pick_move

Prints the estimate first (`mjx_skills.sweeps.cost`, from benchmarks/results/epoch_cost.jsonl),
then runs `python -m mjx_skills.sweep` with the same grid (resumable: a rerun picks up the
finished cells, and then the wall time is not a whole run's) and prints one JSON line:
{"name", "jobs", "estimate_s", "wall_s", "error": wall / estimate - 1, "cells": {...}}.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mjx_skills.sweeps import cost
from mjx_skills.sweeps.experiments import adhoc

RESULTS = Path(__file__).resolve().parent / "results"
"""Where the sweep's CSV and per-seed JSONL go (speed_report reads the epoch-1 times)."""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--tasks", nargs="+", required=True)
    p.add_argument("--methods", nargs="+", required=True)
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--epochs", type=int, default=100)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--name", required=True)
    args = p.parse_args()
    exp = adhoc(args.name, args.tasks, args.methods).with_budget(args.seeds, args.epochs)
    est = cost.estimate(exp, args.jobs, from_scratch=True)
    print(json.dumps({"estimate": est}), flush=True)
    cmd = [
        sys.executable,
        "-m",
        "mjx_skills.sweep",
        "--name",
        args.name,
        "--tasks",
        *args.tasks,
        "--methods",
        *args.methods,
        "--seeds",
        str(args.seeds),
        "--epochs",
        str(args.epochs),
        "--jobs",
        str(args.jobs),
        "--no-progress",
        "--overwrite",
        # Every cell trained (a fresh store), its per-seed rows beside the benchmark's.
        "--store",
        tempfile.mkdtemp(),
        "--results",
        str(RESULTS),
    ]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - t0
    print(
        json.dumps(
            {
                "name": args.name,
                "jobs": args.jobs,
                "seeds": args.seeds,
                "epochs": args.epochs,
                "estimate_s": est["wall_s"],
                "wall_s": round(wall),
                "error": round(wall / est["wall_s"] - 1, 3),
                "cells": est["cells"],
                "command": " ".join(["python -m mjx_skills.sweep", *cmd[3:]]),
            }
        )
    )


if __name__ == "__main__":
    main()
