"""The robot contract: what a task, the methods, the skill library and the search read of a
robot, and the step bookkeeping every task shares.

A task is (robot, task logic): the robot brings the scene's MJCF and the physics model built
from it, the end-effector controller (action -> controls -> one env step of physics), the
gripper (its command is the action's last entry; `grasped` reads it back), the observation
and its `ObsLayout`, the workspace and the start state. The task draws starts and goals and
scores them. `envs.baxter_robot.BaxterRobot` and `envs.fetch.FetchRobot` implement it;
docs/extending.md says what a third robot takes.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import jax
import jax.numpy as jnp
import mujoco

from mjx_skills.core.types import ObsLayout, State
from mjx_skills.envs.physics import PhysicsState


@runtime_checkable
class Robot(Protocol):
    """One robot in one of its scenes (what `registry.ROBOTS` lists and a task's `robot`
    attribute holds once the task is made)."""

    name: str
    """The registry's name of the robot ('baxter', 'fetch'): what a task declares as its
    `robot_name` and a skill library's manifest records as its `robot`."""
    scene: str
    """The scene's MJCF: a file under xml/ (Baxter) or a scene of an installed package
    (Fetch: gymnasium-robotics' 'push', ...)."""
    model: mujoco.MjModel
    """The physics model built from `scene` (with the robot's sensors)."""
    backend: Any
    """The physics backend stepping `model` (`envs.physics.NativeBackend` / `MjxBackend`)."""
    layout: ObsLayout
    """Where the grip, the object, their offset and the fingers lie in `observe`'s output."""
    obs_dim: int
    """Size of `observe`'s output; equals `layout.size`."""
    action_dim: int
    """4: the end effector's displacement (3, in units of `action_scale`) and the gripper
    command (1: -1 closes, +1 opens), each in [-1, 1]."""
    action_scale: float
    """Metres the end effector's target moves per unit of action[:3] in one env step."""
    workspace_low: jax.Array
    """(3,) m, world frame: the lower corner of the box the grip point works in."""
    workspace_high: jax.Array
    """(3,) m: its upper corner."""

    def sensors(self, sensordata: jax.Array) -> dict[str, jax.Array]:
        """sensordata (..., nsensordata) -> named sensor readings; 'grip_pos' (..., 3), m,
        is always among them."""
        ...

    def start(self, object_pos: jax.Array | None, grip: jax.Array | None = None) -> PhysicsState:
        """The physics state an episode starts from: the object at `object_pos` ((3,) m, or
        its xy (2,) where the robot sets the height; None where the scene has no object),
        the grip point at `grip` ((3,) m; None: the robot's own start pose). ValueError
        where the robot cannot start from a chosen `grip`."""
        ...

    def controls(self, physics: PhysicsState, action: jax.Array) -> Any:
        """The end-effector controller: a sanitized action (4,) in [-1, 1] -> the controls
        `step` applies (a pytree of arrays; its form is the robot's)."""
        ...

    def step(self, physics: PhysicsState, control: Any) -> PhysicsState:
        """One env step of physics (the robot's substeps) under `control`."""
        ...

    def observe(self, physics: PhysicsState) -> jax.Array:
        """The observation (obs_dim,) of a physics state, laid out as `layout` says."""
        ...

    def grasped(self, obs: jax.Array) -> jax.Array:
        """The gripper holds the object, read from observations (..., obs_dim) -> (...,)."""
        ...


def sanitize_action(action: jax.Array) -> tuple[jax.Array, jax.Array]:
    """-> (the action the env executes, 1.0 if the given one was invalid else 0.0).
    NaN becomes 0; everything else is clipped to [-1, 1] (so +-inf acts as +-1, as a
    huge value does). Every task and the gymnasium adapter execute this."""
    action = jnp.asarray(action, jnp.float32)
    invalid = jnp.any(~jnp.isfinite(action) | (jnp.abs(action) > 1.0)).astype(jnp.float32)
    return jnp.clip(jnp.where(jnp.isnan(action), 0.0, action), -1.0, 1.0), invalid


def advance(
    state: State,
    physics: PhysicsState,
    qvel: jax.Array,
    invalid: jax.Array,
    max_qvel: float,
    episode_length: int,
) -> tuple[State, PhysicsState, dict[str, jax.Array]]:
    """The bookkeeping after a task's physics step, shared by every task.

    A diverged env (non-finite sensors, or any |qvel| (rad/s, m/s) of the new state at or
    above `max_qvel`) goes back to its episode's start state (`info["start_physics"]`),
    never poisoning the batch. `invalid` (0.0 or 1.0, from `sanitize_action`) and the reset
    are counted in the metrics; the step count advances and `done` is set at
    `episode_length`. -> (state with step and done, the physics to observe, metrics).
    """
    diverged = ~jnp.all(jnp.isfinite(physics.sensordata)) | ~jnp.all(jnp.abs(qvel) < max_qvel)
    physics = jax.tree.map(
        lambda start, new: jnp.where(diverged, start, new), state.info["start_physics"], physics
    )
    step = state.info["step"] + 1
    metrics = {
        **state.metrics,
        "invalid_actions": state.metrics["invalid_actions"] + invalid,
        "physics_resets": state.metrics["physics_resets"] + diverged.astype(jnp.float32),
    }
    state = state.replace(info={**state.info, "step": step}, done=step >= episode_length)
    return state, physics, metrics


class RobotTask:
    """Base of every task: (robot, task logic). Subclasses set `robot_name` and, when made,
    `robot` (that robot's `Robot`), `config` (an `EnvConfig`: its `max_qvel` is read here),
    `episode_length`, and implement `_observe(state, physics, metrics) -> State` (the
    observation, achieved goal, reward and success of a physics state)."""

    robot_name: str
    """The robot of the task (`registry.ROBOTS`); `robot` holds it once the task is made."""
    robot: Robot

    sanitize_action = staticmethod(sanitize_action)

    def _observe(self, state: State, physics: PhysicsState, metrics: dict) -> State:
        raise NotImplementedError

    def step(self, state: State, action: jax.Array) -> State:
        """One env step: the action sanitized (NaN -> 0, clipped to [-1, 1]; counted), the
        robot's controller and physics step, then `advance`'s bookkeeping."""
        action, invalid = sanitize_action(action)
        physics = self.robot.step(state.physics, self.robot.controls(state.physics, action))
        state, physics, metrics = advance(
            state,
            physics,
            self.robot.backend.qvel(physics),
            invalid,
            self.config.max_qvel,
            self.episode_length,
        )
        return self._observe(state, physics, metrics)
