"""Env steps per second of the whole jitted DDPG+HER epoch (physics, replay, relabelling,
updates, evaluation) at several numbers of parallel envs.

    python benchmarks/train_throughput.py [--task pick_move] [--envs 16 64 256] [--epochs 2]

One JSON row per env count; the last line is the row for the largest count (256 by default).
`env_steps_per_s` counts training and evaluation steps; `updates_per_s` the epoch's gradient
steps (40 per epoch here) per second of the whole epoch; `pure_updates_per_s` gradient steps
per second alone (default networks, with LayerNorm). Two rows before them give the update
alone with and without LayerNorm: its FLOPs (XLA's count), the GFLOP/s it reaches, and the
ratio to a chain of matmuls of the hidden layers' shape measured in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import jax

from mjx_skills.config import DDPGConfig, EnvConfig, TrainConfig
from mjx_skills.core import compile_cache
from mjx_skills.training.epoch import build


def timed_epochs(epoch_fn, carry, aux, epochs: int) -> tuple[float, float]:
    """-> (compile seconds, wall seconds of `epochs` epochs after one warm-up epoch)."""
    t0 = time.perf_counter()
    epoch_fn = epoch_fn.lower(carry, aux).compile()
    compile_s = time.perf_counter() - t0
    carry, metrics = epoch_fn(carry, aux)  # warm-up
    jax.block_until_ready(metrics)
    t0 = time.perf_counter()
    for _ in range(epochs):
        carry, metrics = epoch_fn(carry, aux)
    jax.block_until_ready(metrics)
    return compile_s, time.perf_counter() - t0


def measure(task: str, envs: int, epochs: int, physics: str) -> dict:
    cfg = TrainConfig(
        task=task,
        envs=envs,
        cycles=1,
        updates_per_cycle=40,
        eval_episodes=envs,
        replay_capacity=200_000,
        progress=False,
    )
    env, _, epoch_fn, carry = build("ddpg_her", cfg, EnvConfig(physics=physics))
    compile_s, wall = timed_epochs(epoch_fn, carry, None, epochs)
    steps = epochs * (cfg.envs * cfg.cycles + cfg.eval_episodes) * env.episode_length
    updates = epochs * cfg.cycles * cfg.updates_per_cycle
    return {
        "task": task,
        "envs": envs,
        "physics": env.backend.name,
        "cores": os.cpu_count(),
        "env_steps_per_s": round(steps / wall, 1),
        "updates_per_s": round(updates / wall, 1),
        "epoch_s": round(wall / epochs, 3),
        "compile_s": round(compile_s, 1),
    }


def pure_updates(layer_norm: bool, obs_dim: int = 25, n: int = 1000) -> dict:
    """Gradient steps per second alone, as the trainer runs them (`ddpg.update` on n batches
    sampled beforehand), with XLA's FLOP count per step and the GFLOP/s that makes. Batch
    128, 3 x 64 nets."""
    import jax.numpy as jnp

    from mjx_skills.agents import ddpg

    cfg = DDPGConfig(layer_norm=layer_norm)
    key = jax.random.PRNGKey(0)
    agent = ddpg.init(key, obs_dim, 3, 4, cfg)
    b = cfg.batch_size
    batches = {
        "obs": jax.random.normal(key, (n, b, obs_dim)),
        "next_obs": jax.random.normal(key, (n, b, obs_dim)),
        "goal": jax.random.normal(key, (n, b, 3)),
        "action": jax.random.uniform(key, (n, b, 4)),
        "reward": -jnp.ones((n, b)),
    }
    update = jax.jit(lambda a, bs: ddpg.update(a, bs, cfg)[0])
    run = update.lower(agent, batches).compile()
    one = update.lower(agent, jax.tree.map(lambda x: x[:1], batches)).compile()
    flops = one.cost_analysis()["flops"]
    rate = _best_rate(lambda: run(agent, batches), n)
    return {
        "updates_per_s": round(rate, 1),
        "mflop_per_update": round(flops / 1e6, 2),
        "update_gflops": round(rate * flops / 1e9, 1),
    }


def matmul_gflops(n: int = 5000) -> float:
    """Reference: GFLOP/s of a chain of (128 x 64) @ (64 x 64) matmuls + tanh, the shape of
    the networks' hidden layers: the most the update's arithmetic can run at here."""
    import jax.numpy as jnp

    x = jax.random.normal(jax.random.PRNGKey(0), (128, 64))
    w = jax.random.normal(jax.random.PRNGKey(1), (64, 64)) / 8.0
    chain = jax.jit(lambda x, w: jax.lax.fori_loop(0, n, lambda i, x: jnp.tanh(x @ w), x))
    chain = chain.lower(x, w).compile()
    return _best_rate(lambda: chain(x, w), n) * 2 * 128 * 64 * 64 / 1e9


def _best_rate(fn, n: int, repeats: int = 3) -> float:
    """n / the fastest of `repeats` timed calls (after one warm-up): the machine is shared."""
    jax.block_until_ready(fn())
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - t0)
    return n / min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--task", default="pick_move")
    parser.add_argument("--envs", type=int, nargs="+", default=[16, 64, 256])
    parser.add_argument("--epochs", type=int, default=2)
    parser.add_argument("--physics", default="auto")
    args = parser.parse_args()
    compile_cache.enable()
    peak = round(matmul_gflops(), 1)
    updates = {}
    for layer_norm in (True, False):
        u = pure_updates(layer_norm)
        updates[layer_norm] = u
        print(
            json.dumps(
                {
                    "layer_norm": layer_norm,
                    **u,
                    "matmul_gflops": peak,
                    "ratio_to_matmul": round(u["update_gflops"] / peak, 2),
                }
            ),
            flush=True,
        )
    row = {}
    for envs in args.envs:
        row = {
            **measure(args.task, envs, args.epochs, args.physics),
            "pure_updates_per_s": updates[True]["updates_per_s"],
        }
        print(json.dumps(row), flush=True)
    print(json.dumps(row))


if __name__ == "__main__":
    main()
