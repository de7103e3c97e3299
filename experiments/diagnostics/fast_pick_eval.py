"""DDPG+HER+SL+Fast's evaluation at one checkpoint of a run, under variants of the pick, and
how its failed episodes end.

    python experiments/diagnostics/fast_pick_eval.py RUN_DIR --epoch 30 [--episodes 100]
        [--proposals 2 4 8 16 32] [--seed 10000]

The run directory is only read: the checkpoint of `--epoch` is copied to a temporary run
and restored there (`evaluate.load_trained`). Every trained seed plays the same `--episodes`
fresh episodes per variant. Prints one JSON line per variant: the actor alone ("actor"),
the critic's pick with each number of proposals per cube ("proposals=N"; the run's own is
its default) and with the transfer proposals aimed at the task goal itself, without goal
noise ("exact_goals"): success per seed and the mean. Then one line on the failed episodes
of the run's own pick: their final distance to the goal (quantiles, m), the share ever
within the success threshold, still holding the cube at the end and with the cube moved more
than 2 cm, and the goal's height above the cube's start for failed and solved episodes.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import tempfile
from pathlib import Path

import jax
import numpy as np

from mjx_skills import evaluate as evaluation
from mjx_skills import methods
from mjx_skills.core import compile_cache, rollout


def at_epoch(run_dir: Path, epoch: int, where: Path) -> evaluation.TrainedRun:
    """The run restored at `epoch` from a copy of its config and that checkpoint."""
    (where / "checkpoints").mkdir(parents=True)
    shutil.copy(run_dir / "config.json", where / "config.json")
    shutil.copytree(run_dir / "checkpoints" / str(epoch), where / "checkpoints" / str(epoch))
    return evaluation.load_trained(where)


def variant(run: evaluation.TrainedRun, **changes) -> evaluation.TrainedRun:
    """`run` with its method's option groups changed (group -> {field: value})."""
    options = run.args.full_options()
    for group, fields in changes.items():
        options[group] = dataclasses.replace(options[group], **fields)
    learner = methods.get(run.args.method).make_learner(run.env, run.args.train, **options)
    return dataclasses.replace(run, learner=learner)


def failures(run: evaluation.TrainedRun, key: jax.Array, episodes: int) -> dict:
    env = run.env

    def one(agent):
        ep, final, _ = rollout.run_episodes(
            env, run.learner.evaluate(agent, run.aux), key, episodes
        )
        return ep.ag, ep.g, final.obs, final.metrics["success"]

    ag, g, obs, solved = map(np.asarray, jax.jit(jax.vmap(one))(run.agents))
    held = np.asarray(jax.vmap(jax.vmap(env.grasped))(obs))
    after = np.linalg.norm(ag[:, :, 1:] - g, axis=-1)  # (seeds, episodes, T)
    fail = solved < 0.5
    rise = g[:, :, -1, 2] - ag[:, :, 0, 2]
    moved = np.linalg.norm(ag[:, :, -1] - ag[:, :, 0], axis=-1) > 0.02
    q = lambda x: np.quantile(x, [0.1, 0.25, 0.5, 0.75, 0.9]).round(3).tolist()  # noqa: E731
    return {
        "failed": int(fail.sum()),
        "of": int(fail.size),
        "final_distance_quantiles": q(after[fail][:, -1]),
        "ever_within_threshold": round(float((after[fail].min(-1) < env.threshold).mean()), 2),
        "holding_at_end": round(float(held[fail].mean()), 2),
        "cube_moved": round(float(moved[fail].mean()), 2),
        "goal_above_start_failed": np.quantile(rise[fail], [0.25, 0.5, 0.75]).round(3).tolist(),
        "goal_above_start_solved": np.quantile(rise[~fail], [0.25, 0.5, 0.75]).round(3).tolist(),
    }


def main() -> None:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("run_dir", type=Path)
    p.add_argument("--epoch", type=int, required=True)
    p.add_argument("--episodes", type=int, default=100)
    p.add_argument("--proposals", type=int, nargs="+", default=[2, 4, 8, 16, 32])
    p.add_argument("--seed", type=int, default=10000)
    args = p.parse_args()
    compile_cache.enable()
    key = jax.random.PRNGKey(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        run = at_epoch(args.run_dir, args.epoch, Path(tmp) / "run")
        if run.args.method != "ddpg_her_sl_fast":
            raise SystemExit(f"error: {args.run_dir} is a run of {run.args.method}")
        variants = {
            "actor": variant(run, fast={"pick": False}),
            **{f"proposals={n}": variant(run, fast={"proposals": n}) for n in args.proposals},
            "exact_goals": variant(run, search={"transfer_goal_noise": 0.0}),
        }
        for name, v in variants.items():
            success, _ = evaluation.evaluate_jax(v, key, args.episodes)
            print(
                json.dumps(
                    {
                        "epoch": run.epoch,
                        "variant": name,
                        "episodes": args.episodes,
                        "success": round(float(success.mean()), 3),
                        "per_seed": [round(float(x), 2) for x in success],
                    }
                ),
                flush=True,
            )
        print(json.dumps({"epoch": run.epoch, **failures(run, key, args.episodes)}))


if __name__ == "__main__":
    main()
