"""DDPG+HER+SL (thesis Algorithm 2): flat DDPG+HER whose exploration comes from a look-ahead
search over the skill library.

Per env the behaviour keeps (running skill, its goal, steps in it). Whenever an env has no
running skill, or its skill terminated, ran `skill_steps` steps or stalled against an
obstacle the coarse models never saw (`stall_memory`, `stalls.py`), it decides again: with
probability eps it searches and follows the best first skill's library policy; otherwise
(and when every edge was pruned) it acts with the learned policy plus noise. eps decays
linearly over epochs. The replay stores the executed low-level actions, and the learner is
DDPG+HER's, unchanged. `explorer="scripted"` puts the task's scripted controller in the
search's place: the upper bound of what any explorer can give this learner;
`explorer="random"` a random skill and goal, unscored (`lookahead.random_edges`): the
trivial baseline that the search's worth is measured against.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
from flax import struct

from mjx_skills.agents import ddpg
from mjx_skills.agents.ddpg import DDPGState
from mjx_skills.config import DDPGConfig, SearchConfig, TrainConfig
from mjx_skills.core import rollout
from mjx_skills.core.learner import Learner, Progress
from mjx_skills.core.types import GoalEnv
from mjx_skills.envs.two_objects import clear_goals, object_views, workable
from mjx_skills.methods.ddpg_her import make_ddpg_her
from mjx_skills.skills import execution, lookahead, stalls
from mjx_skills.skills.library import SkillLibrary


@struct.dataclass
class ExploreState:
    run: execution.Running
    """The searched skill that drives the env, if any."""
    last_grip: jax.Array
    """(B, 3) the gripper before the last step (stall detection)."""
    obstacles: jax.Array
    """(B, M, 3) where skills stalled this episode (`stalls.py`; M = 0 when off)."""
    stalls: jax.Array
    """(B,) int32 stalls so far this episode (the ring buffer's write position)."""
    obj: jax.Array
    """(B,) int32 the cube the running skill acts on (0 in a one-cube scene)."""


def epsilon(cfg: SearchConfig, epoch: jax.Array, success: jax.Array | float = 0.0) -> jax.Array:
    """Linear decay from eps_start at epoch 0 to the floor at eps_decay_epochs: eps_end, or
    with `eps_floor_by_success` eps_end x (1 - success), `success` the evaluated policy's
    in the previous epoch (`Progress.success`, in [0, 1])."""
    frac = jnp.clip(epoch / cfg.eps_decay_epochs, 0.0, 1.0)
    floor = cfg.eps_end * (1.0 - success) if cfg.eps_floor_by_success else cfg.eps_end
    return cfg.eps_start + frac * (floor - cfg.eps_start)


def make_behaviour(
    agent: ddpg.DDPGState,
    lib: SkillLibrary,
    epoch: jax.Array,
    env: GoalEnv,
    cfg: SearchConfig,
    ddpg_config: DDPGConfig,
    own: Callable[[jax.Array, jax.Array, jax.Array], jax.Array] | None = None,
    success: jax.Array | float = 0.0,
) -> rollout.Behaviour:
    """`own(key, obs, goal) -> (B, A)`: the learner's exploring action where no skill
    drives (default: the actor plus DDPG's noise, `ddpg.explore`). `epoch`, `success`: as
    `Progress`'s, for eps (`epsilon`).

    In a scene of n > 1 cubes every skill acts on one cube k through the scene's projection
    onto (gripper, cube k) (`object_views`), the library used as it is: the search plans
    over (skill, cube, goal), each cube's tree from its own view towards its own part of
    the task goal (the other cube carried over unchanged), among the cubes not yet at
    their goals, and the best path's first edge wins. A cube in hand and not at its goal is
    the only one searched: the explorer finishes what it holds (without this rule it
    started a transit towards the other cube right after a grasp, as often as not, and so
    dropped the first: no episode of its 100 epochs on pick_move_two put both cubes at
    their goals). Transfer is allowed only on a view whose cube is held
    (`SkillLibrary.allowed`), so it only ever moves the held cube. With `cfg.in_order`
    it searches only the first cube not at its goal (`two_objects.workable`). Each cube's
    tree aims at its goal moved `cfg.goal_clearance` clear of the other cubes
    (`clear_goals`)."""
    eps = epsilon(cfg, epoch, success)
    n = env.n_objects
    in_order = cfg.in_order  # read for every task, as goal_clearance; both act where n > 1
    scored = env.cube_view if n > 1 else env  # what a search scores one cube's states with
    if own is None:
        own = lambda k, obs, goal: ddpg.explore(agent, k, obs, goal, ddpg_config)  # noqa: E731

    def init(key, n_envs):
        return ExploreState(
            run=execution.idle(n_envs),
            last_grip=jnp.zeros((n_envs, 3)),
            obstacles=stalls.empty(n_envs, cfg.stall_memory),
            stalls=jnp.zeros((n_envs,), jnp.int32),
            obj=jnp.zeros((n_envs,), jnp.int32),
        )

    def step(ps: ExploreState, key, state):
        k_coin, k_search, k_noise = jax.random.split(key, 3)
        obs, task_goal = state.obs, state.desired_goal
        run = ps.run
        grip = obs[:, env.layout["grip"]]
        stall = jnp.zeros(run.active.shape, bool)
        if cfg.stall_memory:
            stall = stalls.stalled(
                lib.names,
                run.skill,
                grip,
                ps.last_grip,
                run.goal,
                run.active,
                run.steps,
                cfg.stall_step,
                cfg.stall_ahead + cfg.stall_radius,
            )
            obstacles, count = stalls.remember(
                ps.obstacles, ps.stalls, grip, run.goal, stall, cfg.stall_ahead
            )
            ps = ps.replace(obstacles=obstacles, stalls=count)
        views = object_views(env, obs)  # (B, n, 25)
        seen = lookahead.take_row(views, ps.obj)
        done = lib.terminated(run.skill, seen, run.goal) | (run.steps >= cfg.skill_steps) | stall
        decide = execution.decide(run, done)
        explore = decide & (jax.random.uniform(k_coin, run.steps.shape) < eps)
        # With the task already solved, the best plan is to do nothing: hold still, keeping
        # the gripper as it is (searching again would move the cube off the goal).
        held = env.grasped(obs)
        solved = env.is_success(state.achieved_goal, task_goal)
        hold = explore & solved
        explore = explore & ~solved
        # The search's cost is paid only for the envs (and cubes) that explore, and not at
        # all at a step where no env of any seed explores (`lookahead.search_where`).
        B = obs.shape[0]
        where = explore[:, None]
        if n > 1:  # a cube already at its goal is left alone; a cube in hand is finished first
            at_goal = env.cube_success(state.achieved_goal, task_goal)  # (B, n)
            where = where & ~at_goal & workable(env.grasped(views), at_goal, in_order)
        obstacles = ps.obstacles if cfg.stall_memory else None
        aimed = clear_goals(env, obs, task_goal, cfg.goal_clearance)  # (B, n, 3)
        rows = (where.reshape(-1), views.reshape(B * n, -1), aimed.reshape(B * n, 3))
        if cfg.explorer == "random":  # the trivial baseline: no search
            found = lookahead.random_edges(lib, cfg, *rows, k_search)
        else:
            near = None if obstacles is None else jnp.repeat(obstacles, n, 0)
            found = lookahead.search_where(lib, cfg, scored, *rows, k_search, near)
        found = jax.tree.map(lambda x: x.reshape(B, n, *x.shape[1:]), found)
        obj = jnp.argmax(found.utility, axis=1).astype(jnp.int32)  # the best cube's plan
        all_pruned = jnp.all(found.all_pruned, axis=1)
        start = explore & ~all_pruned
        run = execution.advance(
            run,
            decide,
            start,
            lookahead.take_row(found.skill, obj),
            lookahead.take_row(found.goal, obj),
        )
        obj = jnp.where(start, obj, ps.obj)
        skill_action = lib.policy_action(run.skill, lookahead.take_row(views, obj), run.goal)
        action = jnp.where(run.active[:, None], skill_action, own(k_noise, obs, task_goal))
        still = jnp.concatenate(
            [jnp.zeros_like(obs[:, :3]), jnp.where(held, -1.0, 1.0)[:, None]], -1
        )
        action = jnp.where(hold[:, None], still, action)
        record = {
            "skill_calls": start.astype(jnp.int32),
            "skill_driven": run.active,
            "holds": hold,
            "searches": explore,
            "all_pruned": explore & all_pruned,
            "eps": jnp.broadcast_to(eps, run.active.shape),
        }
        if cfg.stall_memory:
            record["stalls"] = stall
        if n > 1:
            record["object"] = obj
        ps = ps.replace(run=run, last_grip=grip, obj=obj)
        return ps, action, record

    return rollout.Behaviour(init=init, step=step)


def make_scripted_behaviour(
    agent: ddpg.DDPGState,
    epoch: jax.Array,
    env: GoalEnv,
    cfg: SearchConfig,
    ddpg_config: DDPGConfig,
    success: jax.Array | float = 0.0,
) -> rollout.Behaviour:
    """The oracle explorer: the scripted controller's action with probability eps per step,
    else the learned policy plus noise."""
    from mjx_skills.envs.controllers import make_scripted_policy

    scripted = jax.vmap(make_scripted_policy(env))
    eps = epsilon(cfg, epoch, success)

    def policy(key, obs, goal):
        k_coin, k_noise = jax.random.split(key)
        use = jax.random.uniform(k_coin, obs.shape[:1]) < eps
        own = ddpg.explore(agent, k_noise, obs, goal, ddpg_config)
        return jnp.where(use[:, None], scripted(obs, goal), own)

    return rollout.stateless(policy)


def make_ddpg_her_sl(
    env: GoalEnv, train: TrainConfig, ddpg: DDPGConfig, search: SearchConfig
) -> Learner[DDPGState, SkillLibrary]:
    """DDPG+HER's learner with the look-ahead explorer; `aux` is the SkillLibrary. (The
    parameters are named after the method's option groups, `--ddpg.*` and `--search.*`.)"""
    base = make_ddpg_her(env, train, ddpg)

    def explore(agent, lib, progress: Progress):
        epoch, success = progress.epoch, progress.success
        if search.explorer == "scripted":
            return make_scripted_behaviour(agent, epoch, env, search, ddpg, success)
        return make_behaviour(agent, lib, epoch, env, search, ddpg, success=success)

    return base._replace(explore=explore)
