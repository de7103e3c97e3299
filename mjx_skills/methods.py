"""The method registry: what each learning method supplies to the one generic trainer.

A method is a `Learner` (a few pure functions closed over the env and its options) and the
option groups it adds to the command line. The trainer (`train.py`) owns the epoch:
collect episodes with `explore` -> `store` them -> `update` -> evaluate with `evaluate`.
Read-only inputs a method needs (the skill library) arrive as `aux`, a non-donated
argument of the jitted epoch, never as constants baked into the program.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from mjx_skills import ddpg as ddpg_agent
from mjx_skills import her, rollout
from mjx_skills.config import DDPGConfig, TrainConfig
from mjx_skills.replay import ReplayState


class Learner(NamedTuple):
    """init(key) -> agent
    explore(agent, aux, epoch) -> Behaviour     training behaviour (epoch: () int32, 0-based)
    evaluate(agent, aux) -> Behaviour           deterministic evaluation behaviour
    store(episodes, records) -> item            what the replay keeps per episode (batched)
    update(agent, buffer, fresh, key) -> (agent, losses)
        one cycle's learning on the buffer (which already holds `fresh`, this cycle's
        stored items); losses are per-step arrays, averaged by the trainer."""

    init: Callable[[jax.Array], Any]
    explore: Callable[[Any, Any, jax.Array], rollout.Behaviour]
    evaluate: Callable[[Any, Any], rollout.Behaviour]
    store: Callable[[rollout.Episode, dict], Any]
    update: Callable[[Any, ReplayState, Any, jax.Array], tuple[Any, dict[str, jax.Array]]]


@dataclasses.dataclass(frozen=True)
class Method:
    name: str
    description: str
    options: dict[str, Any]
    """Option groups of this method by CLI prefix, with their defaults (frozen dataclasses)."""
    make_learner: Callable[..., Learner]
    """make_learner(env, train: TrainConfig, **options) -> Learner."""
    needs_library: bool = False


def make_ddpg_her(env: Any, train: TrainConfig, ddpg: DDPGConfig) -> Learner:
    """Flat DDPG + HER: Gaussian / uniform exploration around the policy, HER relabelling."""

    def init(key: jax.Array) -> ddpg_agent.DDPGState:
        return ddpg_agent.init(key, env.obs_dim, env.goal_dim, env.action_dim, ddpg)

    def explore(agent, aux, epoch) -> rollout.Behaviour:
        return rollout.stateless(lambda k, obs, goal: ddpg_agent.explore(agent, k, obs, goal, ddpg))

    def evaluate(agent, aux) -> rollout.Behaviour:
        return rollout.stateless(lambda k, obs, goal: ddpg_agent.act(agent, obs, goal, ddpg))

    def update(agent, buffer, fresh: rollout.Episode, key):
        return her_update(agent, buffer, fresh, key, env, train.updates_per_cycle, ddpg)

    return Learner(init=init, explore=explore, evaluate=evaluate,
                   store=lambda episodes, records: episodes, update=update)  # fmt: skip


def her_update(
    agent: ddpg_agent.DDPGState,
    buffer: ReplayState,
    fresh: rollout.Episode,
    key: jax.Array,
    env: Any,
    n_updates: int,
    config: DDPGConfig,
) -> tuple[ddpg_agent.DDPGState, dict[str, jax.Array]]:
    """Add the fresh episodes to the normalisers, then `n_updates` DDPG steps on hindsight-
    relabelled batches. The buffer and normalisers are fixed during the steps, so all
    batches are sampled and relabelled up front in a few large gathers."""
    agent = ddpg_agent.observe(
        agent,
        fresh.obs.reshape(-1, env.obs_dim),
        jnp.concatenate([fresh.g, fresh.ag], axis=1).reshape(-1, env.goal_dim),
    )
    b = config.batch_size
    batch = her.sample_batch(
        buffer, key, n_updates * b, env.compute_reward, config.her_strategy, config.relabel_prob
    )
    batches = jax.tree.map(lambda x: x.reshape(n_updates, b, *x.shape[1:]), batch)
    return ddpg_agent.update(agent, batches, config)


METHODS: dict[str, Method] = {
    "ddpg_her": Method(
        name="ddpg_her",
        description="flat DDPG + HER from scratch (thesis baseline 1)",
        options={"ddpg": DDPGConfig()},
        make_learner=make_ddpg_her,
    ),
}
PLANNED = ("pas", "mpas", "ddpg_her_sl")
"""Methods of the thesis that need the skill library, not built yet."""


def get(name: str) -> Method:
    """The registered method `name`; a clear error naming the valid ones otherwise."""
    if name in METHODS:
        return METHODS[name]
    if name in PLANNED:
        raise NotImplementedError(
            f"method {name!r} needs the skill library, not built yet; available: "
            + ", ".join(METHODS)
        )
    raise ValueError(
        f"unknown method {name!r}; valid: {', '.join(METHODS)} (planned: {', '.join(PLANNED)})"
    )
