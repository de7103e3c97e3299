"""Env steps per second of one training epoch of every method, against DDPG+HER's measured
in the same run (the default budget: 4 envs x 4 cycles + 20 eval episodes per epoch).

    python benchmarks/methods_throughput.py [--task take_out] [--epochs 3]

One JSON row per method (and DDPG+HER+SL again with `--search.leaf-state goal`), then a
summary row with each one's ratio to DDPG+HER. Library
methods use the committed skill library (experiments/skill_library). Compile time is
reported apart; the epochs are timed after one warm-up epoch.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os

from train_throughput import timed_epochs  # the sibling script (benchmarks/ is on sys.path)

from mjx_skills import methods
from mjx_skills.config import EnvConfig, TrainConfig
from mjx_skills.core import compile_cache
from mjx_skills.training.epoch import build


def measure(method: str, task: str, epochs: int, leaf_state: str | None = None) -> dict:
    """One method's epochs; `leaf_state` (DDPG+HER+SL only) overrides the search's."""
    cfg = TrainConfig(task=task, progress=False)
    spec = methods.get(method)
    options = dict(spec.options)
    if leaf_state:
        options["search"] = dataclasses.replace(options["search"], leaf_state=leaf_state)
    aux = spec.load_aux(options)
    env, _, epoch_fn, carry = build(method, cfg, EnvConfig(), options, aux)
    compile_s, wall = timed_epochs(epoch_fn, carry, aux, epochs)
    steps = epochs * (cfg.envs * cfg.cycles + cfg.eval_episodes) * env.episode_length
    return {
        "method": method,
        "task": task,
        "cores": os.cpu_count(),
        "env_steps_per_s": round(steps / wall, 1),
        "epoch_s": round(wall / epochs, 3),
        "compile_s": round(compile_s, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--task", default="take_out")
    parser.add_argument("--epochs", type=int, default=3)
    parser.add_argument("--methods", nargs="+", default=list(methods.METHODS))
    args = parser.parse_args()
    compile_cache.enable()
    rows = {m: measure(m, args.task, args.epochs) for m in args.methods}
    if "ddpg_her_sl" in rows:  # the search's cheap leaves (`--search.leaf-state goal`)
        rows["ddpg_her_sl_leaf_goal"] = {
            **measure("ddpg_her_sl", args.task, args.epochs, "goal"),
            "method": "ddpg_her_sl_leaf_goal",
        }
    for row in rows.values():
        print(json.dumps(row))
    if "ddpg_her" in rows:
        ref = rows["ddpg_her"]["env_steps_per_s"]
        ratios = {m: round(r["env_steps_per_s"] / ref, 3) for m, r in rows.items()}
        print(json.dumps({"task": args.task, "ratio_to_ddpg_her": ratios}))


if __name__ == "__main__":
    main()
