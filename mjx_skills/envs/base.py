"""The functional goal-env contract shared by every env (MuJoCo Playground / Brax style)."""

from __future__ import annotations

from typing import Any, Protocol

import jax
from flax import struct

from mjx_skills.envs.physics import PhysicsState


@struct.dataclass
class State:
    physics: PhysicsState
    obs: jax.Array
    """(obs_dim,) observation without the goal."""
    achieved_goal: jax.Array
    """(goal_dim,) what the goal is compared with (gripper or object position)."""
    desired_goal: jax.Array
    """(goal_dim,)"""
    reward: jax.Array
    """0.0 on success, -1.0 otherwise."""
    done: jax.Array
    """True on the last step of the episode."""
    metrics: dict[str, jax.Array]
    """success, distance, invalid_actions, physics_resets."""
    info: dict[str, Any]
    """step count, the episode's start physics state, grasped flag."""


class GoalEnv(Protocol):
    obs_dim: int
    goal_dim: int
    action_dim: int
    episode_length: int

    def reset(self, key: jax.Array) -> State: ...

    def step(self, state: State, action: jax.Array) -> State: ...

    def compute_reward(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array: ...

    def is_success(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array: ...
