"""Baxter with end-effector control: model loading, ids, sensors, reset and step.

Every id is resolved once from the MjModel by name. Observations come only from MJCF
sensors, so the same code runs on both physics backends. Tasks and skills subclass
`BaxterEnv` and provide the start distribution, the goal and the success predicate.
"""

from __future__ import annotations

import functools
from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from mjx_skills.config import EnvConfig
from mjx_skills.core.types import ObsLayout, State
from mjx_skills.envs.physics import PhysicsState, make_backend

XML_DIR = Path(__file__).resolve().parents[2] / "xml"

# Sensor names of the observation, in order, as declared in xml/baxter.xml and the scenes.
SENSORS = (
    "grip_pos", "grip_linvel", "finger_l_pos", "finger_r_pos", "finger_l_vel", "finger_r_vel",
    "object_pos", "object_quat", "object_linvel", "object_angvel",
)  # fmt: skip

# Observation layout (BaxterEnv.observation), used by skills, scripted controllers and tests.
OBS_GRIP = slice(0, 3)
OBS_OBJECT = slice(3, 6)
OBS_REL = slice(6, 9)  # object - grip
OBS_FINGERS = slice(9, 11)
OBS_GRIP_VEL = slice(20, 23)
LAYOUT = ObsLayout(size=25, grip=(0, 3), object=(3, 6), rel=(6, 9), fingers=(9, 11))
"""The same layout, as the env declares it to the library, the search and PAS."""

FINGER_OPEN = 0.020833  # finger travel in m (each); ctrl = -0.02 squeezes past closed.
FINGER_CLOSED_CTRL = -0.02
HOME_GRIP = np.array([0.7, -0.2, 0.1])  # grip point of the home pose, torso frame
UNTUCK_QPOS = np.array([0.08, -1.0, 1.19, 1.94, -0.67, 1.03, 0.50])
PARKED_OBJECT = np.array([2.0, 0.0, -0.5])  # out of every contact pair while the arm moves


def load_model(scene: str, config: EnvConfig) -> mujoco.MjModel:
    path = XML_DIR / scene
    if not path.exists():
        raise FileNotFoundError(f"scene {path} not found")
    model = mujoco.MjModel.from_xml_path(str(path))
    model.opt.timestep = config.timestep
    model.opt.iterations = config.solver_iterations
    model.opt.ls_iterations = config.ls_iterations
    return model


