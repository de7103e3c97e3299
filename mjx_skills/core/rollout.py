"""The one `lax.scan` that runs episodes, for every behaviour policy.

Training exploration, evaluation, scripted controllers and benchmarks all run episodes
through `run_episodes`. A behaviour policy carries its own per-env memory (`pstate`), so a
policy that commits to a skill for several steps (the look-ahead explorer) or hands control
to a running skill until it terminates (the PAS meta-controller) fits without touching the
scan; DDPG's noisy policy is the stateless case (`stateless`).

This module knows envs only by their contract (`reset`, `step`, `episode_length`, State's
`obs` / `achieved_goal` / `desired_goal`), so envs, learners and the trainer can all use it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
from flax import struct

from mjx_skills.core.types import GoalEnv


@struct.dataclass
class Episode:
    """One episode in replay layout (a leading batch axis when several are stacked)."""

    obs: jax.Array
    """(T + 1, obs_dim) observations, the last one after the final step."""
    ag: jax.Array
    """(T + 1, goal_dim) achieved goals."""
    g: jax.Array
    """(T, goal_dim) desired goal at each step."""
    actions: jax.Array
    """(T, act_dim) the low-level actions executed."""


class Behaviour(NamedTuple):
    """A rollout policy with per-env memory, for a batch of n envs.

    init(key, n) -> pstate
    step(pstate, key, env_state) -> (pstate, actions (n, act_dim), record)

    `env_state` is the batched env State; `record` is a dict of per-env arrays (n, ...)
    stacked over the episode's steps by the scan (e.g. whether a skill drove the action).
    A record key `skill_calls` (n,) int counts skills started at that step."""

    init: Callable[[jax.Array, int], Any]
    step: Callable[[Any, jax.Array, Any], tuple[Any, jax.Array, dict[str, jax.Array]]]


SEED_AXIS = "seeds"
"""Name of the vmap axis over seeds (the trainer vmaps the whole epoch over it). Costly work
that a behaviour guards must not branch on a predicate batched over seeds: a `lax.cond` on
a batched predicate becomes a select that evaluates both branches at every step (JAX's vmap
rule). Pool the seeds' inputs instead (`gather_seeds`), decide once, and hand each seed its
part back (`own_seed`), as `search.search_where` does."""


def gather_seeds(tree: Any) -> Any:
    """Every seed's copy of `tree`, stacked on a new leading axis (S, ...) and not batched,
    when the program is vmapped over seeds: work on it is done once for all seeds. Else
    `tree` with a leading axis of 1."""
    try:
        return jax.tree.map(lambda x: jax.lax.all_gather(x, SEED_AXIS), tree)
    except NameError:
        return jax.tree.map(lambda x: x[None], tree)


def own_seed(tree: Any) -> Any:
    """The inverse of `gather_seeds`: this seed's row of a (S, ...) tree."""
    try:
        i = jax.lax.axis_index(SEED_AXIS)
    except NameError:
        i = 0
    return jax.tree.map(lambda x: x[i], tree)


Policy = Callable[[jax.Array, jax.Array, jax.Array], jax.Array]
"""policy(key, obs (n, obs_dim), goal (n, goal_dim)) -> actions (n, act_dim)."""


def stateless(policy: Policy) -> Behaviour:
    """A behaviour without memory: each action is policy(key, obs, desired goal)."""

    def step(pstate, key, env_state):
        return pstate, policy(key, env_state.obs, env_state.desired_goal), {}

    return Behaviour(init=lambda key, n: (), step=step)


def random_actions(behaviour: Behaviour, on: jax.Array) -> Behaviour:
    """`behaviour` whose actions are uniform random in [-1, 1] where `on` (() bool) holds:
    it still steps, so its memory and records go on as if it had acted."""

    def step(pstate, key, env_state):
        k_own, k_random = jax.random.split(key)
        pstate, action, record = behaviour.step(pstate, k_own, env_state)
        random = jax.random.uniform(k_random, action.shape, action.dtype, -1.0, 1.0)
        return pstate, jnp.where(on, random, action), record

    return Behaviour(init=behaviour.init, step=step)


def run_episodes(
    env: GoalEnv, behaviour: Behaviour, key: jax.Array, n: int
) -> tuple[Episode, Any, dict[str, jax.Array]]:
    """Reset n envs and run `env.episode_length` steps of `behaviour`.

    Returns the episodes (fields (n, T or T + 1, ...)), the final env State (batched) and
    the behaviour's records (n, T, ...)."""
    k_reset, k_steps = jax.random.split(key)
    state = jax.vmap(env.reset)(jax.random.split(k_reset, n))
    # fold_in leaves the reset and step keys untouched: a stateless behaviour's episodes
    # are the same whatever its init does with its key.
    pstate = behaviour.init(jax.random.fold_in(key, 1), n)

    def body(carry, k):
        state, pstate = carry
        pstate, action, record = behaviour.step(pstate, k, state)
        new = jax.vmap(env.step)(state, action)
        return (new, pstate), (state.obs, state.achieved_goal, state.desired_goal, action, record)

    (final, _), (obs, ag, g, actions, records) = jax.lax.scan(
        body, (state, pstate), jax.random.split(k_steps, env.episode_length)
    )
    swap = lambda x: jnp.swapaxes(x, 0, 1)  # (T, n, ...) -> (n, T, ...)
    episodes = Episode(
        obs=jnp.concatenate([swap(obs), final.obs[:, None]], axis=1),
        ag=jnp.concatenate([swap(ag), final.achieved_goal[:, None]], axis=1),
        g=swap(g),
        actions=swap(actions),
    )
    return episodes, final, jax.tree.map(swap, records)


def example_episode(env: GoalEnv) -> Episode:
    """Shapes and dtypes of one episode of `env` (no batch axis), without running anything:
    the replay buffer's layout."""
    episodes = jax.eval_shape(
        lambda k: run_episodes(env, stateless(_zero_policy(env.action_dim)), k, 1)[0],
        jax.random.PRNGKey(0),
    )
    return jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape[1:], x.dtype), episodes)


def _zero_policy(action_dim: int) -> Policy:
    return lambda key, obs, goal: jnp.zeros((*obs.shape[:-1], action_dim), obs.dtype)
