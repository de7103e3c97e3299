"""Hindsight experience replay: sample transitions and relabel their goals.

The buffer holds `rollout.Episode`s: `obs` (T + 1, obs_dim), `ag` (T + 1, goal_dim),
`g` (T, goal_dim) and `actions` (T, act_dim).
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from mjx_skills.core import replay

STRATEGIES = ("future", "final", "episode", "none")

RewardFn = Callable[[jax.Array, jax.Array], jax.Array]
"""(..., goal_dim) achieved, (..., goal_dim) desired -> (...) 0.0 on success, -1.0 else."""


def _goal_step(key: jax.Array, t: jax.Array, T: int, strategy: str) -> jax.Array:
    """(B,) index into `ag` (0..T) of the hindsight goal for transitions at steps t (B,)."""
    if strategy == "future":
        # Uniform over t + 1..T in O(B): no per-transition masks over the episode.
        u = jax.random.uniform(key, t.shape)
        f = t + 1 + jnp.floor(u * (T - t)).astype(jnp.int32)
        return jnp.minimum(f, T)  # guards u * (T - t) rounding up to T - t
    if strategy == "final":
        return jnp.full_like(t, T)
    if strategy == "episode":
        return jax.random.randint(key, t.shape, 0, T + 1).astype(t.dtype)
    raise ValueError(f"unknown HER strategy '{strategy}', expected one of {STRATEGIES}")


def sample_batch(
    replay_state: replay.ReplayState,
    key: jax.Array,
    batch_size: int,
    compute_reward: RewardFn,
    strategy: str,
    relabel_prob: float | jax.Array,
    with_index: bool = False,
    n_step: int = 1,
    gamma: float = 1.0,
    actual_prob: float | jax.Array = 0.0,
) -> dict[str, jax.Array]:
    """Sample `batch_size` transitions and relabel a `relabel_prob` share of their goals
    (a float, or a traced () float32) with `strategy`'s achieved goal, and a further
    `actual_prob` share with the desired goal of a transition drawn uniformly from the
    whole replay (mrl's "actual" goals, Pitis et al. 2020; a float 0.0, the default, draws
    nothing and leaves every other draw as it was).

    Returns obs / next_obs (B, obs_dim), goal / ag / next_ag (B, goal_dim), action
    (B, act_dim) and reward (B,) = compute_reward(next_ag, goal), recomputed for every
    transition. `batch_size`, `compute_reward` and `strategy` are static. `with_index`: the
    batch also holds `episode` and `step` (B,) int32, where each transition lies.

    `n_step` > 1 (static): n-step returns under the relabelled goal, as multi-step HER
    (Yang et al. 2021, "MHER"; uncorrected): `reward` is the discounted sum
    sum_i gamma**i r(ag[t + i + 1], goal) over the m = min(n_step, T - t) steps left in
    the episode, `next_obs` is obs[t + m], and `discount` (B,) = gamma**m replaces gamma
    in the critic's target. The steps after t are the behaviour's, not the policy's, so
    the return is the explorer's: biased towards it, which is what a good explorer is for.
    """
    if strategy not in STRATEGIES:
        raise ValueError(f"unknown HER strategy '{strategy}', expected one of {STRATEGIES}")
    k_idx, k_goal, k_mask = jax.random.split(key, 3)
    ep, t = replay.sample_indices(replay_state, k_idx, batch_size)
    d = replay_state.data
    ag = d.ag[ep, t]
    next_ag = d.ag[ep, t + 1]
    goal = d.g[ep, t]
    if strategy != "none":
        f = _goal_step(k_goal, t, replay_state.T, strategy)
        u = jax.random.uniform(k_mask, (batch_size,))
        if not (isinstance(actual_prob, (int, float)) and actual_prob == 0):
            other_ep, other_t = replay.sample_indices(
                replay_state, jax.random.fold_in(key, 1), batch_size
            )
            actual = (u >= relabel_prob) & (u < relabel_prob + actual_prob)
            goal = jnp.where(actual[:, None], d.g[other_ep, other_t], goal)
        goal = jnp.where((u < relabel_prob)[:, None], d.ag[ep, f], goal)
    batch = {
        "obs": d.obs[ep, t],
        "next_obs": d.obs[ep, t + 1],
        "goal": goal,
        "action": d.actions[ep, t],
        "reward": compute_reward(next_ag, goal),
        "ag": ag,
        "next_ag": next_ag,
        **({"episode": ep, "step": t} if with_index else {}),
    }
    if n_step > 1:
        batch |= _n_step_return(d, ep, t, goal, replay_state.T, compute_reward, n_step, gamma)
    return batch


def _n_step_return(d, ep, t, goal, T: int, compute_reward: RewardFn, n: int, gamma: float):
    """reward, next_obs and discount of n-step returns (`sample_batch`) at (ep, t) (B,)."""
    i = jnp.arange(n)
    steps = t[:, None] + i  # (B, n)
    valid = steps < T
    later_ag = d.ag[ep[:, None], jnp.minimum(steps + 1, T)]  # (B, n, goal_dim)
    r = compute_reward(later_ag, jnp.broadcast_to(goal[:, None], later_ag.shape))
    m = jnp.sum(valid, axis=1)
    return {
        "reward": jnp.sum(jnp.where(valid, gamma**i * r, 0.0), axis=1),
        "next_obs": d.obs[ep, t + m],
        "discount": gamma ** m.astype(jnp.float32),
    }
