"""Wall time of a sweep with one cell at a time against `--jobs N` cells at once, in one run.

    python benchmarks/sweep_parallel.py [--experiment smoke] [--jobs 2] [--epochs E]

Runs `python -m mjx_skills.sweep --experiment NAME` three times from scratch, in fresh
directories, with JAX's persistent compilation cache off: `--jobs 1`, `--jobs N` (workers
unpinned, the default) and `--jobs N --pin`. Checks that all wrote the same results (every
metric of every seed and epoch equal, bitwise, but the wall-clock column) and prints one
JSON line: {"experiment", "cells", "jobs", "serial_s", "parallel_s", "speedup",
"pinned_s", "speedup_pinned", "identical"}.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(experiment: str, jobs: int, root: Path, extra: list[str]) -> tuple[float, list[dict]]:
    """Wall seconds of one sweep and its per-seed rows without the wall-clock column."""
    env = {**os.environ, "MJX_SKILLS_CACHE_DIR": "off"}
    cmd = [
        sys.executable,
        "-m",
        "mjx_skills.sweep",
        "--experiment",
        experiment,
        "--jobs",
        str(jobs),
        "--sweep-dir",
        str(root / "cells"),
        "--results",
        str(root / "results"),
        "--no-progress",
        *extra,
    ]
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    rows = [json.loads(line) for line in (root / "results" / f"{experiment}.jsonl").open()]
    return wall, [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--experiment", default="smoke")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--epochs", type=int, help="override the experiment's epochs")
    args = parser.parse_args()
    extra = ["--epochs", str(args.epochs)] if args.epochs else []
    with tempfile.TemporaryDirectory() as tmp:
        serial_s, serial = run(args.experiment, 1, Path(tmp) / "serial", extra)
        parallel_s, parallel = run(args.experiment, args.jobs, Path(tmp) / "parallel", extra)
        pinned_s, pinned = run(args.experiment, args.jobs, Path(tmp) / "pinned", [*extra, "--pin"])
    key = lambda r: (r["task"], r["method"], r["library"], r["epoch"], r["seed"])
    same = lambda a, b: sorted(a, key=key) == sorted(b, key=key)
    print(
        json.dumps(
            {
                "experiment": args.experiment,
                "cells": len({key(r)[:3] for r in serial}),
                "jobs": args.jobs,
                "cores": os.cpu_count(),
                "serial_s": round(serial_s, 1),
                "epochs": args.epochs,
                "parallel_s": round(parallel_s, 1),
                "speedup": round(serial_s / parallel_s, 3),
                "pinned_s": round(pinned_s, 1),
                "speedup_pinned": round(serial_s / pinned_s, 3),
                "identical": same(serial, parallel) and same(serial, pinned),
            }
        )
    )


if __name__ == "__main__":
    main()
