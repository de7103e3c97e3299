"""The Baxter tasks' base: a task of `envs.baxter_robot.BaxterRobot` (reset and step).

Tasks and skills subclass `BaxterEnv` and provide the scene, the start distribution, the
goal and the success predicate; the robot (scene model, controller, gripper, observation,
workspace, start state) is `BaxterRobot`, the `envs.robot.Robot` contract's Baxter.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.config import EnvConfig
from mjx_skills.core.types import ObsLayout, State
from mjx_skills.envs.baxter_robot import (
    FINGER_CLOSED_CTRL,
    FINGER_OPEN,
    HOME_GRIP,
    LAYOUT,
    OBS_FINGERS,
    OBS_GRIP,
    OBS_GRIP_VEL,
    OBS_OBJECT,
    OBS_REL,
    PARKED_OBJECT,
    SENSORS,
    XML_DIR,
    BaxterRobot,
    load_model,
    smooth_path,
)
from mjx_skills.envs.physics import PhysicsState
from mjx_skills.envs.robot import RobotTask

__all__ = [
    "BaxterEnv",
    "FINGER_CLOSED_CTRL",
    "FINGER_OPEN",
    "HOME_GRIP",
    "LAYOUT",
    "OBS_FINGERS",
    "OBS_GRIP",
    "OBS_GRIP_VEL",
    "OBS_OBJECT",
    "OBS_REL",
    "PARKED_OBJECT",
    "SENSORS",
    "XML_DIR",
    "BaxterRobot",
    "load_model",
    "smooth_path",
]
"""BaxterEnv, and the robot's facts the tasks and tests import from here (named once, in
`envs.baxter_robot`)."""


class BaxterEnv(RobotTask):
    """Base of every Baxter task and skill env. Subclasses set the class attributes below and
    implement `sample_start` and (optionally) `achieved_goal` / `is_success`."""

    robot_name = "baxter"
    scene: str = "scene_pick_move.xml"
    default_episode_length: int = 50
    default_threshold: float = 0.03
    grasped_start: bool = False
    """Whether episodes start with the object held (transfer)."""
    goal_is_object: bool = True
    """Whether the achieved goal is the object's position (else the gripper's)."""
    action_dim = BaxterRobot.action_dim
    goal_dim = 3
    n_objects = 1
    layout: ObsLayout = LAYOUT
    """Where the gripper, the object and their relation lie in the observation."""
    parked: np.ndarray = PARKED_OBJECT
    """Where the object(s) wait, out of every contact, while a reset moves the arm."""

    def __init__(self, config: EnvConfig | None = None):
        self.config = config = config or EnvConfig()
        if config.goal_start_prob and self.n_objects == 1:
            raise ValueError("goal_start_prob: goal starts are for tasks of several cubes")
        self.robot = robot = BaxterRobot(self.scene, config)
        # The robot's facts the tasks read (the same objects: a scene adds its sensors).
        self.model, self.backend = robot.model, robot.backend
        self.home_arm_qpos = robot.home_arm_qpos
        self.sensor_slices = robot.sensor_slices
        self.object_qpos_adr, self.object_qvel_adr = robot.object_qpos_adr, robot.object_qvel_adr
        self.table_z, self.object_half = robot.table_z, robot.object_half
        self.workspace_low, self.workspace_high = robot.workspace_low, robot.workspace_high
        self.episode_length = config.episode_length or self.default_episode_length
        self.threshold = config.distance_threshold or self.default_threshold
        self.obs_dim = robot.obs_dim

    # ------------------------------------------------------------------ sensors
    def sensors(self, sensordata: jax.Array) -> dict[str, jax.Array]:
        return self.robot.sensors(sensordata)

    def observation(self, sens: dict[str, jax.Array]) -> jax.Array:
        """The observation of named sensor readings: the robot's one-cube observation (25)."""
        return BaxterRobot.observation(sens)

    def grasped(self, obs: jax.Array) -> jax.Array:
        """The cube held, read from an observation (..., 25): `BaxterRobot.grasped`."""
        return self.robot.grasped(obs)

    # ------------------------------------------------------------------ task hooks
    def sample_start(self, key: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
        """-> (grip start (3,), object position (3,), desired goal (3,))."""
        raise NotImplementedError

    def achieved_goal(self, sens: dict[str, jax.Array]) -> jax.Array:
        return sens["object_pos"] if self.goal_is_object else sens["grip_pos"]

    def achieved_from_obs(self, obs: jax.Array) -> jax.Array:
        """The achieved goal read from observations (..., 25), e.g. predicted ones."""
        return obs[..., OBS_OBJECT] if self.goal_is_object else obs[..., OBS_GRIP]

    def is_success(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array:
        return jnp.linalg.norm(achieved_goal - desired_goal, axis=-1) < self.threshold

    def compute_reward(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array:
        """Sparse reward: 0 on success, -1 otherwise. Pure; HER calls it on relabelled goals."""
        return self.is_success(achieved_goal, desired_goal).astype(jnp.float32) - 1.0

    # ------------------------------------------------------------------ sampling helpers
    def sample_workspace(self, key: jax.Array, low=None, high=None) -> jax.Array:
        low = self.workspace_low if low is None else low
        high = self.workspace_high if high is None else high
        return jax.random.uniform(key, (3,), minval=low, maxval=high)

    def sample_on_table(self, key: jax.Array, xy_low, xy_high) -> jax.Array:
        xy = jax.random.uniform(key, (2,), minval=jnp.asarray(xy_low), maxval=jnp.asarray(xy_high))
        return jnp.concatenate([xy, jnp.array([self.table_z + self.object_half])])

    # ------------------------------------------------------------------ reset / step
    def _put_object(self, qpos: jax.Array, qvel: jax.Array, object_pos: jax.Array):
        return self.robot.put_object(qpos, qvel, object_pos)

    def place(self, grip: jax.Array, object_pos: jax.Array, held=None) -> PhysicsState:
        """Physics state with the grip point at `grip` and the object(s) at `object_pos`
        (`BaxterRobot.place` with this scene's object placement and parking spot)."""
        return self.robot.place(
            grip, object_pos, held, self.grasped_start, self._put_object, self.parked
        )

    @functools.cached_property
    def single_goal(self) -> jax.Array:
        """(goal_dim,) the goal of every episode with `EnvConfig.single_goal`: the mean of
        256 fixed draws of the task's goal, computed once (a constant of every program)."""
        with jax.ensure_compile_time_eval():
            keys = jax.random.split(jax.random.PRNGKey(0), 256)
            return jax.vmap(self.sample_start)(keys)[2].mean(axis=0)

    def reset(self, key: jax.Array) -> State:
        grip, object_pos, goal = self.sample_start(key)
        if self.config.single_goal:
            goal = self.single_goal
        grip, object_pos, held = self.training_start(key, grip, object_pos, goal)
        physics = self.place(grip, object_pos, held)
        zero = jnp.zeros((), jnp.float32)
        info = {"step": jnp.zeros((), jnp.int32), "start_physics": physics}
        state = State(
            physics=physics,
            obs=jnp.zeros(self.obs_dim),
            achieved_goal=jnp.zeros(self.goal_dim),
            desired_goal=goal,
            reward=zero,
            done=jnp.zeros((), bool),
            metrics={
                "success": zero,
                "distance": zero,
                "invalid_actions": zero,
                "physics_resets": zero,
            },
            info=info,
        )
        return self._observe(state, physics, state.metrics)

    def training_start(self, key, grip, object_pos, goal):
        """The training-only starts drawn over `sample_start`'s (fold_in: the other starts
        keep their keys) -> (grip, object_pos, held: bool or None): with `held_start_prob`
        the cube starts closed in the fingers where it lies."""
        del goal
        held = None
        if self.config.held_start_prob > 0 and self.goal_is_object and not self.grasped_start:
            coin = jax.random.uniform(jax.random.fold_in(key, 7))
            held = coin < self.config.held_start_prob
            grip = jnp.where(held, object_pos, grip)
        return grip, object_pos, held

    def _observe(self, state: State, physics: PhysicsState, metrics: dict) -> State:
        sens = self.sensors(physics.sensordata)
        achieved = self.achieved_goal(sens)
        success = self.is_success(achieved, state.desired_goal)
        distance = jnp.linalg.norm(achieved - state.desired_goal)
        metrics = {**metrics, "success": success.astype(jnp.float32), "distance": distance}
        obs = self.observation(sens)
        info = {**state.info, "grasped": self.grasped(obs)}
        return state.replace(
            physics=physics,
            obs=obs,
            achieved_goal=achieved,
            reward=self.compute_reward(achieved, state.desired_goal),
            metrics=metrics,
            info=info,
        )

    def action_to_controls(self, grip_pos: jax.Array, action: jax.Array):
        """-> (finger ctrl (2,), mocap target (3,)): `BaxterRobot.action_to_controls`."""
        return self.robot.action_to_controls(grip_pos, action)