def home_qpos(model: mujoco.MjModel) -> np.ndarray:
    """Arm joints of the home pose: let the weld pull the untucked arm onto HOME_GRIP."""
    data = mujoco.MjData(model)
    data.qpos[:7] = UNTUCK_QPOS
    data.mocap_pos[0] = HOME_GRIP
    for _ in range(int(2.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    return data.qpos[:7].copy()


def smooth_path(start: jax.Array, end: jax.Array, n_substeps: int) -> jax.Array:
    """(n_substeps, 3) mocap path from start to end with a cosine velocity profile.

    Jumping the mocap target 5 cm at once makes the stiff weld accelerate the hand at
    hundreds of m/s^2, which shakes a held cube out of a 15 N grip; a smooth path keeps the
    peak acceleration near 11 m/s^2 for a full 5 cm step.
    """
    phase = jnp.arange(1, n_substeps + 1, dtype=jnp.float32) / n_substeps
    s = 0.5 * (1.0 - jnp.cos(jnp.pi * phase))
    return start + s[:, None] * (end - start)


def quat_to_euler(q: jax.Array) -> jax.Array:
    """(w, x, y, z) -> roll, pitch, yaw (x-y-z convention)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = jnp.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = jnp.arcsin(jnp.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = jnp.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return jnp.stack([roll, pitch, yaw], axis=-1)


class BaxterEnv:
    """Base of every task and skill env. Subclasses set the class attributes below and
    implement `sample_start` and (optionally) `achieved_goal` / `is_success`."""

    scene: str = "scene_pick_move.xml"
    default_episode_length: int = 50
    default_threshold: float = 0.03
    grasped_start: bool = False
    """Whether episodes start with the object held (transfer)."""
    goal_is_object: bool = True
    """Whether the achieved goal is the object's position (else the gripper's)."""
    action_dim = 4
    goal_dim = 3
    n_objects = 1
    layout: ObsLayout = LAYOUT
    """Where the gripper, the object and their relation lie in the observation."""
    parked: np.ndarray = PARKED_OBJECT
    """Where the object(s) wait, out of every contact, while a reset moves the arm."""

    def __init__(self, config: EnvConfig | None = None):
        self.config = config = config or EnvConfig()
        self.model = load_model(self.scene, config)
        self.home_arm_qpos = jnp.asarray(home_qpos(self.model), jnp.float32)
        # A weak spring pulls the seven joints toward the home posture. The weld fixes only
        # the grip's pose, so without it the redundant arm drifts into other IK branches
        # and can end against a joint limit (elbow straight) where it cannot follow.
        self.model.qpos_spring[:7] = np.asarray(self.home_arm_qpos)
        self.model.jnt_stiffness[:7] = config.posture_stiffness
        self.backend = make_backend(self.model, config.physics, config.native_threads)
        if config.goal_start_prob and self.n_objects == 1:
            raise ValueError("goal_start_prob: goal starts are for tasks of several cubes")
        self.episode_length = config.episode_length or self.default_episode_length
        self.threshold = config.distance_threshold or self.default_threshold
        sensors = {name: self.model.sensor(name) for name in SENSORS}
        self.sensor_slices = {
            name: slice(int(s.adr[0]), int(s.adr[0] + s.dim[0])) for name, s in sensors.items()
        }
        self.object_qpos_adr = self.model.jnt_qposadr[self.model.joint("object").id]
        self.object_qvel_adr = self.model.jnt_dofadr[self.model.joint("object").id]
        data = mujoco.MjData(self.model)
        mujoco.mj_kinematics(self.model, data)
        table = self.model.geom("table")
        self.table_z = float(data.geom_xpos[table.id][2] + table.size[2])
        self.object_half = float(self.model.geom("object").size[2])
        # Workspace of the grip point (torso frame): the thesis's box re-derived for our
        # table; z from just above the table (pads reach 5 mm below the grip point) to 25 cm.
        # Beyond x = 0.85 the arm nears full stretch, where its motion turns ill-conditioned.
        self.workspace_low = jnp.array([0.5, -0.5, self.table_z + 0.012])
        self.workspace_high = jnp.array([0.85, 0.1, self.table_z + 0.25])
        self.obs_dim = 25

    # ------------------------------------------------------------------ sensors
    def sensors(self, sensordata: jax.Array) -> dict[str, jax.Array]:
        return {name: sensordata[..., s] for name, s in self.sensor_slices.items()}

    def observation(self, sens: dict[str, jax.Array]) -> jax.Array:
        """25 numbers: grip pos, object pos, object - grip, finger pos (2), object rotation
        (euler), object lin/ang velocity, grip velocity, finger velocities (2)."""
        fingers = jnp.concatenate([sens["finger_l_pos"], sens["finger_r_pos"]], axis=-1)
        finger_vel = jnp.concatenate([sens["finger_l_vel"], sens["finger_r_vel"]], axis=-1)
        return jnp.concatenate(
            [
                sens["grip_pos"], sens["object_pos"], sens["object_pos"] - sens["grip_pos"],
                fingers, quat_to_euler(sens["object_quat"]), sens["object_linvel"],
                sens["object_angvel"], sens["grip_linvel"], finger_vel,
            ],
            axis=-1,
        )  # fmt: skip

    def grasped(self, obs: jax.Array) -> jax.Array:
        """The cube held, read from an observation (..., 25): between the pads, and the
        fingers' summed opening between a closed grip and fully open (the sum, not each
        finger: a held cube accelerated sideways shifts both fingers together)."""
        rel = obs[..., OBS_REL]
        near = (jnp.linalg.norm(rel[..., :2], axis=-1) < 0.015) & (jnp.abs(rel[..., 2]) < 0.025)
        gap = jnp.sum(obs[..., OBS_FINGERS], axis=-1)
        return near & (gap > 0.5 * self.object_half) & (gap < 1.96 * FINGER_OPEN)

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
        pose = jnp.concatenate([object_pos, jnp.array([1.0, 0.0, 0.0, 0.0])])
        qpos = qpos.at[self.object_qpos_adr : self.object_qpos_adr + 7].set(pose)
        qvel = qvel.at[self.object_qvel_adr : self.object_qvel_adr + 6].set(0.0)
        return qpos, qvel

    def place(self, grip: jax.Array, object_pos: jax.Array, held=None) -> PhysicsState:
        """Physics state with the grip point at `grip` and the object at `object_pos`.

        The weld carries the arm from home to `grip` with the object parked out of reach,
        then the object is put in place and, for held starts, the fingers close on it
        (otherwise one substep makes sensordata describe the placed state). `held`, a traced
        bool, chooses per reset (the fingers then close or stay open for the same substeps).
        """
        cfg = self.config
        qpos = jnp.zeros(self.model.nq).at[:7].set(self.home_arm_qpos)
        qpos, qvel = self._put_object(qpos, jnp.zeros(self.model.nv), jnp.asarray(self.parked))
        physics = self.backend.init(qpos, qvel)
        open_ctrl = jnp.full((2,), FINGER_OPEN)
        closed_ctrl = jnp.full((2,), FINGER_CLOSED_CTRL)
        if held is not None:
            last = (jnp.where(held, closed_ctrl, open_ctrl), cfg.grasp_settle_substeps)
        elif self.grasped_start:
            last = (closed_ctrl, cfg.grasp_settle_substeps)
        else:
            last = (open_ctrl, 1)
        phases = ((open_ctrl, cfg.settle_substeps), last)
        put = lambda qpos, qvel: self._put_object(qpos, qvel, object_pos)
        return self.backend.settle(physics, grip, phases, put)

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
            physics=physics, obs=jnp.zeros(self.obs_dim), achieved_goal=jnp.zeros(self.goal_dim),
            desired_goal=goal, reward=zero, done=jnp.zeros((), bool),
            metrics={"success": zero, "distance": zero, "invalid_actions": zero, "physics_resets": zero},
            info=info,
        )  # fmt: skip
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
            physics=physics, obs=obs, achieved_goal=achieved,
            reward=self.compute_reward(achieved, state.desired_goal), metrics=metrics, info=info,
        )  # fmt: skip

    def action_to_controls(self, grip_pos: jax.Array, action: jax.Array):
        """-> (finger ctrl (2,), mocap target (3,)): the target moves from where the grip
        is by action * 5 cm, clipped to the workspace; the gripper command maps [-1, 1]
        to [closed and squeezing, fully open]."""
        target = jnp.clip(
            grip_pos + self.config.action_scale * action[:3],
            self.workspace_low,
            self.workspace_high,
        )
        opening = FINGER_CLOSED_CTRL + (action[3] + 1.0) * 0.5 * (FINGER_OPEN - FINGER_CLOSED_CTRL)
        return jnp.full((2,), opening), target

    @staticmethod
    def sanitize_action(action: jax.Array) -> tuple[jax.Array, jax.Array]:
        """-> (the action the env executes, 1.0 if the given one was invalid else 0.0).
        NaN becomes 0; everything else is clipped to [-1, 1] (so +-inf acts as +-1, as a
        huge value does). The JAX env and the gymnasium adapter both execute this."""
        action = jnp.asarray(action, jnp.float32)
        invalid = jnp.any(~jnp.isfinite(action) | (jnp.abs(action) > 1.0)).astype(jnp.float32)
        return jnp.clip(jnp.where(jnp.isnan(action), 0.0, action), -1.0, 1.0), invalid

    def step(self, state: State, action: jax.Array) -> State:
        # NaN actions become 0 and out-of-range ones are clipped; both are counted.
        action, invalid = self.sanitize_action(action)
        grip_pos = self.sensors(state.physics.sensordata)["grip_pos"]
        ctrl, target = self.action_to_controls(grip_pos, action)
        path = smooth_path(grip_pos, target, self.config.n_substeps)
        physics = self.backend.step(state.physics, ctrl, path)
        # A diverged env goes back to its episode's start state, never poisoning the batch.
        diverged = ~jnp.all(jnp.isfinite(physics.sensordata)) | ~jnp.all(
            jnp.abs(self.backend.qvel(physics)) < self.config.max_qvel
        )
        physics = jax.tree.map(
            lambda start, new: jnp.where(diverged, start, new), state.info["start_physics"], physics
        )
        step = state.info["step"] + 1
        metrics = {
            **state.metrics,
            "invalid_actions": state.metrics["invalid_actions"] + invalid,
            "physics_resets": state.metrics["physics_resets"] + diverged.astype(jnp.float32),
        }
        state = state.replace(info={**state.info, "step": step}, done=step >= self.episode_length)
        return self._observe(state, physics, metrics)
