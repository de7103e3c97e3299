"""DDPG+HER+SL's explorer alone on a two-cube task (eps = 1, an untrained learner): how often it
solves the task, and how its grasps fare (the first of an episode against later ones).

    python experiments/diagnostics/two_cube_explorer.py two_in_container [--envs 16] [--grasp-reach 0.06]

Prints one JSON line: the share of episodes solved and of cubes at their goals at the end,
and per kind of grasp (first / later): how many, the share holding their cube 10 steps
after the start, the median gripper-to-cube distance at the start (m; the grasp skill was
trained from within 5 cm) and the median success probability its classifier gave.
"""

from __future__ import annotations

import argparse
import json

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig, SearchConfig
from mjx_skills.core import rollout
from mjx_skills.envs import make
from mjx_skills.envs.two_objects import object_views
from mjx_skills.methods import ddpg_her_sl
from mjx_skills.skills import lookahead
from mjx_skills.skills.library import DEFAULT_DIR, load


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("task", help="a task: the two-cube ones, or a one-cube one to compare")
    p.add_argument("--envs", type=int, default=16)
    p.add_argument(
        "--grasp-reach",
        type=float,
        default=0.0,
        help="SearchConfig.grasp_reach (m; 0: grasp may start anywhere)",
    )
    args = p.parse_args()
    env, (lib, _) = make(args.task), load(DEFAULT_DIR)
    config = DDPGConfig()
    agent = ddpg.init(jax.random.PRNGKey(0), env.obs_dim, env.goal_dim, 4, config)
    explorer = ddpg_her_sl.make_behaviour(
        agent,
        lib,
        jnp.zeros((), jnp.int32),
        env,
        SearchConfig(eps_start=1.0, eps_end=1.0, grasp_reach=args.grasp_reach),
        config,
    )

    def step(ps, key, state):
        ps, action, record = explorer.step(ps, key, state)
        view = lookahead.take_row(object_views(env, state.obs), ps.obj)
        return (
            ps,
            action,
            {
                **record,
                "skill": ps.run.skill,
                "view": view,
                "held": env.grasped(view),
                "p": lib.success_prob(ps.run.skill, view, ps.run.goal),
            },
        )

    behaviour = rollout.Behaviour(init=explorer.init, step=step)
    _, final, rec = jax.jit(lambda k: rollout.run_episodes(env, behaviour, k, args.envs))(
        jax.random.PRNGKey(1)
    )
    rec = jax.tree.map(np.asarray, rec)
    grasp, T = lib.names.index("grasp"), rec["skill"].shape[1]
    cube_of = rec.get("object", np.zeros_like(rec["skill"]))  # one-cube tasks record none
    kinds: dict[str, list] = {"first": [], "later": []}
    for e in range(args.envs):
        starts = [t for t in range(T) if rec["skill_calls"][e, t] and rec["skill"][e, t] == grasp]
        for i, t in enumerate(starts):
            view, cube = rec["view"][e, t], cube_of[e, t]
            after = min(t + 10, T - 1)
            held = bool(rec["held"][e, after]) and cube_of[e, after] == cube
            reach = float(np.linalg.norm(view[0:3] - view[3:6]))
            kinds["first" if i == 0 else "later"].append((held, reach, rec["p"][e, t]))
    out = {
        "task": args.task,
        "episodes": args.envs,
        "grasp_reach": args.grasp_reach,
        "solved": float(final.metrics["success"].mean()),
        "cubes_at_goal": float(
            getattr(env, "cube_success", env.is_success)(
                final.achieved_goal, final.desired_goal
            ).mean()
        ),
    }
    for kind, rows in kinds.items():
        if rows:
            held, reach, p = (np.array(x) for x in zip(*rows, strict=True))
            out[f"{kind}_grasps"] = {
                "n": len(rows),
                "holding_after_10_steps": round(held.mean(), 2),
                "grip_to_cube_m": round(float(np.median(reach)), 3),
                "classifier_p": round(float(np.median(p)), 2),
            }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
