"""gymnasium-robotics 1.4.2's four Fetch tasks (FetchReach/Push/Slide/PickAndPlace-v4) as JAX
goal envs of this project, step for step equal to the originals on native MuJoCo.

Each task is the original's parameters (`envs/fetch/{reach,push,slide,pick_and_place}.py`)
read by one `FetchTask` (`fetch_env.py`'s sampling, reward and success); the robot, its
controller and observation are `envs.fetch.FetchRobot`. Facts are gymnasium-robotics'
(MIT); the code is ours, and never calls theirs (`envs/fetch_reference.py` builds theirs
for the tests). On MJX they step the model with `envs.fetch_mjx.MJX_EDITS`; Slide, which
MJX cannot collide, is refused there (`fetch_mjx.MJX_REFUSALS`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_skills.config import EnvConfig
from mjx_skills.core.types import State
from mjx_skills.envs.fetch import FetchRobot
from mjx_skills.envs.fetch_mjx import resolve_physics
from mjx_skills.envs.robot import RobotTask

UNUSED_FIELDS = tuple(
    "timestep n_substeps solver_iterations ls_iterations action_scale settle_substeps "
    "grasp_settle_substeps posture_stiffness held_start_prob goal_start_prob object_reward "
    "single_goal".split()
)
"""EnvConfig fields of the Baxter scenes: a Fetch task keeps gymnasium-robotics' physics,
control and start distribution, so it refuses any of them set."""
MIN_OBJECT_DISTANCE = 0.1
"""The object starts at least this far (xy, m) from the gripper's start (`_reset_sim`)."""
AIR_PROB, AIR_MAX = 0.5, 0.45
"""target_in_the_air: half the goals are lifted by up to 45 cm (`_sample_goal`)."""


def refuse_unsupported(task: str, config: EnvConfig, scene: str) -> None:
    """ValueError if `config` asks a Fetch task for what it does not do: MJX where MJX cannot
    run `scene` (`fetch_mjx.MJX_REFUSALS`, with MJX's reason) or a field of the Baxter scenes
    (`UNUSED_FIELDS`) set away from its default."""
    default = EnvConfig()
    for field in UNUSED_FIELDS:
        if getattr(config, field) != getattr(default, field):
            flag = "--env." + field.replace("_", "-")
            raise ValueError(
                f"{task} keeps gymnasium-robotics' physics, control and starts: EnvConfig."
                f"{field} ({flag}) is for the Baxter scenes; leave it at its default "
                f"{getattr(default, field)!r}"
            )
    try:
        resolve_physics(scene, config.physics)
    except ValueError as refusal:
        raise ValueError(f"{task}: {refusal} (asked: physics={config.physics!r})") from None


