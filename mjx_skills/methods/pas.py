"""PAS and MPAS (thesis ch. 4): a DDPG meta-controller over the skill library in a
parameterized action space (Hausknecht & Stone 2016, the thesis's reference [21]).

The meta-controller chooses a skill among those allowed to start here (transfer only with
the cube in hand) and the goal its parameters name (`goal_from_param`). Two critics
(`PASConfig.critic`): 'per_skill' (default, `pdqn`) values each skill on its own goal;
'joint' (the thesis's) sees one vector in [-1, 1]^(K + 3K), a score per skill and every
skill's parameters padded to 3, with a linear actor kept inside the bounds by inverting
gradients (`ddpg` with bounds='invert'). The chosen skill's library policy drives the arm
until the skill reaches its goal (transfer: or drops the cube) or `skill_steps` env steps
pass, and the meta-controller chooses again. The task keeps its env-step budget, so
episodes and env steps (the curves' x-axes) count exactly as DDPG+HER's do.

Meta transitions are kept in episode layout: the episode itself plus, per meta step j, the
env steps where it began and ended and its meta action. A sampled transition is
(s_start, g, a, s_end) with the task's sparse reward at s_end (-1 / 0), one discount per
meta step, terminal where the goal is reached (`terminal_at_goal`). MPAS relabels the goal
with the achieved goal at the end of a later meta step of the same episode (hindsight at
the coarse level) and recomputes the reward; PAS keeps the task's goal. Both see the goal
as an input: our tasks draw a goal per episode, where the single-goal formulation of [21]
fixes one, so PAS differs from MPAS by hindsight alone.

In a scene of c cubes (per-skill critic only) the meta-controller chooses among (cube,
skill) pairs, cube-major, each with its parameters: skill k acts on cube j through the
scene's projection onto (gripper, cube j) (`object_views`), its goal named on that view,
and transfer may start only on the held cube's view. The library is the one-cube one, as
it is. (Option index = j K + k; with one cube, the skill index.)
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

from mjx_skills.agents import ddpg, mpdqn
from mjx_skills.agents.ddpg import DDPGState
from mjx_skills.config import DDPGConfig, PASConfig, TrainConfig
from mjx_skills.core import replay, rollout
from mjx_skills.core.learner import Learner
from mjx_skills.core.types import GoalEnv
from mjx_skills.envs.skills import PARAM_DIM
from mjx_skills.envs.two_objects import object_views
from mjx_skills.skills import execution
from mjx_skills.skills.library import (
    SkillLibrary,
    allowed_skills,
    carries_object,
    skill_envs,
)


@struct.dataclass
class MetaEpisode:
    """An episode with its meta steps j = 0 .. count - 1 (leaves (T + 1 or T, ...))."""

    episode: rollout.Episode
    start: jax.Array
    """(T,) int32 env step where meta step j began (T for j >= count)."""
    end: jax.Array
    """(T,) int32 env step where it ended: the next one's start, or T."""
    action: jax.Array
    """(T, meta_dim) its meta action."""
    valid: jax.Array
    """(T,) bool: j < count."""


def meta_dim(n_skills: int) -> int:
    return n_skills * (1 + PARAM_DIM)


def choose(lib: SkillLibrary, meta_action: jax.Array, obs: jax.Array):
    """meta_action (B, meta_dim), obs (B, 25) -> (skill (B,) int32, goal (B, 3)): the
    best-scoring allowed skill and the goal its parameters name."""
    K = len(lib.names)
    scores = jnp.where(lib.allowed(obs), meta_action[..., :K], -jnp.inf)
    skill = jnp.argmax(scores, axis=-1).astype(jnp.int32)
    params = meta_action[..., K:].reshape(*meta_action.shape[:-1], K, PARAM_DIM)
    param = jnp.take_along_axis(params, skill[..., None, None], axis=-2)[..., 0, :]
    return skill, lib.goal_from_param(skill, param, obs)


def option_goals(env: GoalEnv, envs) -> mpdqn.SkillGoals:
    """Every (cube, skill) choice's goal from its parameters, named on that cube's view:
    params (..., c K, PARAM_DIM), obs (..., obs_dim) -> (..., c K, 3)."""
    goals, K = mpdqn.skill_goals(envs), len(envs)

    def fn(params, obs):
        views = object_views(env, obs)
        return jnp.concatenate(
            [
                goals(params[..., j * K : (j + 1) * K, :], views[..., j, :])
                for j in range(views.shape[-2])
            ],
            axis=-2,
        )

    return fn


