"""Baxter's right arm with end-effector control: the `envs.robot.Robot` of the Baxter scenes.

The scene is an MJCF file under xml/ (the arm, its two-finger gripper, the table and a cube;
the tasks' scenes add their fixtures). The controller moves a mocap target, welded to the
grip point, along a smooth path of at most `EnvConfig.action_scale` per step inside the
workspace; the gripper maps the action's last entry to the finger position actuators.
Every id is resolved once from the MjModel by name. Observations come only from MJCF
sensors, so the same code runs on both physics backends.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from mjx_skills.config import EnvConfig
from mjx_skills.core.types import ObsLayout
from mjx_skills.envs.physics import PhysicsState, make_backend

XML_DIR = Path(__file__).resolve().parents[2] / "xml"

# Sensor names of the observation, in order, as declared in xml/baxter.xml and the scenes.
SENSORS = (
    "grip_pos",
    "grip_linvel",
    "finger_l_pos",
    "finger_r_pos",
    "finger_l_vel",
    "finger_r_vel",
    "object_pos",
    "object_quat",
    "object_linvel",
    "object_angvel",
)

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


PutObject = Callable[[jax.Array, jax.Array, jax.Array], tuple[jax.Array, jax.Array]]
"""(qpos, qvel, object position(s)) -> (qpos, qvel) with the object(s) posed at rest."""


class BaxterRobot:
    """Baxter's right arm in the scene `scene` (a file under xml/), with `config`'s physics
    (timestep, solver, backend, posture spring) and control (action_scale, n_substeps)."""

    name = "baxter"
    action_dim = 4
    layout: ObsLayout = LAYOUT
    obs_dim = LAYOUT.size
    parked: np.ndarray = PARKED_OBJECT
    """Where the object waits, out of every contact, while a reset moves the arm."""

    def __init__(self, scene: str, config: EnvConfig):
        self.scene, self.config = scene, config
        self.model = load_model(scene, config)
        self.action_scale = config.action_scale
        self.home_arm_qpos = jnp.asarray(home_qpos(self.model), jnp.float32)
        # A weak spring pulls the seven joints toward the home posture. The weld fixes only
        # the grip's pose, so without it the redundant arm drifts into other IK branches
        # and can end against a joint limit (elbow straight) where it cannot follow.
        self.model.qpos_spring[:7] = np.asarray(self.home_arm_qpos)
        self.model.jnt_stiffness[:7] = config.posture_stiffness
        self.backend = make_backend(self.model, config.physics, config.native_threads)
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

    # ------------------------------------------------------------------ observation
    def sensors(self, sensordata: jax.Array) -> dict[str, jax.Array]:
        return {name: sensordata[..., s] for name, s in self.sensor_slices.items()}

    @staticmethod
    def observation(sens: dict[str, jax.Array]) -> jax.Array:
        """25 numbers: grip pos, object pos, object - grip, finger pos (2), object rotation
        (euler), object lin/ang velocity, grip velocity, finger velocities (2)."""
        fingers = jnp.concatenate([sens["finger_l_pos"], sens["finger_r_pos"]], axis=-1)
        finger_vel = jnp.concatenate([sens["finger_l_vel"], sens["finger_r_vel"]], axis=-1)
        return jnp.concatenate(
            [
                sens["grip_pos"],
                sens["object_pos"],
                sens["object_pos"] - sens["grip_pos"],
                fingers,
                quat_to_euler(sens["object_quat"]),
                sens["object_linvel"],
                sens["object_angvel"],
                sens["grip_linvel"],
                finger_vel,
            ],
            axis=-1,
        )

    def observe(self, physics: PhysicsState) -> jax.Array:
        """The one-cube observation (25,) of a physics state (`observation`)."""
        return self.observation(self.sensors(physics.sensordata))

    def grasped(self, obs: jax.Array) -> jax.Array:
        """The cube held, read from an observation (..., 25): between the pads, and the
        fingers' summed opening between a closed grip and fully open (the sum, not each
        finger: a held cube accelerated sideways shifts both fingers together)."""
        rel = obs[..., OBS_REL]
        near = (jnp.linalg.norm(rel[..., :2], axis=-1) < 0.015) & (jnp.abs(rel[..., 2]) < 0.025)
        gap = jnp.sum(obs[..., OBS_FINGERS], axis=-1)
        return near & (gap > 0.5 * self.object_half) & (gap < 1.96 * FINGER_OPEN)

    # ------------------------------------------------------------------ start state
    def put_object(self, qpos: jax.Array, qvel: jax.Array, object_pos: jax.Array):
        """(qpos, qvel) with the cube at `object_pos` (3,), m, upright and at rest."""
        pose = jnp.concatenate([object_pos, jnp.array([1.0, 0.0, 0.0, 0.0])])
        qpos = qpos.at[self.object_qpos_adr : self.object_qpos_adr + 7].set(pose)
        qvel = qvel.at[self.object_qvel_adr : self.object_qvel_adr + 6].set(0.0)
        return qpos, qvel

    def place(
        self,
        grip: jax.Array,
        object_pos: jax.Array,
        held=None,
        closed: bool = False,
        put: PutObject | None = None,
        parked: np.ndarray | None = None,
    ) -> PhysicsState:
        """Physics state with the grip point at `grip` and the object at `object_pos`.

        The weld carries the arm from home to `grip` with the object parked out of reach,
        then the object is put in place and, for held starts, the fingers close on it
        (otherwise one substep makes sensordata describe the placed state). `held`, a traced
        bool, chooses per reset (the fingers then close or stay open for the same substeps);
        `closed`: every start is held (transfer). `put`, `parked`: a scene's own object
        placement and parking spot (several cubes); default the one cube's.
        """
        cfg = self.config
        put_at = put or self.put_object
        parked = self.parked if parked is None else parked
        qpos = jnp.zeros(self.model.nq).at[:7].set(self.home_arm_qpos)
        qpos, qvel = put_at(qpos, jnp.zeros(self.model.nv), jnp.asarray(parked))
        physics = self.backend.init(qpos, qvel)
        open_ctrl = jnp.full((2,), FINGER_OPEN)
        closed_ctrl = jnp.full((2,), FINGER_CLOSED_CTRL)
        if held is not None:
            last = (jnp.where(held, closed_ctrl, open_ctrl), cfg.grasp_settle_substeps)
        elif closed:
            last = (closed_ctrl, cfg.grasp_settle_substeps)
        else:
            last = (open_ctrl, 1)
        phases = ((open_ctrl, cfg.settle_substeps), last)
        return self.backend.settle(physics, grip, phases, lambda q, v: put_at(q, v, object_pos))

    def start(self, object_pos: jax.Array | None, grip: jax.Array | None = None) -> PhysicsState:
        """The contract's start state: the cube at `object_pos` (3,) (None: parked out of
        reach), the grip point at `grip` (3,) (None: the home pose's, HOME_GRIP), open."""
        parked = jnp.asarray(self.parked)
        grip = jnp.asarray(HOME_GRIP, jnp.float32) if grip is None else grip
        return self.place(grip, parked if object_pos is None else object_pos)

    # ------------------------------------------------------------------ control
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

    def controls(self, physics: PhysicsState, action: jax.Array) -> tuple[jax.Array, jax.Array]:
        """action (4,) -> (finger ctrl (2,), mocap path (n_substeps, 3)): `action_to_controls`
        from the sensed grip point, reached along `smooth_path`."""
        grip_pos = self.sensors(physics.sensordata)["grip_pos"]
        ctrl, target = self.action_to_controls(grip_pos, action)
        return ctrl, smooth_path(grip_pos, target, self.config.n_substeps)

    def step(self, physics: PhysicsState, control: tuple[jax.Array, jax.Array]) -> PhysicsState:
        """n_substeps substeps, the mocap following the path with the fingers' ctrl held."""
        ctrl, path = control
        return self.backend.step(physics, ctrl, path)
