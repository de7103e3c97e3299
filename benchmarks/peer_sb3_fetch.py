"""What a user would run instead (issue #45): Stable-Baselines3 with HER on gymnasium-robotics'
own Fetch envs (not our adapter), learning curves over env steps for the report's Fetch
section.

    pip install -e '.[bench]'    # torch (CPU), stable-baselines3, sb3-contrib
    python benchmarks/peer_sb3_fetch.py --task fetch_push --algo tqc --steps 100000 --seeds 3

The env is gymnasium-robotics 1.4.2's `MujocoFetchPushEnv` / `MujocoFetchPickAndPlaceEnv`
(what `FetchPush-v4` / `FetchPickAndPlace-v4` make), built through `envs.fetch_reference`
(its joint-type checks patched to run on our mujoco 4.0, nothing else changed) and limited
to 50 steps an episode as `gymnasium.make` does.

Settings: rl-zoo3's tuned recipe for FetchPush (`hyperparams/tqc.yml`, FetchPush-v1, which
FetchPickAndPlace-v1 inherits): TQC, 2 critics, HER "future" with 4 sampled goals, gamma 0.95,
Adam 1e-3, tau 0.05, one gradient step per env step, SB3's 100 random steps before the first;
its 3 x 512 networks and batch 2048 are sized down to fit these 2 cores (`--net`, `--batch`,
recorded in every row). `--algo ddpg` runs SB3's DDPG+HER with the same HER and Gaussian
noise 0.2 instead.

Evaluation as ours: after every 16 training episodes (800 env steps), 20 episodes of the
deterministic policy from starts drawn afresh for each epoch and seed (`eval_seeds`), success
read at the last step; evaluation steps are not counted, and its time is not on the
training clock (`wall_s`). Rows without `eval_starts` were evaluated on the same 20 starts
at every epoch and seed (reset seeds 10,000-10,019): their seeds' curves are not
independent samples of the start distribution, and the report says so.

One JSON row per (task, algo, seed, settings) in `benchmarks/results/peer_sb3_fetch.jsonl`;
a seed whose row with the same settings is there already is skipped (rerunning resumes a
campaign seed by seed; `--force` trains it again and replaces that row).
"""

from __future__ import annotations

import argparse
import json
import os
import runpy
import time
from pathlib import Path

import gymnasium
import numpy as np

from mjx_skills.core.files import read_jsonl, write_text_atomic
from mjx_skills.envs.fetch_reference import reference_env

RESULTS = Path(__file__).parent / "results" / "peer_sb3_fetch.jsonl"
PEER_SB3 = runpy.run_path(str(Path(__file__).with_name("peer_sb3.py")))
"""benchmarks/peer_sb3.py's functions: its evaluation (`success_rate`) is ours too."""
EPISODE, EPISODES_PER_EPOCH, EVAL_EPISODES = 50, 16, 20
EVAL_SEED = 10_000
ZOO = {
    "source": "rl-baselines3-zoo hyperparams/tqc.yml, FetchPush-v1",
    "gamma": 0.95,
    "learning_rate": 1e-3,
    "tau": 0.05,
    "n_sampled_goal": 4,
    "goal_selection_strategy": "future",
    "n_critics": 2,
    "learning_starts": 100,
    "train_freq": 1,
    "gradient_steps": 1,
    "zoo_net_arch": [512, 512, 512],
    "zoo_batch_size": 2048,
}
"""The recipe (as rl-zoo3 publishes it); `net` and `batch` here are the sized-down values."""


def make_env(task: str) -> gymnasium.Env:
    """gymnasium-robotics' own env of `task` with gymnasium.make's 50-step limit."""
    return gymnasium.wrappers.TimeLimit(reference_env(task), max_episode_steps=EPISODE)


EVAL_STARTS = "fresh per epoch and seed"
"""How the evaluation's starts are drawn (recorded in every row: older rows used one fixed set)."""


def eval_seeds(seed: int, epoch: int) -> list[int]:
    """The env reset seeds of training seed `seed`'s evaluation after epoch `epoch` (1-based):
    20 of their own, distinct across epochs and seeds (our runs draw theirs from the run's
    PRNG key, so no two epochs or seeds share starts)."""
    first = EVAL_SEED + (seed * 100_000 + (epoch - 1)) * EVAL_EPISODES
    return list(range(first, first + EVAL_EPISODES))


class Evaluator:
    """An SB3 callback's body: every epoch (16 training episodes), 20 deterministic episodes
    from `eval_seeds`; the training clock excludes their time."""

    def __init__(self, task: str, seed: int):
        self.env, self.curve, self.seed = make_env(task), [], seed
        self.t0, self.eval_s = time.perf_counter(), 0.0

    def train_s(self) -> float:
        return time.perf_counter() - self.t0 - self.eval_s

    def __call__(self, model, env_steps: int) -> float:
        t_eval = time.perf_counter()
        seeds = eval_seeds(self.seed, len(self.curve) + 1)
        success = PEER_SB3["success_rate"](model, self.env, seeds)
        self.eval_s += time.perf_counter() - t_eval
        self.curve.append(
            {"env_steps": env_steps, "wall_s": round(self.train_s(), 2), "eval_success": success}
        )
        return success


