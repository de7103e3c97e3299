"""DDPG+HER+SL+BC: DDPG+HER+SL whose actor also learns from the explorer's skills as from
demonstrations (beyond the thesis).

The look-ahead explorer shows the learner how to solve the task, but DDPG+HER absorbs
that only through its critic. Here every step a library skill drove (or that held still
at a solved goal) is stored as a demonstration, and the actor's loss adds behaviour
cloning on the demonstrated actions of each batch, kept only where the critic values the
demonstrated action above the actor's own (the Q-filter of Nair et al. 2018, "Overcoming
Exploration in Reinforcement Learning with Demonstrations", which learned pick-and-place
with DDPG + HER this way). Demonstrations are relabelled by HER like every transition: the
action that moved the cube is a demonstration for wherever it moved it. As the explorer's
eps decays, fewer new steps are demonstrations and the term fades with them.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
from flax import struct

from mjx_skills.agents.ddpg import DDPGState
from mjx_skills.config import DDPGConfig, SearchConfig, TrainConfig, check_numbers
from mjx_skills.core import rollout
from mjx_skills.core.learner import Learner
from mjx_skills.core.types import GoalEnv
from mjx_skills.methods.ddpg_her import her_update
from mjx_skills.methods.ddpg_her_sl import make_ddpg_her_sl
from mjx_skills.skills.library import SkillLibrary


@struct.dataclass
class DemoEpisode:
    """An episode and which of its steps an expert drove (the explorer's skills): what this
    method's replay keeps."""

    episode: rollout.Episode
    demo: jax.Array
    """(T,) bool."""


@dataclasses.dataclass(frozen=True)
class BCConfig:
    """Behaviour cloning from the explorer's skills (`--bc.*`)."""

    weight: float = 1.0
    """Weight of the Q-filtered behaviour-cloning term in the actor's loss, against the
    -mean Q term's 1 (0: DDPG+HER+SL)."""

    def __post_init__(self) -> None:
        check_numbers(self)


def make_ddpg_her_sl_bc(
    env: GoalEnv, train: TrainConfig, ddpg: DDPGConfig, search: SearchConfig, bc: BCConfig
) -> Learner[DDPGState, SkillLibrary]:
    """DDPG+HER+SL's learner, storing which steps the explorer's skills drove and cloning
    them where the critic agrees."""
    base = make_ddpg_her_sl(env, train, ddpg, search)

    def store(episodes: rollout.Episode, records: dict) -> DemoEpisode:
        driven = records.get("skill_driven", jnp.zeros(episodes.actions.shape[:-1], bool))
        held = records.get("holds", jnp.zeros_like(driven))
        return DemoEpisode(episode=episodes, demo=driven | held)

    def update(agent, buffer, fresh: DemoEpisode, key):
        episodes = buffer.replace(data=buffer.data.episode)
        n = train.updates_per_cycle
        demo = buffer.data.demo
        return her_update(agent, episodes, fresh.episode, key, env, n, ddpg, bc.weight, demo)

    return base._replace(store=store, update=update)
