"""Our DDPG+HER against Stable-Baselines3 DDPG+HER and SAC+HER, same task, same machine,
same process, same number of env steps.

    pip install -e '.[bench]'    # torch 2.13.0 (CPU), stable-baselines3, gymnasium
    python benchmarks/peer_sb3.py [--tasks transit pick_move] [--epochs 20] [--seeds 3]

Both sides: actor and critic 3 x 64 ReLU without LayerNorm (SB3's networks have none),
batch 128, gamma 0.98, tau 0.05, Adam 1e-3, HER "future" with k = 4 (relabel share 0.8),
Gaussian action noise sigma 0.2. SB3 runs our gymnasium adapter (mjx_skills.envs.gym), the
same XML and task logic on native MuJoCo. Both clocks run for training only: evaluation
(20 episodes, deterministic policy, success at the last step) stops them.

- Throughput: training env steps per second with updates included, both sides at one
  gradient update per env step. SB3 steps one env and is timed after its 1,000 random
  warm-up steps (no updates there). Ours collects a cycle of N parallel episodes (N = 16 and
  64 by default), then runs as many updates as that took env steps.
- Learning: eval success after every 16 training episodes, against env steps and
  wall-clock; each side at its best settings found (ours: the trainer's defaults, 1.25
  updates per env step on transit, without LayerNorm, which learned transit faster;
  SB3: one update per step after 1,000 random steps).

One JSON row per (task, algorithm, seed); the last line is the transit summary, medians over
seeds: `ratio` (our env steps/s over SB3 DDPG's) and the seconds of training each side
needed to first reach 90 % (ours with its build and compile included, and `_warm_s` without
them, as with a warm compilation cache). Run with MJX_SKILLS_CACHE_DIR=off for a truly cold
compile.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import gymnasium
import jax
import numpy as np

import mjx_skills.envs.gym  # noqa: F401  (registers MjxSkills/*-v0)
from mjx_skills.config import DDPGConfig, EnvConfig, TrainConfig
from mjx_skills.core import compile_cache
from mjx_skills.envs import ENVS, make
from mjx_skills.envs.gym import gym_id
from mjx_skills.methods.ddpg_her import make_ddpg_her
from mjx_skills.training.epoch import init_carry, make_evaluate, make_train_cycles

EPISODES_PER_EPOCH, EVAL_EPISODES = 16, 20


def time_to(curve: list[dict], level: float = 0.9, key: str = "wall_s") -> float | None:
    """`key` (wall_s or env_steps) of the first evaluation at or above `level`."""
    return next((p[key] for p in curve if p["eval_success"] >= level), None)


def _compiled_cycles(cfg: TrainConfig, agent_cfg: DDPGConfig):
    """-> (env, learner, initial carry, compiled train_cycles) for one seed."""
    env = make(cfg.task, EnvConfig())
    learner = make_ddpg_her(env, cfg, agent_cfg)
    carry = jax.jit(lambda k: init_carry(learner, env, cfg, k))(jax.random.PRNGKey(cfg.seed))
    cycles_fn = jax.jit(make_train_cycles(learner, env, cfg), donate_argnums=0)
    return env, learner, carry, cycles_fn.lower(carry).compile()


def ours_matched_throughput(task: str, envs: int, seed: int = 0, min_steps: int = 4000) -> float:
    """Training env steps per second at one update per env step: each cycle collects `envs`
    episodes, then runs as many updates as it took env steps. Networks without LayerNorm,
    as SB3's."""
    T = ENVS[task].default_episode_length
    cfg = TrainConfig(
        task=task,
        replay_capacity=200_000,
        progress=False,
        seed=seed,
        envs=envs,
        cycles=1,
        updates_per_cycle=envs * T,
    )
    _, _, carry, cycles_fn = _compiled_cycles(cfg, DDPGConfig(layer_norm=False))
    carry, _ = cycles_fn(carry)  # the first cycle fills the buffer from empty; not timed
    jax.block_until_ready(carry)
    n = max(3, -(-min_steps // (envs * T)))
    t0 = time.perf_counter()
    for _ in range(n):
        carry, _ = cycles_fn(carry)
    jax.block_until_ready(carry)
    return n * envs * T / (time.perf_counter() - t0)


def run_ours(task: str, epochs: int, layer_norm: bool, seed: int = 0) -> dict:
    """Our trainer at its defaults (4 cycles of 4 episodes, 100 updates each) -> learning
    curve and throughput. The clock runs for training only: the 20 evaluation episodes are a
    separate jitted call outside it, as SB3's are."""
    cfg = TrainConfig(task=task, replay_capacity=200_000, progress=False, seed=seed)
    agent_cfg = DDPGConfig(layer_norm=layer_norm)
    t0 = time.perf_counter()
    env, learner, carry, cycles_fn = _compiled_cycles(cfg, agent_cfg)
    compile_s = time.perf_counter() - t0  # build + compile: what a cold start pays once
    evaluate = jax.jit(make_evaluate(learner, env, cfg))
    jax.block_until_ready(evaluate(carry.agent, None, carry.key))  # its compile: not timed either
    curve, steps, train_s = [], cfg.envs * cfg.cycles * env.episode_length, 0.0
    for epoch in range(1, epochs + 1):
        t_epoch = time.perf_counter()
        carry, _ = cycles_fn(carry)
        jax.block_until_ready(carry)
        train_s += time.perf_counter() - t_epoch
        metrics = evaluate(carry.agent, None, jax.random.fold_in(jax.random.PRNGKey(10_000), epoch))
        curve.append(
            {
                "env_steps": epoch * steps,
                "wall_s": compile_s + train_s,
                "train_s": train_s,
                "eval_success": float(metrics["eval_success"]),
            }
        )
    updates = cfg.cycles * cfg.updates_per_cycle
    return {
        "env_steps_per_s": steps * epochs / train_s,
        "updates_per_env_step": updates / steps,
        "layer_norm": layer_norm,
        "compile_s": compile_s,
        "curve": curve,
    }


LEARNING_STARTS = 1000
"""SB3's random steps before its first update; its throughput is timed after them."""


class _Eval:
    """SB3 callback: every epoch's worth of env steps, 20 deterministic episodes; and the
    training clock at the first update (evaluation time excluded throughout)."""

    def __init__(self, task: str, every: int):
        from stable_baselines3.common.callbacks import BaseCallback

        outer = self

        class Callback(BaseCallback):
            def _on_step(self) -> bool:
                if self.num_timesteps == LEARNING_STARTS:
                    outer.train_s_at_start = outer.train_s()
                if self.num_timesteps % every == 0:
                    outer.evaluate(self.model, self.num_timesteps)
                return True

        self.callback, self.env, self.curve = Callback(), gymnasium.make(gym_id(task)), []
        self.eval_s, self.t0, self.train_s_at_start = 0.0, time.perf_counter(), 0.0

    def train_s(self) -> float:
        return time.perf_counter() - self.t0 - self.eval_s

    def evaluate(self, model, env_steps: int) -> None:
        t_eval = time.perf_counter()
        seeds = [10_000 + i + env_steps for i in range(EVAL_EPISODES)]
        success = success_rate(model, self.env, seeds)
        self.eval_s += time.perf_counter() - t_eval
        self.curve.append(
            {"env_steps": env_steps, "wall_s": self.train_s(), "eval_success": success}
        )


def success_rate(model, env: gymnasium.Env, seeds: list[int]) -> float:
    """The share of episodes, one from each reset seed, that an SB3 `model`'s deterministic
    policy ends with `info["is_success"]` (success read at the last step)."""
    wins = 0
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        done, info = False, {}
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        wins += bool(info.get("is_success"))
    return wins / len(seeds)


def run_sb3(task: str, algo: str, total_steps: int, seed: int = 0) -> dict:
    import torch
    from stable_baselines3 import DDPG, SAC, HerReplayBuffer
    from stable_baselines3.common.noise import NormalActionNoise

    torch.set_num_threads(os.cpu_count() or 1)  # every core (2 here)
    env = gymnasium.make(gym_id(task))
    episode = env.unwrapped.task.episode_length
    common = dict(
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs=dict(n_sampled_goal=4, goal_selection_strategy="future"),
        learning_rate=1e-3,
        batch_size=128,
        gamma=0.98,
        tau=0.05,
        buffer_size=200_000,
        learning_starts=LEARNING_STARTS,
        train_freq=1,
        gradient_steps=1,
        seed=seed,
        verbose=0,
        policy_kwargs=dict(net_arch=[64, 64, 64]),
    )
    if algo == "ddpg":
        noise = NormalActionNoise(np.zeros(4), 0.2 * np.ones(4))
        model = DDPG("MultiInputPolicy", env, action_noise=noise, **common)
    else:
        model = SAC("MultiInputPolicy", env, **common)
    evaluator = _Eval(task, EPISODES_PER_EPOCH * episode)
    model.learn(total_timesteps=total_steps, callback=evaluator.callback)
    # Throughput at exactly one update per env step: the random warm-up is not counted.
    updating_s = evaluator.train_s() - evaluator.train_s_at_start
    return {
        "env_steps_per_s": (total_steps - LEARNING_STARTS) / updating_s,
        "updates_per_env_step": 1.0,
        "curve": evaluator.curve,
    }


def plot(results: dict[tuple[str, str], list[dict]], path: str) -> None:
    """Eval success against env steps and against training wall-clock, one colour per
    algorithm, one line per seed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = sorted({task for task, _ in results})
    fig, axes = plt.subplots(len(tasks), 2, figsize=(10, 3.4 * len(tasks)), squeeze=False)
    for row, task in enumerate(tasks):
        algos = [algo for t, algo in results if t == task]
        for colour, algo in enumerate(algos):
            for i, res in enumerate(results[(task, algo)]):
                xs = [p["env_steps"] for p in res["curve"]], [p["wall_s"] for p in res["curve"]]
                ys = [p["eval_success"] for p in res["curve"]]
                for col in (0, 1):
                    axes[row, col].plot(
                        xs[col],
                        ys,
                        color=f"C{colour}",
                        alpha=1.0 if i == 0 else 0.45,
                        label=algo if i == 0 else None,
                    )
        for col, label in enumerate(["env steps", "training wall-clock s (2-core CPU)"]):
            axes[row, col].set(xlabel=label, ylabel=f"{task}: eval success", ylim=(-0.02, 1.02))
            axes[row, col].grid(alpha=0.3)
            axes[row, col].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def median(values: list[float | None]) -> float | None:
    """Median with None (never reached) counted as infinitely late; None if that is the
    median."""
    m = float(np.median([np.inf if v is None else v for v in values]))
    return None if np.isinf(m) else round(m, 2)


def summarize(
    task: str, ours: list[dict], sb3: list[dict], env_steps: int, matched_envs: list[int]
) -> dict:
    """The last line: medians over seeds of throughput and time to 90 %; `ratio` at the last
    of `matched_envs`, and the rate and ratio at every one of them."""
    sb3_rate = median([r["env_steps_per_s"] for r in sb3])
    by_envs = {
        e: median([r[f"env_steps_per_s_matched_{e}_envs"] for r in ours]) for e in matched_envs
    }
    to_90 = [time_to(r["curve"]) for r in ours]
    return {
        "task": task,
        "env_steps": env_steps,
        "device": jax.default_backend(),
        "cores": os.cpu_count(),
        "seeds": len(ours),
        "updates_per_env_step": 1.0,
        "ours_envs": matched_envs[-1],
        "ours_env_steps_per_s": by_envs[matched_envs[-1]],
        "sb3_env_steps_per_s": sb3_rate,
        "ratio": round(by_envs[matched_envs[-1]] / sb3_rate, 2),
        **{f"ours_env_steps_per_s_{e}_envs": r for e, r in by_envs.items()},
        **{f"ratio_{e}_envs": round(r / sb3_rate, 2) for e, r in by_envs.items()},
        "ours_time_to_90_s": median(to_90),
        "sb3_time_to_90_s": median([time_to(r["curve"]) for r in sb3]),
        "ours_time_to_90_warm_s": median(
            [t and t - r["compile_s"] for t, r in zip(to_90, ours, strict=True)]
        ),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--tasks", nargs="+", default=["transit", "pick_move"])
    parser.add_argument("--epochs", type=int, default=20, help="epochs of 16 training episodes")
    parser.add_argument("--algos", nargs="+", default=["ddpg", "sac"])
    parser.add_argument(
        "--sb3-epochs",
        type=int,
        default=None,
        help="SB3's budget in epochs (default: --epochs), to see where it reaches 90 %%",
    )
    parser.add_argument("--seeds", type=int, default=1, help="seeds of ours and SB3 DDPG")
    parser.add_argument(
        "--matched-envs",
        type=int,
        nargs="+",
        default=[16, 64],
        help="our parallel envs in the matched-throughput runs; the summary's `ratio` is at the last",
    )
    parser.add_argument("--sac-seeds", type=int, default=1, help="seeds of SB3 SAC (slowest)")
    parser.add_argument(
        "--ours-layer-norm",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="LayerNorm in our best-settings run (off: learned transit faster, see docs/methods.md)",
    )
    parser.add_argument("--plot", default="benchmarks/peer_sb3.png")
    args = parser.parse_args()
    compile_cache.enable()
    results, summary = {}, None
    for task in args.tasks:
        episode = ENVS[task].default_episode_length
        total = args.epochs * EPISODES_PER_EPOCH * episode
        sb3_total = (args.sb3_epochs or args.epochs) * EPISODES_PER_EPOCH * episode
        for seed in range(args.seeds):
            matched = {
                f"env_steps_per_s_matched_{envs}_envs": ours_matched_throughput(task, envs, seed)
                for envs in args.matched_envs
            }
            ours = run_ours(task, args.epochs, args.ours_layer_norm, seed)
            runs = {"ours_ddpg_her": {**matched, **ours}}
            for algo in args.algos:
                if seed < (args.sac_seeds if algo == "sac" else args.seeds):
                    runs[f"sb3_{algo}_her"] = run_sb3(task, algo, sb3_total, seed)
            for name, res in runs.items():
                results.setdefault((task, name), []).append(res)
                summary_row = {k: v for k, v in res.items() if k != "curve"}
                steps = total if name.startswith("ours") else sb3_total
                print(
                    json.dumps(
                        {
                            "task": task,
                            "algo": name,
                            "seed": seed,
                            "env_steps": steps,
                            **summary_row,
                            "final_success": res["curve"][-1]["eval_success"],
                            "time_to_90_s": time_to(res["curve"]),
                            "env_steps_to_90": time_to(res["curve"], key="env_steps"),
                        }
                    ),
                    flush=True,
                )
        if task == "transit" and "ddpg" in args.algos:
            summary = summarize(
                task,
                results[(task, "ours_ddpg_her")],
                results[(task, "sb3_ddpg_her")],
                total,
                args.matched_envs,
            )
    if args.plot:
        plot(results, args.plot)
    if summary:
        print(json.dumps(summary))


if __name__ == "__main__":
    main()
