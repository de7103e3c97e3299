"""The functional goal-env contract (MuJoCo Playground / Brax style): the env state, the
observation layout an env declares, and what the trainer and the methods use of an env."""

from __future__ import annotations

import dataclasses
from typing import Any, Protocol

import jax
from flax import struct


@struct.dataclass
class State:
    physics: Any
    """The physics backend's state (`envs.physics.PhysicsState`)."""
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


@dataclasses.dataclass(frozen=True)
class ObsLayout:
    """Where each part of an env's observation lies, as (start, stop) index pairs: what the
    skill library, the search, the stall memory and PAS read instead of fixed offsets."""

    size: int
    """obs_dim."""
    grip: tuple[int, int]
    """The gripper's position (3,), m."""
    object: tuple[int, int]
    """The object's position (3,), m."""
    rel: tuple[int, int]
    """Object minus gripper (3,), m: derived from the two above."""
    fingers: tuple[int, int]
    """The two finger positions (2,), m."""

    def __getitem__(self, part: str) -> slice:
        """layout["grip"] -> the slice of that part."""
        return slice(*getattr(self, part))


class GoalEnv(Protocol):
    """What the trainer and the methods use of an env: a task of a robot (`envs.robot`;
    `envs.baxter.BaxterEnv` and `envs.fetch_tasks.FetchTask` are such tasks)."""

    robot_name: str
    """The robot the task is of (`envs.registry.ROBOTS`)."""
    obs_dim: int
    goal_dim: int
    action_dim: int
    episode_length: int
    threshold: float
    """Success tolerance, m."""
    layout: ObsLayout
    goal_is_object: bool
    """Whether the goal is the object's position (else the gripper's)."""
    n_objects: int
    """Objects the task moves to goals: 1 for most tasks, 0 for FetchReach, more in a
    several-object scene (which then is a `MultiObjectEnv`)."""

    def grasped(self, obs: jax.Array) -> jax.Array:
        """obs (..., obs_dim) -> (...,) bool: the object is held in the fingers."""
        ...

    def achieved_from_obs(self, obs: jax.Array) -> jax.Array:
        """obs (..., obs_dim) -> the achieved goal (..., goal_dim) it shows."""
        ...

    def reset(self, key: jax.Array) -> State: ...

    def step(self, state: State, action: jax.Array) -> State: ...

    def compute_reward(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array: ...

    def is_success(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array: ...


class MultiObjectEnv(GoalEnv, Protocol):
    """A scene of `n_objects` > 1 cubes, each with its own 3-D goal (the goal is their
    concatenation): what the methods use beyond a GoalEnv to act on one cube at a time
    with the one-cube skill library (`envs.two_objects`)."""

    def project(self, obs: jax.Array, k: int | jax.Array) -> jax.Array:
        """obs (..., obs_dim) -> the one-cube observation (..., 25) of (gripper, cube k)."""
        ...

    def cube_success(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array:
        """(..., goal_dim) twice -> (..., n_objects) bool: each cube at its goal."""
        ...

    @property
    def cube_view(self) -> GoalEnv:
        """The task as one cube sees it: what a search scores one cube's states with."""
        ...


class SkillEnv(GoalEnv, Protocol):
    """A skill of a robot's skill library (`envs.skills`): what the library, its fits and
    the search read of it beyond a GoalEnv.

    Optional: `collection_param(key, obs (n, obs_dim)) -> (n, param_dim)`, how the library's
    data collection draws the goal parameters of n runs from their start states (without
    it, uniform in [-1, 1]; `skills.fit.make_collect`)."""

    param_dim: int
    """How many goal parameters in [-1, 1] the skill reads (of the library's padded 3)."""
    state_dims: tuple[int, ...]
    """The observation's dimensions the skill changes (its model predicts)."""
    memory_dims: tuple[int, ...]
    """The observation's dimensions memory retrieval compares (with the goal)."""

    def goal_from_param(self, param: jax.Array, obs: jax.Array) -> jax.Array:
        """param (..., param_dim) in [-1, 1], obs (..., obs_dim) -> goal (..., goal_dim)."""
        ...

    def terminated(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """obs (..., obs_dim), goal (..., goal_dim) -> (...,) bool: the skill has stopped."""
        ...
