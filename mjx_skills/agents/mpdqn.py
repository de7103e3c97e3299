"""A per-skill critic for the parameterized meta action: Q(s, g, k, goal_k).

The thesis's PAS critic (Hausknecht & Stone 2016) sees every skill's score and parameters,
so the value of "transfer to x" is learned through 12 inputs of which 9 do nothing. The
thesis's outlook (ch. 7, its reference [37]) proposes a value per discrete action with
gradients only to the chosen action's parameters; this module is that critic in the
multi-pass form of MP-DQN (Bester et al. 2019): one network reads (s, g, one-hot(k), goal_k).

goal_k is skill k's goal in world coordinates (`goal_from_param` of its parameters),
normalised with the task goal's statistics: "carry the cube to goal_k" is then worth the
most where goal_k is the task goal g, a relation between two inputs on the same scale. (On
the raw parameters the critic stayed flat in them after 30 epochs of take_out: measured.)
In a scene of c cubes the discrete choices are (cube, skill) pairs, cube-major (K / c per
cube), and a choice's 3-D goal is normalised with its cube's part of the task goal's
statistics (`option_norm`).

- The actor maps (s, g) to every skill's parameters (tanh-bounded, padded to PARAM_DIM).
- The chosen skill is argmax_k Q(s, g, k, goal_k) over the skills allowed in s; exploring:
  a uniformly random allowed skill with probability `random_eps`, else the greedy one, its
  parameters with Gaussian noise `noise_sigma`.
- Critic target: r + gamma * max over skills allowed in s' of Q'(s', g, k, goal'_k).
- Actor loss: -mean of Q(s, g, k, goal_k(s, g)) over the skills allowed in s.

The state is a `ddpg.DDPGState` whose critic reads K + goal_dim action inputs. Replay keeps
the executed (one-hot skill, raw goal): normalised when used, so never stale.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig
from mjx_skills.core import normalizer, optim
from mjx_skills.envs.skills import PARAM_DIM

SkillGoals = Callable[[jax.Array, jax.Array], jax.Array]
"""goals(params (..., K, PARAM_DIM), raw obs (..., obs_dim)) -> (..., K, goal_dim)."""


def skill_goals(envs) -> SkillGoals:
    """Every skill's goal from its parameters, for the skills' envs (`library.skill_envs`)."""

    def goals(params, obs):
        return jnp.stack(
            [
                env.goal_from_param(params[..., i, : env.param_dim], obs)
                for i, env in enumerate(envs)
            ],
            axis=-2,
        )

    return goals


SKILL_GOAL = 3
"""A skill's goal: a 3-D point in world coordinates."""


def init(key, obs_dim: int, goal_dim: int, n_skills: int, config: DDPGConfig) -> ddpg.DDPGState:
    """`n_skills` discrete choices (skills, or (cube, skill) pairs) over a `goal_dim` task.
    Raises ValueError for `config.critics` > 1 (this per-skill critic has one head)."""
    if config.critics != 1:
        raise ValueError(
            f"invalid config value for 'critics': the per-skill critic of PAS and "
            f"MPAS is one network (--pas.critic joint takes more), got "
            f"{config.critics}"
        )
    return ddpg.init(
        key, obs_dim, goal_dim, n_skills * PARAM_DIM, config, critic_act_dim=n_skills + SKILL_GOAL
    )


def _all_goals(state, actor_params, obs, o, g, goals: SkillGoals, config):
    """-> (the actor's parameters (B, K, PARAM_DIM), the raw goals they name (B, K,
    goal_dim), those goals normalised)."""
    out = ddpg.actor_module(state, config).apply(actor_params, o, g)
    params = out.reshape(*out.shape[:-1], -1, PARAM_DIM)
    raw = goals(params, obs)
    return params, raw, _norm_goal(state, raw, config)


