"""Running library skills inside an env's behaviour: the state machine that DDPG+HER+SL's
explorer and PAS / MPAS's meta-controller share.

Per env a skill is running or not; at a step where an env decides (nothing runs, or its
stop rule fires) the method's choice rule either starts a skill with a goal or leaves the
env idle; a running skill's library policy gives the action. The methods differ only in
their rules: DDPG+HER+SL decides by eps-greedy look-ahead search and stops a skill when the
library says it terminated, after `skill_steps` or at a stall; PAS / MPAS decide by their
meta-controller, always start a skill, and stop at the skill's goal or when the cube drops.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class Running:
    """Per env (leaves (B, ...)): the running skill, its goal and the env steps it has run."""

    active: jax.Array
    """(B,) bool: a skill drives the env."""
    skill: jax.Array
    """(B,) int32 its index in the library."""
    goal: jax.Array
    """(B, goal_dim) its goal."""
    steps: jax.Array
    """(B,) int32 env steps it has run, this one included."""


def idle(n: int, goal_dim: int = 3) -> Running:
    """n envs with no skill running."""
    return Running(
        active=jnp.zeros((n,), bool),
        skill=jnp.zeros((n,), jnp.int32),
        goal=jnp.zeros((n, goal_dim)),
        steps=jnp.zeros((n,), jnp.int32),
    )


def decide(run: Running, stop: jax.Array) -> jax.Array:
    """(B,) bool: the envs that choose this step, where nothing runs or the stop rule (B,)
    fires."""
    return ~run.active | stop


def advance(
    run: Running, deciding: jax.Array, start: jax.Array, skill: jax.Array, goal: jax.Array
) -> Running:
    """One step: the `deciding` envs (B,) run `skill` (B,) to `goal` (B, goal_dim) where
    `start` (B,) says so and go idle elsewhere; the others keep their skill. Steps count
    from 1 at a start."""
    return Running(
        active=jnp.where(deciding, start, run.active),
        skill=jnp.where(start, skill, run.skill),
        goal=jnp.where(start[:, None], goal, run.goal),
        steps=jnp.where(start, 0, run.steps) + 1,
    )
