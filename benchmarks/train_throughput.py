"""Env steps per second of the whole jitted DDPG+HER epoch (physics, replay, relabelling,
updates, evaluation) at several numbers of parallel envs.

    python benchmarks/train_throughput.py [--task pick_move] [--envs 16 64 256] [--epochs 2]

One JSON row per env count; the last line is the row for the largest count (256 by default).
`env_steps_per_s` counts training and evaluation steps; `updates_per_s` the epoch's gradient
steps (40 per epoch here) per second of the whole epoch; `pure_updates_per_s` gradient steps
per second alone.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import jax

from mjx_skills.config import DDPGConfig, EnvConfig, TrainConfig
from mjx_skills.train import build


def measure(task: str, envs: int, epochs: int, physics: str) -> dict:
    cfg = TrainConfig(task=task, envs=envs, cycles=1, updates_per_cycle=40, eval_episodes=envs,
                      replay_capacity=200_000, progress=False)  # fmt: skip
    env, epoch_fn, carry = build(cfg, EnvConfig(physics=physics), DDPGConfig())
    t0 = time.perf_counter()
    epoch_fn = epoch_fn.lower(carry).compile()
    compile_s = time.perf_counter() - t0
    carry, _ = epoch_fn(carry)  # warm-up
    jax.block_until_ready(carry)
    t0 = time.perf_counter()
    for _ in range(epochs):
        carry, metrics = epoch_fn(carry)
    jax.block_until_ready(metrics)
    wall = time.perf_counter() - t0
    steps = epochs * (cfg.envs * cfg.cycles + cfg.eval_episodes) * env.episode_length
    updates = epochs * cfg.cycles * cfg.updates_per_cycle
    return {
        "task": task, "envs": envs, "physics": env.backend.name, "cores": os.cpu_count(),
        "env_steps_per_s": round(steps / wall, 1), "updates_per_s": round(updates / wall, 1),
        "epoch_s": round(wall / epochs, 3), "compile_s": round(compile_s, 1),
    }  # fmt: skip


def pure_updates_per_s(obs_dim: int = 25, n: int = 500) -> float:
    """DDPG+HER gradient steps per second alone (batch 128, sample + relabel excluded)."""
    from mjx_skills import ddpg

    cfg = DDPGConfig()
    key = jax.random.PRNGKey(0)
    agent = ddpg.init(key, obs_dim, 3, 4, cfg)
    b = cfg.batch_size
    batch = {"obs": jax.random.normal(key, (b, obs_dim)), "next_obs": jax.random.normal(key, (b, obs_dim)),
             "goal": jax.random.normal(key, (b, 3)), "action": jax.random.uniform(key, (b, 4)),
             "reward": -jax.numpy.ones(b)}  # fmt: skip
    run = jax.jit(
        lambda a: jax.lax.scan(
            lambda a, _: (ddpg.update(a, batch, cfg)[0], None), a, None, length=n
        )[0]
    )
    jax.block_until_ready(run(agent))
    t0 = time.perf_counter()
    jax.block_until_ready(run(agent))
    return n / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--task", default="pick_move")
    parser.add_argument("--envs", type=int, nargs="+", default=[16, 64, 256])
    parser.add_argument("--epochs", type=int, default=2)
    parser.add_argument("--physics", default="auto")
    args = parser.parse_args()
    row, updates = {}, round(pure_updates_per_s(), 1)
    for envs in args.envs:
        row = {**measure(args.task, envs, args.epochs, args.physics), "pure_updates_per_s": updates}
        print(json.dumps(row), flush=True)
    print(json.dumps(row))


if __name__ == "__main__":
    main()