def build(algo: str, env: gymnasium.Env, net: int, batch: int, seed: int):
    """SB3's model: TQC+HER (sb3-contrib) or DDPG+HER, at the zoo's recipe, networks 3 x `net`
    and batch `batch`."""
    from stable_baselines3 import DDPG, HerReplayBuffer
    from stable_baselines3.common.noise import NormalActionNoise

    common = dict(
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs=dict(
            n_sampled_goal=ZOO["n_sampled_goal"],
            goal_selection_strategy=ZOO["goal_selection_strategy"],
        ),
        learning_rate=ZOO["learning_rate"],
        batch_size=batch,
        gamma=ZOO["gamma"],
        tau=ZOO["tau"],
        buffer_size=1_000_000,
        learning_starts=ZOO["learning_starts"],
        train_freq=ZOO["train_freq"],
        gradient_steps=ZOO["gradient_steps"],
        seed=seed,
        verbose=0,
    )
    if algo == "tqc":
        from sb3_contrib import TQC

        kwargs = dict(net_arch=[net] * 3, n_critics=ZOO["n_critics"])
        return TQC("MultiInputPolicy", env, policy_kwargs=kwargs, **common)
    noise = NormalActionNoise(np.zeros(4), 0.2 * np.ones(4))
    return DDPG(
        "MultiInputPolicy",
        env,
        action_noise=noise,
        policy_kwargs=dict(net_arch=[net] * 3),
        **common,
    )


def run(task: str, algo: str, steps: int, net: int, batch: int, seed: int) -> dict:
    """One seed's training -> its row (settings, curve, throughput)."""
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    torch.set_num_threads(os.cpu_count() or 1)
    evaluator, every = Evaluator(task, seed), EPISODES_PER_EPOCH * EPISODE

    class Callback(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps % every == 0:
                success = evaluator(self.model, self.num_timesteps)
                print(
                    f"{task} {algo} seed {seed}: {self.num_timesteps:,} env steps, "
                    f"eval success {success:.2f}, {evaluator.train_s():.0f} s",
                    flush=True,
                )
            return True

    model = build(algo, make_env(task), net, batch, seed)
    model.learn(total_timesteps=steps, callback=Callback())
    return {
        **key(task, algo, steps, net, batch, seed),
        "env_steps_per_s": round(steps / evaluator.train_s(), 1),
        "cores": os.cpu_count(),
        "curve": evaluator.curve,
    }


def key(task: str, algo: str, steps: int, net: int, batch: int, seed: int) -> dict:
    """What identifies a row: a seed is reused only if the same settings made it."""
    import stable_baselines3

    return {
        "task": task,
        "env": f"gymnasium-robotics Mujoco{reference_env_name(task)}Env (v4)",
        "algo": f"sb3_{algo}_her",
        "seed": seed,
        "steps": steps,
        "net_arch": [net] * 3,
        "batch_size": batch,
        **{k: v for k, v in ZOO.items() if algo == "tqc" or k != "n_critics"},
        "eval_starts": EVAL_STARTS,
        "sb3": stable_baselines3.__version__,
    }


def reference_env_name(task: str) -> str:
    from mjx_skills.envs.fetch_reference import reference_class

    return reference_class(task).__name__.removeprefix("Mujoco").removesuffix("Env")


def stored_rows(path: Path = RESULTS) -> list[dict]:
    """Every row of the results file (none if it is missing; it is written whole)."""
    return read_jsonl(path, whole=True) if path.exists() else []


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--task", choices=["fetch_push", "fetch_pick_and_place"], default="fetch_push"
    )
    parser.add_argument("--algo", choices=["tqc", "ddpg"], default="tqc")
    parser.add_argument("--steps", type=int, default=100_000, help="training env steps per seed")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--net", type=int, default=256, help="hidden units of each of 3 layers")
    parser.add_argument("--batch", type=int, default=512)
    parser.add_argument("--force", action="store_true", help="retrain seeds already stored")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    if args.steps % (EPISODES_PER_EPOCH * EPISODE):
        parser.error(f"--steps must be a multiple of {EPISODES_PER_EPOCH * EPISODE} (one epoch)")
    for seed in args.seeds:
        want = key(args.task, args.algo, args.steps, args.net, args.batch, seed)
        rows = stored_rows(args.out)
        same = [r for r in rows if {k: r.get(k) for k in want} == want]
        if same and not args.force:
            print(f"seed {seed}: stored already ({args.out}); --force trains it again")
            continue
        row = run(args.task, args.algo, args.steps, args.net, args.batch, seed)
        kept = [r for r in rows if r not in same]
        write_text_atomic(args.out, "".join(json.dumps(r) + "\n" for r in [*kept, row]))
        print(json.dumps({k: v for k, v in row.items() if k != "curve"}), flush=True)


if __name__ == "__main__":
    main()
