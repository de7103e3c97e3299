"""Replay a trained run's final policy on the gymnasium adapter (native `mj_step`, the JAX
env's reset) from fresh seeds, and compare with the run's own last eval_success.

python experiments/replay_gym.py RUN_DIR [--episodes 50] [--seed 10000]

Prints one JSON line per trained seed: {"seed", "gym_success", "eval_success_last5"}.
For methods whose evaluation is the flat DDPG actor (ddpg_her, ddpg_her_sl).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import jax
import numpy as np

from mjx_skills import compile_cache, ddpg
from mjx_skills.envs.gym import BaxterGymEnv
from mjx_skills.logging import read_metrics
from mjx_skills.runner import RunArgs, load_config, train_and_keep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("run", type=Path)
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=10_000)
    args = parser.parse_args()
    compile_cache.enable()
    cfg = load_config(args.run)
    if cfg.method not in ("ddpg_her", "ddpg_her_sl"):
        raise SystemExit(f"{cfg.method}: only flat-policy runs (ddpg_her, ddpg_her_sl) replay here")
    _, carry = train_and_keep(RunArgs(resume=str(args.run)))
    ddpg_cfg = cfg.full_options()["ddpg"]
    env = BaxterGymEnv(cfg.train.task, **_env_overrides(cfg.env))
    rows = read_metrics(args.run)
    last = max(r["epoch"] for r in rows)
    for s in range(cfg.train.seeds):
        agent = jax.tree.map(lambda x, s=s: x[s], carry.agent)
        act = jax.jit(lambda o, g, agent=agent: ddpg.act(agent, o, g, ddpg_cfg))
        wins = []
        for e in range(args.episodes):
            obs, _ = env.reset(seed=args.seed + e)
            for _ in range(env.task.episode_length):
                a = np.asarray(act(obs["observation"], obs["desired_goal"]))
                obs, _, _, _, info = env.step(a)
            wins.append(bool(info["is_success"]))
        own = [r["eval_success"] for r in rows if r["seed"] == s and r["epoch"] > last - 5]
        print(json.dumps({"seed": s, "gym_success": float(np.mean(wins)),
                          "eval_success_last5": float(np.mean(own)), "episodes": args.episodes}))  # fmt: skip


def _env_overrides(env_cfg) -> dict:
    """The run's EnvConfig fields other than the backend (the adapter is native)."""
    import dataclasses

    fields = dataclasses.asdict(env_cfg)
    fields.pop("physics")
    return fields


if __name__ == "__main__":
    main()