def option_norm(state, n_options: int, config) -> tuple[jax.Array, jax.Array]:
    """(n_options, 3) mean and std of each choice's goal: the task goal's statistics, for a
    task goal of c cubes (3 c numbers) its cube's part, choices cube-major."""
    mean, std = normalizer.mean_std(state.goal_norm, config.norm_eps)
    cubes = mean.shape[-1] // SKILL_GOAL
    per = lambda x: jnp.repeat(x.reshape(cubes, SKILL_GOAL), n_options // cubes, axis=0)  # noqa: E731
    return per(mean), per(std)


def _norm_goal(state, goal, config):
    """Every choice's goal (..., K, 3) normalised with its cube's statistics."""
    return _clip_norm(goal, *option_norm(state, goal.shape[-2], config), config)


def _clip_norm(x, mean, std, config):
    return jnp.clip((x - mean) / std, -config.norm_clip, config.norm_clip)


def _values(critic_params, o, g, goals_n, config):
    """Q(s, g, k, goal_k) for every skill k: goals_n (B, K, goal_dim) -> (B, K)."""
    K = goals_n.shape[-2]
    x = jnp.concatenate([jnp.broadcast_to(jnp.eye(K), (*goals_n.shape[:-2], K, K)), goals_n], -1)
    tile = lambda v: jnp.broadcast_to(v[..., None, :], (*v.shape[:-1], K, v.shape[-1]))
    return ddpg.critic_module(config).apply(critic_params, tile(o), tile(g), x)


def _critic_input(state, action, config):
    """Stored (one-hot skill, raw goal) -> the critic's action input."""
    K = action.shape[-1] - SKILL_GOAL
    mean, std = option_norm(state, K, config)
    k = jnp.argmax(action[..., :K], axis=-1)
    return jnp.concatenate(
        [action[..., :K], _clip_norm(action[..., K:], mean[k], std[k], config)], -1
    )


def choose(state, obs, goal, allowed, goals: SkillGoals, config: DDPGConfig, key=None):
    """-> (skill (B,) int32, its goal (B, goal_dim), stored action (B, K + goal_dim)): greedy
    over the allowed skills, or exploring when a key is given."""
    o, g = ddpg.normalize_inputs(state, obs, goal, config)
    params, raw, norm = _all_goals(state, state.actor_params, obs, o, g, goals, config)
    q = jnp.where(allowed, _values(state.critic_params, o, g, norm, config), -jnp.inf)
    skill = jnp.argmax(q, axis=-1)
    if key is not None:
        k_pick, k_skill, k_noise = jax.random.split(key, 3)
        uniform = jnp.where(allowed, jax.random.uniform(k_skill, allowed.shape), -1.0)
        explore = jax.random.uniform(k_pick, skill.shape) < config.random_eps
        skill = jnp.where(explore, jnp.argmax(uniform, axis=-1), skill)
        noisy = jnp.clip(
            params + config.noise_sigma * jax.random.normal(k_noise, params.shape), -1, 1
        )
        raw = goals(noisy, obs)
    skill = skill.astype(jnp.int32)
    chosen = jnp.take_along_axis(raw, skill[:, None, None], axis=-2)[:, 0]
    return skill, chosen, jnp.concatenate([jax.nn.one_hot(skill, allowed.shape[-1]), chosen], -1)


def update(
    state: ddpg.DDPGState, batches: dict[str, jax.Array], goals: SkillGoals, config: DDPGConfig
):
    """n gradient steps, one per batch (as `ddpg.update`); batches also hold `allowed` and
    `next_allowed` (n, B, K) bool."""
    nbatches = {
        **ddpg.normalize_batch(state, batches, config),
        **{k: batches[k] for k in ("allowed", "next_allowed")},
        "raw_obs": batches["obs"],
        "raw_next_obs": batches["next_obs"],
    }
    state, metrics = jax.lax.scan(lambda s, nb: _step(s, nb, goals, config), state, nbatches)
    return ddpg.cycle_targets(state, config), metrics


def _step(state: ddpg.DDPGState, nb, goals: SkillGoals, config: DDPGConfig):
    critic = ddpg.critic_module(config)
    o, g, o2 = nb["obs"], nb["goal"], nb["next_obs"]
    _, _, goals2 = _all_goals(
        state, state.target_actor_params, nb["raw_next_obs"], o2, g, goals, config
    )
    q2 = _values(state.target_critic_params, o2, g, goals2, config)
    q2 = jnp.max(jnp.where(nb["next_allowed"], q2, -jnp.inf), axis=-1)
    y = ddpg.target_from_next_value(nb, q2, config)
    action = _critic_input(state, nb["action"], config)

    def critic_loss_fn(params):
        q = critic.apply(params, o, g, action)
        return ddpg.td_loss(q, y), q

    critic_params, critic_opt, critic_loss, q = optim.gradient_step(
        critic_loss_fn, state.critic_params, state.critic_opt_state, ddpg.critic_opt(config)
    )
    weight = nb["allowed"] / jnp.maximum(jnp.sum(nb["allowed"], -1, keepdims=True), 1)

    def actor_loss_fn(params):
        pi, _, norm = _all_goals(state, params, nb["raw_obs"], o, g, goals, config)
        q_pi = jnp.sum(weight * _values(critic_params, o, g, norm, config), -1)
        return ddpg.actor_loss(q_pi, pi, config.action_l2), None

    actor_params, actor_opt, actor_loss, _ = optim.gradient_step(
        actor_loss_fn, state.actor_params, state.actor_opt_state, ddpg.actor_opt(config)
    )
    new = ddpg.advance(state, actor_params, critic_params, actor_opt, critic_opt, config)
    return new, {"critic_loss": critic_loss, "actor_loss": actor_loss, "q_mean": jnp.mean(q)}
