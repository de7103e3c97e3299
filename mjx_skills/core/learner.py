"""The contract between a learning method and the one trainer (`training/epoch.py`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Generic, NamedTuple, TypeVar

import jax
import jax.numpy as jnp
from flax import struct

from mjx_skills.core import rollout
from mjx_skills.core.replay import ReplayState

AgentT = TypeVar("AgentT")
"""The agent's state: networks, optimisers, normalisers (e.g. `agents.ddpg.DDPGState`)."""
AuxT = TypeVar("AuxT")
"""The read-only input of the jitted epoch: the skill library, or None."""


@struct.dataclass
class Progress:
    """Where a seed's training stands, as the exploring behaviour may read it."""

    epoch: jax.Array
    """() int32, 0-based: the epoch being trained."""
    success: jax.Array
    """() float32: the evaluated policy's success at the end of the previous epoch (0 before
    the first)."""


class Learner(NamedTuple, Generic[AgentT, AuxT]):
    """init(key) -> agent
    explore(agent, aux, progress) -> Behaviour  training behaviour (`Progress`)
    evaluate(agent, aux) -> Behaviour           deterministic evaluation behaviour
    store(episodes, records) -> item            what the replay keeps per episode (batched)
    update(agent, buffer, fresh, key) -> (agent, losses)
        one cycle's learning on the buffer (which already holds `fresh`, this cycle's
        stored items); losses are per-step arrays, averaged by the trainer.
    summarize(records) -> metrics                the behaviour's records (n, T, ...) of a
        cycle -> scalars logged as explore_*; default: the mean of each record."""

    init: Callable[[jax.Array], AgentT]
    explore: Callable[[AgentT, AuxT, Progress], rollout.Behaviour]
    evaluate: Callable[[AgentT, AuxT], rollout.Behaviour]
    store: Callable[[rollout.Episode, dict], Any]
    update: Callable[[AgentT, ReplayState, Any, jax.Array], tuple[AgentT, dict[str, jax.Array]]]
    summarize: Callable[[dict[str, jax.Array]], dict[str, jax.Array]] | None = None


def mean_records(records: dict[str, jax.Array]) -> dict[str, jax.Array]:
    """Each record's mean over envs and steps (a share, for boolean records)."""
    return {k: jnp.mean(v.astype(jnp.float32)) for k, v in records.items()}
