"""DDPG+HER+SL's explorer alone on FetchPush with the push library (eps = 1, an untrained
learner): how often it solves the task, and where its chain approach -> push breaks.

    python experiments/diagnostics/fetch_push_explorer.py [--envs 64] [--library-dir DIR]

Prints one JSON line: the share of episodes solved; the skill calls per episode and how
often a push follows an approach; per push call, the grip's distance from push's training
start (BEHIND behind the block opposite the push, `envs.fetch_push_skills`), the angle
between the push asked and the task's goal direction, and how far the block moved towards
its push goal and towards the task's goal (m, medians); and the share of episodes whose
block moved at all (> 1 cm) before the first push.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig, SearchConfig
from mjx_skills.core import rollout
from mjx_skills.envs import fetch_push_skills as push
from mjx_skills.envs import make
from mjx_skills.methods import FETCH_PUSH_LIBRARY, ddpg_her_sl
from mjx_skills.skills.library import load


def _median(x) -> float | None:
    return round(float(np.median(x)), 3) if len(x) else None


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--envs", type=int, default=64)
    p.add_argument("--library-dir", default=FETCH_PUSH_LIBRARY)
    p.add_argument("--skill-steps", type=int, default=SearchConfig.skill_steps)
    p.add_argument("--prune-below", type=float, default=SearchConfig.prune_below)
    p.add_argument("--skip-reached", action="store_true")
    args = p.parse_args()
    env, (lib, _) = make("fetch_push"), load(Path(args.library_dir))
    config = DDPGConfig()
    agent = ddpg.init(jax.random.PRNGKey(0), env.obs_dim, env.goal_dim, 4, config)
    search = SearchConfig(
        eps_start=1.0,
        eps_end=1.0,
        library="SL_fetch_push",
        library_dir=args.library_dir,
        skill_steps=args.skill_steps,
        prune_below=args.prune_below,
        skip_reached=args.skip_reached,
    )
    explorer = ddpg_her_sl.make_behaviour(agent, lib, jnp.zeros((), jnp.int32), env, search, config)

    def step(ps, key, state):
        ps, action, record = explorer.step(ps, key, state)
        return ps, action, {**record, "skill": ps.run.skill, "goal": ps.run.goal}

    behaviour = rollout.Behaviour(init=explorer.init, step=step)
    episodes, final, rec = jax.jit(lambda k: rollout.run_episodes(env, behaviour, k, args.envs))(
        jax.random.PRNGKey(1)
    )
    rec, obs = jax.tree.map(np.asarray, rec), np.asarray(episodes.obs)
    task_goal = np.asarray(episodes.g)[:, 0]
    approach, push_id = lib.names.index("fetch_approach"), lib.names.index("fetch_push_block")
    grip_of, obj_of = env.layout["grip"], env.layout["object"]
    T = rec["skill"].shape[1]
    calls, off_start, angle, to_push_goal, to_task, moved_before = [], [], [], [], [], []
    chained = 0
    for e in range(args.envs):
        starts = [t for t in range(T) if rec["skill_calls"][e, t]]
        calls.append(len(starts))
        skills = [int(rec["skill"][e, t]) for t in starts]
        chained += sum(
            a == approach and b == push_id for a, b in zip(skills, skills[1:], strict=False)
        )
        pushes = [t for t in starts if rec["skill"][e, t] == push_id]
        block0 = obs[e, 0, obj_of]
        if pushes:
            moved_before.append(np.linalg.norm(obs[e, pushes[0], obj_of] - block0) > 0.01)
        for t in pushes:
            block, grip, goal = obs[e, t, obj_of], obs[e, t, grip_of], rec["goal"][e, t]
            way = (goal - block)[:2] / max(np.linalg.norm((goal - block)[:2]), 1e-6)
            ideal = block[:2] - push.BEHIND * way
            off_start.append(np.linalg.norm(grip[:2] - ideal))
            task_way = (task_goal[e] - block)[:2]
            cos = way @ task_way / max(np.linalg.norm(task_way), 1e-6)
            angle.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
            end = min(t + args.skill_steps, T)
            after = obs[e, end, obj_of]
            to_push_goal.append(np.linalg.norm(goal - block) - np.linalg.norm(goal - after))
            to_task.append(
                np.linalg.norm(task_goal[e] - block) - np.linalg.norm(task_goal[e] - after)
            )
    out = {
        "library_dir": args.library_dir,
        "episodes": args.envs,
        "prune_below": args.prune_below,
        "skip_reached": args.skip_reached,
        "solved": round(float(final.metrics["success"].mean()), 3),
        "solved_at_start": round(
            float(env.is_success(episodes.ag[:, 0], episodes.g[:, 0]).mean()), 3
        ),
        "skill_calls_per_episode": round(float(np.mean(calls)), 2),
        "approach_then_push_per_episode": round(chained / args.envs, 2),
        "push_calls": len(off_start),
        "push_grip_from_start_m": _median(off_start),
        "push_grip_within_2cm": round(float(np.mean(np.array(off_start) < 0.02)), 2)
        if off_start
        else None,
        "push_angle_to_task_deg": _median(angle),
        "push_progress_to_its_goal_m": _median(to_push_goal),
        "push_progress_to_task_goal_m": _median(to_task),
        "block_moved_before_first_push": round(float(np.mean(moved_before)), 2)
        if moved_before
        else None,
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