class FetchTask(RobotTask):
    """One Fetch task as a `core.types.GoalEnv`. Subclasses set the class attributes below,
    gymnasium-robotics' arguments of that task. `EnvConfig` fields it reads: physics ('auto'
    is native on a CPU and for Slide), native_threads, episode_length, distance_threshold, max_qvel."""

    robot_name = "fetch"
    scene: str
    initial_qpos: dict
    block_gripper: bool
    gripper_extra_height: float
    target_in_the_air: bool
    target_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    obj_range: float = 0.15
    target_range: float = 0.15
    default_threshold = 0.05
    default_episode_length = 50
    """gymnasium-robotics registers the Fetch tasks with max_episode_steps=50."""
    action_dim = 4
    goal_dim = 3
    n_objects = 1
    render_view = {
        "lookat": (1.3, 0.75, 0.55),
        "distance": 2.5,
        "azimuth": 132.0,
        "elevation": -14.0,
    }
    """The free camera `python -m mjx_skills.render` draws from: gymnasium-robotics' own."""

    def __init__(self, config: EnvConfig | None = None):
        self.config = config = config or EnvConfig()
        self.check_config(config)
        self.robot = FetchRobot(
            self.scene,
            self.initial_qpos,
            self.gripper_extra_height,
            self.block_gripper,
            config.native_threads,
            resolve_physics(self.scene, config.physics),
        )
        self.model, self.backend, self.layout = (
            self.robot.model,
            self.robot.backend,
            self.robot.layout,
        )
        self.obs_dim, self.dt = self.robot.obs_dim, self.robot.dt
        self.goal_is_object = self.robot.has_object
        self.episode_length = config.episode_length or self.default_episode_length
        self.threshold = config.distance_threshold or self.default_threshold
        self.initial_gripper_xpos = jnp.asarray(self.robot.initial_gripper_xpos, jnp.float32)
        self.height_offset = self.robot.height_offset

    @classmethod
    def check_config(cls, config: EnvConfig) -> None:
        """ValueError if this task cannot honour `config` (`refuse_unsupported`): called
        before a run writes anything (`methods.check_task`), and again when the env is made."""
        refuse_unsupported(cls.__name__, config, cls.scene)

    # ------------------------------------------------------------------ goals
    def achieved_from_obs(self, obs: jax.Array) -> jax.Array:
        part = "object" if self.goal_is_object else "grip"
        return obs[..., self.layout[part]]

    def grasped(self, obs: jax.Array) -> jax.Array:
        return self.robot.grasped(obs)

    def compute_reward(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array:
        """gymnasium-robotics' sparse reward: -1 where the distance exceeds the threshold, else
        0 (at exactly the threshold: 0, while `is_success` says no)."""
        distance = jnp.linalg.norm(achieved_goal - desired_goal, axis=-1)
        return jnp.where(distance > self.threshold, -1.0, 0.0).astype(jnp.float32)

    def is_success(self, achieved_goal: jax.Array, desired_goal: jax.Array) -> jax.Array:
        """gymnasium-robotics' success: the distance below the threshold."""
        return jnp.linalg.norm(achieved_goal - desired_goal, axis=-1) < self.threshold

    # ------------------------------------------------------------------ sampling
    def sample_object_xy(self, key: jax.Array) -> jax.Array:
        """(2,) gymnasium-robotics' rejection loop: uniform within obj_range of the gripper's
        start, drawn again while within MIN_OBJECT_DISTANCE of it."""
        grip = self.initial_gripper_xpos[:2]

        def near(carry):
            return jnp.linalg.norm(carry[1] - grip) < MIN_OBJECT_DISTANCE

        def draw(carry):
            key, sub = jax.random.split(carry[0])
            offset = jax.random.uniform(sub, (2,), minval=-self.obj_range, maxval=self.obj_range)
            return key, grip + offset

        return jax.lax.while_loop(near, draw, (key, grip))[1]

    def sample_goal(self, key: jax.Array) -> jax.Array:
        """(3,) gymnasium-robotics' `_sample_goal`."""
        k_xyz, k_air, k_lift = jax.random.split(key, 3)
        offset = jax.random.uniform(
            k_xyz, (3,), minval=-self.target_range, maxval=self.target_range
        )
        goal = self.initial_gripper_xpos + offset
        if not self.goal_is_object:
            return goal
        goal = (goal + jnp.asarray(self.target_offset)).at[2].set(self.height_offset)
        if self.target_in_the_air:
            lift = jax.random.uniform(k_lift, minval=0.0, maxval=AIR_MAX)
            goal = goal.at[2].add(jnp.where(jax.random.uniform(k_air) < AIR_PROB, lift, 0.0))
        return goal

    # ------------------------------------------------------------------ reset / step
    def reset(self, key: jax.Array) -> State:
        k_object, k_goal = jax.random.split(key)
        object_xy = self.sample_object_xy(k_object) if self.goal_is_object else None
        return self.start_state(object_xy, self.sample_goal(k_goal))

    def start_state(self, object_xy: jax.Array | None, goal: jax.Array) -> State:
        """The episode's start with the object at `object_xy` (None without an object) and
        the desired goal `goal`: what `reset` draws, or any given start (the parity tests
        start from gymnasium-robotics' draws)."""
        return self.state_from(self.robot.start(object_xy), goal)

    def state_from(self, physics, goal: jax.Array) -> State:
        """The episode's first State from its start physics and desired goal (3,)."""
        zero = jnp.zeros((), jnp.float32)
        metrics = {
            "success": zero,
            "distance": zero,
            "invalid_actions": zero,
            "physics_resets": zero,
        }
        state = State(
            physics=physics,
            obs=jnp.zeros(self.obs_dim),
            achieved_goal=jnp.zeros(self.goal_dim),
            desired_goal=jnp.asarray(goal, jnp.float32),
            reward=zero,
            done=jnp.zeros((), bool),
            metrics=metrics,
            info={"step": jnp.zeros((), jnp.int32), "start_physics": physics},
        )
        return self._observe(state, physics, metrics)

    def _observe(self, state: State, physics, metrics: dict) -> State:
        obs = self.robot.observe(physics)
        achieved = self.achieved_from_obs(obs)
        goal = state.desired_goal
        metrics = {
            **metrics,
            "success": self.is_success(achieved, goal).astype(jnp.float32),
            "distance": jnp.linalg.norm(achieved - goal),
        }
        return state.replace(
            physics=physics,
            obs=obs,
            achieved_goal=achieved,
            reward=self.compute_reward(achieved, goal),
            metrics=metrics,
            info={**state.info, "grasped": self.grasped(obs)},
        )


_ON_TABLE = {"robot0:slide0": 0.405, "robot0:slide1": 0.48, "robot0:slide2": 0.0}
_BLOCK = (1.25, 0.53, 0.4, 1.0, 0.0, 0.0, 0.0)


class FetchReach(FetchTask):
    """Move the gripper to a 3-D goal within 15 cm of its start (fingers blocked)."""

    scene = "reach"
    initial_qpos = {**_ON_TABLE, "robot0:slide0": 0.4049}
    block_gripper = True
    gripper_extra_height = 0.2
    target_in_the_air = True
    n_objects = 0


class FetchPush(FetchTask):
    """Push the block to a goal on the table (fingers blocked)."""

    scene = "push"
    initial_qpos = {**_ON_TABLE, "object0:joint": _BLOCK}
    block_gripper = True
    gripper_extra_height = 0.0
    target_in_the_air = False


class FetchSlide(FetchTask):
    """Slide the puck over the low-friction table to a goal out of reach (fingers blocked)."""

    scene = "slide"
    initial_qpos = {
        **_ON_TABLE,
        "robot0:slide0": 0.05,
        "object0:joint": (1.7, 1.1, 0.41, 1, 0, 0, 0),
    }
    block_gripper = True
    gripper_extra_height = -0.02
    target_in_the_air = False
    target_offset = (0.4, 0.0, 0.0)
    obj_range = 0.1
    target_range = 0.3


class FetchPickAndPlace(FetchTask):
    """Pick the block and place it at a goal on the table or, half the time, in the air."""

    scene = "pick_and_place"
    initial_qpos = {**_ON_TABLE, "object0:joint": _BLOCK}
    block_gripper = False
    gripper_extra_height = 0.2
    target_in_the_air = True


FETCH_TASKS: dict[str, type[FetchTask]] = {
    "fetch_reach": FetchReach,
    "fetch_push": FetchPush,
    "fetch_slide": FetchSlide,
    "fetch_pick_and_place": FetchPickAndPlace,
}
"""Registry names -> tasks; gymnasium-robotics' ids: FetchReach-v4, FetchPush-v4, ..."""


def reference_id(name: str) -> str:
    """gymnasium-robotics' id of a registry name: 'fetch_push' -> 'FetchPush-v4'."""
    return FETCH_TASKS[name].__name__ + "-v4"
