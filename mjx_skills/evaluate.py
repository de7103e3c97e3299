"""Success of a trained run's final checkpoint on fresh episodes, on any physics backend.

python -m mjx_skills.evaluate RUN_DIR [--episodes 50] [--physics native|mjx|gym] [--seed 10000]

Prints one JSON line per trained seed ({"seed", "success", "distance", "episodes",
"physics", "epoch", "run_eval_success"}), then one summary line with the means over seeds.
`run_eval_success` is what the run itself logged for that checkpoint's epoch (its own
`eval_episodes` episodes), for comparison. The run directory is only read.

native / mjx: `rollout.run_episodes` with the method's deterministic evaluation behaviour,
as the trainer evaluates (every method). gym: the gymnasium adapter (native `mj_step`),
for the flat-policy methods only (ddpg_her, ddpg_her_sl, whose evaluation is the DDPG
actor); its episodes start from the same reset keys, so with the same --seed every backend
starts from the same states.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path
from typing import Any

import jax
import numpy as np

from mjx_skills import methods
from mjx_skills.agents import ddpg
from mjx_skills.cli_args import run_parser
from mjx_skills.core import compile_cache, plugins
from mjx_skills.core.learner import Learner
from mjx_skills.core.precision import require_float32, use_float32
from mjx_skills.envs.registry import make
from mjx_skills.training.checkpoint import Checkpoints
from mjx_skills.training.epoch import (
    compiler_options,
    init_carry,
    make_evaluate,
    over_seeds,
    seed_keys,
)
from mjx_skills.training.metrics_log import read_metrics
from mjx_skills.training.runner import RunArgs, load_config


class UnsupportedOnGym(ValueError):
    """A method whose behaviour needs the JAX env (skills, the library) asked for gym."""


@dataclasses.dataclass(frozen=True)
class TrainedRun:
    """A run's final checkpoint, ready to act: agents with a leading seed axis."""

    run_dir: Path
    args: RunArgs
    env: Any
    """The run's task env on the requested backend, with evaluation starts (no held or goal
    starts)."""
    learner: Learner
    aux: Any
    agents: Any
    epoch: int


def has_checkpoint(run_dir: Path) -> bool:
    """Whether checkpoints/ holds a finished step (orbax names them by epoch)."""
    directory = run_dir / "checkpoints"
    return directory.is_dir() and any(p.name.isdigit() for p in directory.iterdir())


def load_trained(run_dir: Path, physics: str = "native") -> TrainedRun:
    """Restore the newest checkpoint of `run_dir` without training or writing anything
    (`runner.train_and_keep` would continue an unfinished run and rewrite its log).
    ValueError while JAX has 64-bit types on (`precision`: runs are float32)."""
    require_float32()
    args = load_config(run_dir)
    if not has_checkpoint(run_dir):
        raise FileNotFoundError(f"{run_dir} has no checkpoint: nothing to evaluate")
    spec = methods.get(args.method)
    options = args.full_options()
    aux = spec.load_aux(options)
    # As the trainer's evaluation env: training-only held starts never reach evaluation.
    env = make(args.train.task, args.env.for_evaluation(), physics=physics)
    learner = spec.make_learner(env, args.train, **options)
    # Only the shapes of a fresh carry are needed to restore one: no replay is allocated.
    shapes = jax.eval_shape(
        jax.vmap(lambda k: init_carry(learner, env, args.train, k, aux)), seed_keys(args.train)
    )
    device = jax.sharding.SingleDeviceSharding(jax.devices()[0])
    like = jax.tree.map(lambda s: jax.ShapeDtypeStruct(s.shape, s.dtype, sharding=device), shapes)
    checkpoints = Checkpoints(run_dir / "checkpoints")
    try:
        epoch, carry = checkpoints.restore(like)
    finally:
        checkpoints.close()
    return TrainedRun(
        run_dir=run_dir,
        args=args,
        env=env,
        learner=learner,
        aux=aux,
        agents=carry.agent,
        epoch=epoch,
    )


def seed_agent(run: TrainedRun, seed: int) -> Any:
    return jax.tree.map(lambda x: x[seed], run.agents)


def evaluate_jax(run: TrainedRun, key: jax.Array, episodes: int) -> tuple[np.ndarray, np.ndarray]:
    """-> (success, final distance) per seed, means over `episodes` episodes from `key`:
    what `train.make_evaluate` computes, every seed on the same starts."""

    train = dataclasses.replace(run.args.train, eval_episodes=episodes)
    evaluate = make_evaluate(run.learner, run.env, train)
    # aux (the library) is an argument, not a constant baked into the program, as in training.
    program = jax.jit(
        over_seeds(evaluate, in_axes=(0, None, None)), compiler_options=compiler_options(run.env)
    )
    metrics = program(run.agents, run.aux, key)
    return np.asarray(metrics["eval_success"]), np.asarray(metrics["eval_distance"])


def reset_keys(key: jax.Array, episodes: int) -> jax.Array:
    """The reset key of each episode, derived as `rollout.run_episodes` derives them."""
    k_reset, _ = jax.random.split(key)
    return jax.random.split(k_reset, episodes)


