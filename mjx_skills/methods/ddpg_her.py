"""Flat DDPG + HER as a method: the thesis's baseline 1, and the learner of DDPG+HER+SL."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_skills.agents import ddpg as ddpg_agent
from mjx_skills.agents.ddpg import DDPGState
from mjx_skills.config import DDPGConfig, TrainConfig
from mjx_skills.core import her, rollout
from mjx_skills.core.learner import Learner
from mjx_skills.core.replay import ReplayState
from mjx_skills.core.types import GoalEnv
from mjx_skills.envs.two_objects import view_indices


def make_ddpg_her(env: GoalEnv, train: TrainConfig, ddpg: DDPGConfig) -> Learner[DDPGState, None]:
    """Flat DDPG + HER: Gaussian / uniform exploration around the policy, HER relabelling."""

    # The cubes' views, for deep sets only: a task without a Baxter scene (no `n_objects`) has none.
    views = view_indices(env) if ddpg.architecture == "deep_sets" else None

    def init(key: jax.Array) -> ddpg_agent.DDPGState:
        return ddpg_agent.init(key, env.obs_dim, env.goal_dim, env.action_dim, ddpg, views=views)

    def explore(agent, aux, progress) -> rollout.Behaviour:
        return rollout.stateless(lambda k, obs, goal: ddpg_agent.explore(agent, k, obs, goal, ddpg))

    def evaluate(agent, aux) -> rollout.Behaviour:
        return rollout.stateless(lambda k, obs, goal: ddpg_agent.act(agent, obs, goal, ddpg))

    def update(agent, buffer, fresh: rollout.Episode, key):
        return her_update(agent, buffer, fresh, key, env, train.updates_per_cycle, ddpg)

    return Learner(
        init=init,
        explore=explore,
        evaluate=evaluate,
        store=lambda episodes, records: episodes,
        update=update,
    )


def her_update(
    agent: ddpg_agent.DDPGState,
    buffer: ReplayState,
    fresh: rollout.Episode,
    key: jax.Array,
    env: GoalEnv,
    n_updates: int,
    config: DDPGConfig,
    bc_weight: float = 0.0,
    demo: jax.Array | None = None,
) -> tuple[ddpg_agent.DDPGState, dict[str, jax.Array]]:
    """Add the fresh episodes to the normalisers, then `n_updates` DDPG steps on hindsight-
    relabelled batches. The buffer and normalisers are fixed during the steps, so all
    batches are sampled and relabelled up front in a few large gathers. With `demo` (the
    buffer's episodes' (capacity, T) bool: which steps an expert drove) and `bc_weight` > 0,
    the actor also clones the demonstrated steps (`ddpg.q_filtered_bc_loss`), relabelled
    like every other transition (DDPG+HER+SL+BC).

    `config.warm_up` > 0: the steps' result is kept only once the replay holds more
    transitions than that (the normalisers see the episodes either way); `config.
    future_warm_up` > 0: every goal is relabelled from the future while the replay holds
    fewer (no `relabel_actual` share then, as mrl). `config.goal_stats` picks the goals the
    goal normaliser sees."""
    demo = demo if bc_weight else None
    goals = fresh.g
    if config.goal_stats == "desired_and_achieved":
        goals = jnp.concatenate([fresh.g, fresh.ag], axis=1)
    observed = ddpg_agent.observe(
        agent, fresh.obs.reshape(-1, env.obs_dim), goals.reshape(-1, env.goal_dim)
    )
    b = config.batch_size
    stored = buffer.size * buffer.T  # transitions in the replay (its episodes are whole)
    relabel_prob = config.relabel_prob
    if config.future_warm_up:
        relabel_prob = jnp.where(stored < config.future_warm_up, 1.0, relabel_prob)
    batch = her.sample_batch(
        buffer,
        key,
        n_updates * b,
        env.compute_reward,
        config.her_strategy,
        relabel_prob,
        with_index=demo is not None,
        n_step=config.n_step,
        gamma=config.gamma,
        actual_prob=config.relabel_actual,
    )
    if demo is not None:
        batch["demo"] = demo[batch.pop("episode"), batch.pop("step")]
    batches = jax.tree.map(lambda x: x.reshape(n_updates, b, *x.shape[1:]), batch)
    agent, metrics = ddpg_agent.update(observed, batches, config, bc_weight)
    if config.warm_up:
        ready = stored > config.warm_up
        agent = jax.tree.map(lambda new, old: jnp.where(ready, new, old), agent, observed)
    return agent, metrics
