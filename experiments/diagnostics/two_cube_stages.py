"""Which stage of a two-cube task a trained run fails at: its evaluation policy on fresh
episodes, every trained seed, followed cube by cube.

    python experiments/diagnostics/two_cube_stages.py RUN_DIR [--episodes 40] [--seed 10000]

Restores the run's newest checkpoint (`evaluate.load_trained`, nothing written) and prints
one JSON line over all seeds' episodes: the share ending with 0, 1 or 2 cubes at their goals;
the share where a cube ever got there, and where both did (not necessarily at once); the
median step the first cube got there; the share of cubes that got there and left again;
and, of the episodes ending with one cube there, the share where the other cube was ever
held after the first got there, where the first is still held at the end, where the other
ends on top of the first (within 4.5 cm of it in xy and at least 3 cm above it), and the
median steps left once the first got there; of the episodes where no cube got there, the share
where a cube was ever held.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import jax
import numpy as np

from mjx_skills import evaluate as evaluation
from mjx_skills.core import compile_cache, rollout
from mjx_skills.envs.two_objects import object_views


def follow(run: evaluation.TrainedRun, key: jax.Array, episodes: int):
    """-> at_goal, held: (seeds x episodes, T, 2) bool after each step, per cube; last:
    (seeds x episodes, 2, 3) each cube's position at the end (m)."""
    env = run.env

    def one(agent, key):
        ep, _, _ = rollout.run_episodes(env, run.learner.evaluate(agent, run.aux), key, episodes)
        at_goal = env.cube_success(ep.ag[:, 1:], ep.g)
        held = env.grasped(object_views(env, ep.obs[:, 1:]))  # each cube's view: that cube held
        return at_goal, held, ep.ag[:, -1].reshape(-1, 2, 3)

    found = jax.jit(jax.vmap(one, (0, None)))(run.agents, key)
    return (np.asarray(x).reshape(-1, *x.shape[2:]) for x in found)


def stages(at_goal: np.ndarray, held: np.ndarray, last: np.ndarray) -> dict:
    """The figures of the module's docstring from at_goal, held (E, T, 2), last (E, 2, 3)
    (`follow`'s)."""
    E, T = at_goal.shape[:2]
    end = at_goal[:, -1].sum(-1)
    ever = at_goal.any(1)
    first = np.sort(np.where(ever, at_goal.argmax(1), T), axis=1)[:, 0]  # first cube's step
    one_in = end == 1
    other = np.where(at_goal[:, -1, 0], 1, 0)  # in one-in episodes: the cube not there
    rows = np.arange(E)
    later = np.array([held[e, first[e] :, other[e]].any() for e in rows])
    kept = held[rows, -1, 1 - other]
    there, away = last[rows, 1 - other], last[rows, other]
    on_top = (np.linalg.norm(away[:, :2] - there[:, :2], axis=-1) < 0.045) & (
        away[:, 2] - there[:, 2] > 0.03
    )
    none = ~ever.any(-1)
    share = lambda x: round(float(np.mean(x)), 2) if len(x) else None  # noqa: E731
    return {
        "episodes": int(E),
        "cubes_at_goal_at_end": [share(end == k) for k in range(3)],
        "a_cube_ever_there": share(ever.any(-1)),
        "both_ever_there": share(ever.all(-1)),
        "first_cube_there_at_step": float(np.median(first[first < T]))
        if (first < T).any()
        else None,
        "cubes_there_that_left": round(
            float((ever & ~at_goal[:, -1]).sum() / max(ever.sum(), 1)), 2
        ),
        "one_there": {
            "episodes": int(one_in.sum()),
            "other_cube_held_after": share(later[one_in]),
            "first_still_held_at_end": share(kept[one_in]),
            "other_on_top_of_the_first": share(on_top[one_in]),
            "steps_left_median": float(np.median(T - first[one_in])) if one_in.any() else None,
        },
        "none_there": {
            "episodes": int(none.sum()),
            "a_cube_ever_held": share(held[none].any((1, 2))),
        },
    }


def main() -> None:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("run_dir", type=Path)
    p.add_argument("--episodes", type=int, default=40)
    p.add_argument("--seed", type=int, default=10000)
    args = p.parse_args()
    compile_cache.enable()
    run = evaluation.load_trained(args.run_dir)
    if getattr(run.env, "n_objects", 1) != 2:
        raise SystemExit(f"error: {run.args.train.task} is not a two-cube task")
    found = follow(run, jax.random.PRNGKey(args.seed), args.episodes)
    print(json.dumps({"run": str(args.run_dir), "epoch": run.epoch, **stages(*found)}))


if __name__ == "__main__":
    main()