def check_gym_supports(method: str, task: str) -> None:
    from mjx_skills.envs.registry import FETCH

    if task in FETCH:
        raise UnsupportedOnGym(
            f"{task}: --physics gym replays the Baxter adapter's episodes in its own mj_step "
            "loop; the Fetch adapter (MjxSkills/Fetch*-v0) steps the JAX env itself, so "
            "--physics native evaluates the same physics: use it"
        )
    flat = [name for name, spec in methods.METHODS.items() if spec.flat_policy]
    if method not in flat:
        raise UnsupportedOnGym(
            f"{method} is not supported on the gym adapter (its skills and library run in "
            f"the JAX env); use --physics native or mjx (gym: {', '.join(flat)})"
        )


def evaluate_gym(run: TrainedRun, key: jax.Array, episodes: int) -> tuple[np.ndarray, np.ndarray]:
    """-> (success, final distance) per seed on the gymnasium adapter (flat methods)."""
    check_gym_supports(run.args.method, run.args.train.task)
    from mjx_skills.envs.gym import BaxterGymEnv  # imports gymnasium: only when asked for

    fields = dataclasses.asdict(run.args.env.for_evaluation())
    fields.pop("physics")  # the adapter is native by construction
    env = BaxterGymEnv(run.args.train.task, **fields)
    ddpg_config = run.args.full_options()["ddpg"]
    act = jax.jit(lambda agent, obs, goal: ddpg.act(agent, obs, goal, ddpg_config))
    n_seeds = run.args.train.seeds
    success, distance = np.zeros((n_seeds, episodes)), np.zeros((n_seeds, episodes))
    for s in range(n_seeds):
        agent = seed_agent(run, s)
        for e, reset_key in enumerate(reset_keys(key, episodes)):
            obs, info = env.reset(options={"jax_key": reset_key})
            for _ in range(env.task.episode_length):
                action = act(agent, obs["observation"], obs["desired_goal"])
                obs, _, _, _, info = env.step(np.asarray(action))
            success[s, e] = info["is_success"]
            distance[s, e] = np.linalg.norm(obs["achieved_goal"] - obs["desired_goal"])
    env.close()
    return success.mean(axis=1), distance.mean(axis=1)


def logged_eval_success(run_dir: Path, epoch: int, n_seeds: int) -> list[float | None]:
    """The run's own eval_success per seed at `epoch` (None where it was not logged)."""
    path = run_dir / "metrics.jsonl"
    rows = read_metrics(run_dir) if path.exists() else []
    by_seed = {r["seed"]: r["eval_success"] for r in rows if r["epoch"] == epoch}
    return [by_seed.get(s) for s in range(n_seeds)]


def evaluate_run(run_dir: Path, episodes: int, physics: str, seed: int) -> list[dict]:
    """-> one result row per trained seed (the rows `main` prints before the summary)."""
    if physics == "gym":  # said before anything is restored or compiled
        args = load_config(run_dir)
        check_gym_supports(args.method, args.train.task)
    run = load_trained(run_dir, physics="native" if physics == "gym" else physics)
    key = jax.random.PRNGKey(seed)
    evaluate = evaluate_gym if physics == "gym" else evaluate_jax
    success, distance = evaluate(run, key, episodes)
    logged = logged_eval_success(run_dir, run.epoch, run.args.train.seeds)
    return [
        {
            "seed": s,
            "success": float(success[s]),
            "distance": float(distance[s]),
            "episodes": episodes,
            "physics": physics,
            "epoch": run.epoch,
            "run_eval_success": logged[s],
        }
        for s in range(run.args.train.seeds)
    ]


def summarize(rows: list[dict]) -> dict:
    """Means over seeds (run_eval_success over the seeds that logged it)."""
    logged = [r["run_eval_success"] for r in rows if r["run_eval_success"] is not None]
    first = rows[0]
    return {
        "seeds": len(rows),
        "success": float(np.mean([r["success"] for r in rows])),
        "success_std": float(np.std([r["success"] for r in rows])),
        "distance": float(np.mean([r["distance"] for r in rows])),
        "episodes": first["episodes"],
        "physics": first["physics"],
        "epoch": first["epoch"],
        "run_eval_success": float(np.mean(logged)) if logged else None,
    }


def parse_args(argv: list[str] | None):
    parser = run_parser("python -m mjx_skills.evaluate", __doc__, episodes=50)
    parser.add_argument("--physics", choices=("native", "mjx", "gym"), default="native")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    compile_cache.enable()
    use_float32()
    args = parse_args(plugins.take_imports(sys.argv[1:] if argv is None else argv))
    try:
        rows = evaluate_run(args.run_dir, args.episodes, args.physics, args.seed)
    except UnsupportedOnGym as err:
        print(f"error: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    except ModuleNotFoundError as err:  # gymnasium, an optional dependency
        raise SystemExit(f"error: {err} (install it: pip install gymnasium)") from None
    except (FileNotFoundError, ValueError, NotImplementedError) as err:
        # Not a run, no checkpoint, a run of an older version, a missing skill library.
        raise SystemExit(f"error: {err}") from None
    for row in rows:
        print(json.dumps(row))
    print(json.dumps(summarize(rows)))


if __name__ == "__main__":
    main()
