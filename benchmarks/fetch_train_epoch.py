"""A DDPG+HER training epoch of a Fetch task on each physics backend: what compiling and
running it costs, and that it runs (the smallest epoch: `--envs` envs x 1 cycle, 5 updates,
`--eval-episodes` evaluation episodes, one seed).

    python benchmarks/fetch_train_epoch.py [--tasks fetch_reach ...] [--physics native mjx]

Each (task, physics) is measured in a process of its own (its peak memory is its own): the
epoch program is built and compiled (`compile_s`, the persistent cache off), run once
(`epoch_s`, timed after a warm-up epoch for native, whose compile is short; MJX's first epoch
is timed, since one MJX epoch costs minutes on a CPU), and the process's peak resident memory
is read (`peak_rss_gb`, compile included). `env_steps_per_s` counts training and evaluation
steps. One JSON row per run (benchmarks/results/fetch_train_epoch.jsonl). On a CPU an MJX row
costs about ten minutes: MJX is for accelerators, and a device has not measured it yet.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time

os.environ.setdefault("MJX_SKILLS_CACHE_DIR", "off")  # compile_s is a real compile

TASKS = ("fetch_reach", "fetch_push", "fetch_pick_and_place")
"""The Fetch tasks both backends run (Slide: `envs.fetch_mjx.MJX_REFUSALS`)."""


def measure(task: str, physics: str, envs: int, eval_episodes: int) -> dict:
    """One row, in this process."""
    import jax

    from mjx_skills.config import EnvConfig, TrainConfig
    from mjx_skills.training import epoch

    train = TrainConfig(
        task=task,
        envs=envs,
        cycles=1,
        updates_per_cycle=5,
        eval_episodes=eval_episodes,
        replay_capacity=2000,
        seeds=1,
    )
    start = time.perf_counter()
    env, _, epoch_fn, carry = epoch.build("ddpg_her", train, EnvConfig(physics=physics))
    compiled = epoch_fn.lower(carry, None).compile()
    compile_s = time.perf_counter() - start
    if physics == "native":
        carry, _ = compiled(carry, None)
        jax.block_until_ready(carry)
    start = time.perf_counter()
    carry, metrics = compiled(carry, None)
    jax.block_until_ready(metrics)
    epoch_s = time.perf_counter() - start
    steps = (envs + eval_episodes) * env.episode_length
    return {
        "task": task,
        "physics": physics,
        "backend": env.backend.name,
        "compiler_options": env.backend.compiler_options,
        "envs": envs,
        "eval_episodes": eval_episodes,
        "compile_s": round(compile_s, 1),
        "epoch_s": round(epoch_s, 2),
        "env_steps_per_s": round(steps / epoch_s, 2),
        "peak_rss_gb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20, 2),
        "eval_success": float(metrics["eval_success"][0]),
        "cores": len(os.sched_getaffinity(0)),
        "device": jax.devices()[0].platform,
        "jax": jax.__version__,
        "machine": platform.machine(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS)
    parser.add_argument(
        "--physics", nargs="+", default=["native", "mjx"], choices=["native", "mjx"]
    )
    parser.add_argument("--envs", type=int, default=2)
    parser.add_argument("--eval-episodes", type=int, default=2)
    parser.add_argument("--one", nargs=2, metavar=("TASK", "PHYSICS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        row = measure(*args.one, envs=args.envs, eval_episodes=args.eval_episodes)
        print(json.dumps(row), flush=True)
        return
    for task in args.tasks:
        for physics in args.physics:
            argv = [
                sys.executable,
                __file__,
                "--one",
                task,
                physics,
                "--envs",
                str(args.envs),
                "--eval-episodes",
                str(args.eval_episodes),
            ]
            out = subprocess.run(argv, check=True, stdout=subprocess.PIPE, text=True).stdout
            print(out.strip().splitlines()[-1], flush=True)


if __name__ == "__main__":
    main()