def option_allowed(env: GoalEnv, names: tuple[str, ...], obs: jax.Array) -> jax.Array:
    """obs (..., obs_dim) -> (..., c K) bool: the (cube, skill) choices that may start here
    (transfer only on the held cube's view). A transit or grasp on another cube's view may
    start with a cube in hand: that is how a cube at its goal is let go (no skill releases),
    and the meta-controller learns when (a rule on the task goal would go stale under HER's
    relabelling, which `allowed` / `next_allowed` in the replay do not follow)."""
    allowed = allowed_skills(names, env.grasped(object_views(env, obs)))
    return allowed.reshape(*obs.shape[:-1], -1)


def make_behaviour(
    agent: ddpg.DDPGState,
    lib: SkillLibrary,
    env: GoalEnv,
    cfg: PASConfig,
    ddpg_config: DDPGConfig,
    noisy: bool,
) -> rollout.Behaviour:
    """Meta-controller plus library policies as one behaviour; `noisy`: DDPG's exploration
    (Gaussian noise on scores and parameters, random_eps uniform meta actions). The
    running skill's index is its (cube, skill) choice (`option_goals`)."""
    K = len(lib.names)
    goals = option_goals(env, lib.envs)

    def init(key, n):
        return execution.idle(n)

    def step(ms: execution.Running, key, state):
        obs, task_goal = state.obs, state.desired_goal
        views = object_views(env, obs)  # (B, c, 25)
        seen = lambda choice: jnp.take_along_axis(views, (choice // K)[:, None, None], 1)[:, 0]  # noqa: E731
        running = seen(ms.skill)  # the running choice's cube view
        done = _stopped(lib, ms.skill % K, running, ms.goal, cfg.drop_distance)
        decide = execution.decide(ms, done | (ms.steps >= cfg.skill_steps))
        if cfg.critic == "per_skill":
            new_skill, new_goal, meta = mpdqn.choose(
                agent,
                obs,
                task_goal,
                option_allowed(env, lib.names, obs),
                goals,
                ddpg_config,
                key if noisy else None,
            )
        else:
            if noisy:
                meta = ddpg.explore(agent, key, obs, task_goal, ddpg_config)
            else:
                meta = ddpg.act(agent, obs, task_goal, ddpg_config)
            new_skill, new_goal = choose(lib, meta, obs)
        # Every deciding env starts the chosen skill: after the first step all are active.
        new = execution.advance(ms, decide, decide, new_skill, new_goal)
        ended = decide & ms.active
        record = {
            "skill_calls": decide.astype(jnp.int32),
            "decision": decide,
            "meta_action": meta,
            "skill": new.skill,
            "ended": ended,
            "ended_at_goal": ended & lib.reached(ms.skill % K, running, ms.goal),
        }
        action = lib.policy_action(new.skill % K, seen(new.skill), new.goal)
        return new, action, record

    return rollout.Behaviour(init=init, step=step)


def _stopped(lib: SkillLibrary, skill, obs, goal, drop_distance: float) -> jax.Array:
    """A chosen skill stops at its goal; transfer (a skill that carries the object) also
    once the cube is `drop_distance` away from the gripper. (The library's `terminated`
    stops transfer as soon as the grasp
    predicate fails, which a carried cube swinging in the fingers trips for a step or two:
    meta steps of 1-3 steps that never carried the cube to the chosen goal.)"""
    dropped = jnp.linalg.norm(obs[..., lib.layout["rel"]], axis=-1) > drop_distance
    carries = carries_object(lib.names)[skill]
    return lib.reached(skill, obs, goal) | (carries & dropped)


def store(episodes: rollout.Episode, records: dict[str, jax.Array]) -> MetaEpisode:
    """Episodes (n, ...) and the behaviour's records (n, T, ...) -> their meta steps."""

    def one(decision, meta_action):
        T = decision.shape[0]
        t = jnp.arange(T, dtype=jnp.int32)
        rank = jnp.cumsum(decision) - 1
        slot = jnp.where(decision, rank, T + 1)  # out of range: dropped
        start = jnp.full((T + 1,), T, jnp.int32).at[slot].set(t, mode="drop")
        return start[:T], start[1:], meta_action[jnp.minimum(start[:T], T - 1)], t <= rank[-1]

    start, end, action, valid = jax.vmap(one)(records["decision"], records["meta_action"])
    return MetaEpisode(episode=episodes, start=start, end=end, action=action, valid=valid)


def sample_batch(
    buffer: replay.ReplayState,
    key: jax.Array,
    n: int,
    env: GoalEnv,
    cfg: PASConfig,
    names: tuple[str, ...],
) -> dict[str, jax.Array]:
    """n meta transitions uniform over episodes, then over each episode's meta steps; with
    `cfg.hindsight` a `relabel_prob` share gets the achieved goal at the end of a meta step
    k >= j of the same episode. Reward = the task's reward at the end of meta step j;
    `allowed` / `next_allowed` (n, K): the skills that may start at either end; `terminal`:
    the goal reached, with `cfg.terminal_at_goal`."""
    k_idx, k_j, k_future, k_mask = jax.random.split(key, 4)
    d = buffer.data
    ep, _ = replay.sample_indices(buffer, k_idx, n)
    count = jnp.sum(d.valid[ep], axis=-1)
    j = jnp.floor(jax.random.uniform(k_j, (n,)) * count).astype(jnp.int32)
    j = jnp.minimum(j, count - 1)
    start, end = d.start[ep, j], d.end[ep, j]
    goal = d.episode.g[ep, start]
    next_ag = d.episode.ag[ep, end]
    if cfg.hindsight:
        later = j + jnp.floor(jax.random.uniform(k_future, (n,)) * (count - j)).astype(jnp.int32)
        future_ag = d.episode.ag[ep, d.end[ep, jnp.minimum(later, count - 1)]]
        relabel = jax.random.uniform(k_mask, (n,)) < cfg.relabel_prob
        goal = jnp.where(relabel[:, None], future_ag, goal)
    obs, next_obs = d.episode.obs[ep, start], d.episode.obs[ep, end]
    reward = env.compute_reward(next_ag, goal)
    return {
        "obs": obs,
        "next_obs": next_obs,
        "goal": goal,
        "action": d.action[ep, j],
        "reward": reward,
        "terminal": (reward == 0.0).astype(jnp.float32) * cfg.terminal_at_goal,
        "allowed": option_allowed(env, names, obs),
        "next_allowed": option_allowed(env, names, next_obs),
    }


def summarize(names: tuple[str, ...], cubes: int = 1):
    """-> records -> per-cycle metrics: the share of each skill among the choices (and, with
    several cubes, the mean cube index chosen, `object`), the mean env steps per meta step
    and the share of ended skills that reached their goal."""

    def fn(records: dict[str, jax.Array]) -> dict[str, jax.Array]:
        decision = records["decision"]
        n_choices = jnp.maximum(jnp.sum(decision), 1)
        skill = records["skill"] % len(names)
        shares = {
            f"share_{name}": jnp.sum(decision & (skill == i)) / n_choices
            for i, name in enumerate(names)
        }
        if cubes > 1:
            shares["object"] = jnp.sum(decision * (records["skill"] // len(names))) / n_choices
        ended = jnp.maximum(jnp.sum(records["ended"]), 1)
        return {
            **shares,
            "skill_length": decision.size / n_choices,
            "skill_success": jnp.sum(records["ended_at_goal"]) / ended,
        }

    return fn


def make_pas(
    env: GoalEnv, train: TrainConfig, ddpg: DDPGConfig, pas: PASConfig
) -> Learner[DDPGState, SkillLibrary]:
    """PAS (pas.hindsight off) or MPAS (on); `aux` is the SkillLibrary. (The parameters are
    named after the method's option groups, `--ddpg.*` and `--pas.*`.)"""
    from mjx_skills.agents import ddpg as agent_ops
    from mjx_skills.skills.library import library_skills

    names = library_skills(pas.library)
    options = env.n_objects * len(names)  # (cube, skill) choices

    def init(key):
        if pas.critic == "per_skill":
            return mpdqn.init(key, env.obs_dim, env.goal_dim, options, ddpg)
        return agent_ops.init(
            key, env.obs_dim, env.goal_dim, meta_dim(len(names)), ddpg, bounds="invert"
        )

    def update(agent, buffer, fresh: MetaEpisode, key):
        ep = fresh.episode
        agent = agent_ops.observe(
            agent,
            ep.obs.reshape(-1, env.obs_dim),
            jnp.concatenate([ep.g, ep.ag], 1).reshape(-1, env.goal_dim),
        )
        n, b = pas.updates_per_cycle, ddpg.batch_size
        batch = sample_batch(buffer, key, n * b, env, pas, names)
        batches = jax.tree.map(lambda x: x.reshape(n, b, *x.shape[1:]), batch)
        if pas.critic == "per_skill":
            return mpdqn.update(agent, batches, option_goals(env, skill_envs(names)), ddpg)
        return agent_ops.update(agent, batches, ddpg)

    return Learner(
        init=init,
        explore=lambda agent, lib, progress: make_behaviour(agent, lib, env, pas, ddpg, noisy=True),
        evaluate=lambda agent, lib: make_behaviour(agent, lib, env, pas, ddpg, noisy=False),
        store=store,
        update=update,
        summarize=summarize(names, env.n_objects),
    )
