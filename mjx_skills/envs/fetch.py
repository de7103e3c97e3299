"""The Fetch robot of gymnasium-robotics 1.4.2 for JAX envs: scene, controller, gripper,
observation and start state, on the native MuJoCo backend or MJX (`envs/fetch_mjx.py`).

The MJCF is the installed gymnasium-robotics package's own (never copied into xml/), with
sensors added (`mujoco.MjSpec`) so that the native backend's `sensordata` carries every
kinematic quantity the observation reads; sensors do not act on the dynamics
(`tests/envs/test_fetch.py` steps both models side by side). The facts below are
gymnasium-robotics' (`envs/fetch/fetch_env.py`, `utils/mujoco_utils.py`, MIT); the code is
ours. `FetchRobot` is what a task reads of the robot: the `envs.robot.Robot` contract's
Fetch (scene, end-effector controller, gripper, observation layout, workspace, start state).

Timing, as in gymnasium-robotics: an env step sets the mocap target and the finger
controls, runs 20 substeps of 0.002 s (`mj_step`), then, where the gripper is blocked
(reach, push, slide), puts both finger joints back to 0 and calls `mj_forward`. The
observation then reads the MjData as it is: after the forward pass, every quantity is of
the end state; without it (pick and place) the positions, orientations and Jacobians are
those computed at the start of the last substep while qpos and qvel are the end state's.
`FetchRobot.step` reproduces both: it senses the state vector those quantities belong to.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from mjx_skills.core.types import ObsLayout
from mjx_skills.envs.fetch_mjx import fetch_backend
from mjx_skills.envs.physics import PhysicsState

N_SUBSTEPS = 20
"""Substeps of the model's 0.002 s per env step (0.04 s: 25 Hz)."""
ACTION_SCALE = 0.05
"""The mocap target moves by at most 5 cm per step from the gripper body."""
MOCAP_QUAT_OFFSET = (1.0, 0.0, 1.0, 0.0)
"""Added to the gripper body's quaternion (not normalised: MuJoCo does that) as the mocap's
orientation at every step, as gymnasium-robotics' `_set_action` does."""
GRIPPER_TARGET_OFFSET = (-0.498, 0.005, -0.431)
"""`_env_setup`: the mocap target of the setup, from the grip site's position at the initial
joints (plus the task's gripper_extra_height in z)."""
SETUP_STEPS = 10
"""`_env_setup`: env steps (of N_SUBSTEPS each) that carry the gripper to its start."""
FINGERS = ("robot0:r_gripper_finger_joint", "robot0:l_gripper_finger_joint")
"""The gripper state's order: the last two `robot*` joints by joint id (`robot_get_obs`)."""
GRIP, HAND, OBJECT = "robot0:grip", "robot0:gripper_link", "object0"
"""The grip site, the body welded to the mocap, the object's site."""
PLACE_STEPS = 10
"""Env steps the mocap takes to carry the grip to a chosen start (`FetchRobot.place`): from
the setup's pose it reaches any point of the skills' box within about 1 cm."""
CLOSE_STEPS = 4
"""Env steps the fingers then take to close on a held object (or stay open); the object is
held in place, at rest, before each of them but the last."""
PARKED_OBJECT = (1.3, 0.75, 3.0, 1.0, 0.0, 0.0, 0.0)
"""Where the object waits (qpos: position, quaternion), far above every contact, while
`place` moves the arm."""
WORKSPACE_HEIGHT = 0.5
"""The workspace reaches this far (m) above the table's top: the goals in the air, at most
45 cm above a block resting on it (`fetch_tasks.AIR_MAX`), lie within."""

_S, _O = mujoco.mjtSensor, mujoco.mjtObj
ROBOT_SENSORS = {
    "grip_pos": (_S.mjSENS_FRAMEPOS, _O.mjOBJ_SITE, GRIP),
    "grip_linvel": (_S.mjSENS_FRAMELINVEL, _O.mjOBJ_SITE, GRIP),
    "hand_pos": (_S.mjSENS_FRAMEPOS, _O.mjOBJ_XBODY, HAND),
    "hand_quat": (_S.mjSENS_FRAMEQUAT, _O.mjOBJ_XBODY, HAND),
}
"""Sensors added to every scene: name -> (type, object type, object name). The grip site's
position and global linear velocity (= `mj_jacSite` @ qvel, gymnasium-robotics' `xvelp`);
the gripper body's frame (xpos, xquat), from which the mocap is set."""
OBJECT_SENSORS = {
    "object_pos": (_S.mjSENS_FRAMEPOS, _O.mjOBJ_SITE, OBJECT),
    "object_xaxis": (_S.mjSENS_FRAMEXAXIS, _O.mjOBJ_SITE, OBJECT),
    "object_yaxis": (_S.mjSENS_FRAMEYAXIS, _O.mjOBJ_SITE, OBJECT),
    "object_zaxis": (_S.mjSENS_FRAMEZAXIS, _O.mjOBJ_SITE, OBJECT),
    "object_linvel": (_S.mjSENS_FRAMELINVEL, _O.mjOBJ_SITE, OBJECT),
    "object_angvel": (_S.mjSENS_FRAMEANGVEL, _O.mjOBJ_SITE, OBJECT),
}
"""Added where there is an object: its site's position, the columns of its rotation matrix
(`site_xmat`, read as it is), global linear and angular velocity."""

_EULER_EPS = 4 * np.finfo(np.float64).eps
"""gymnasium-robotics' `mat2euler` switches branch where cos(pitch) is below this."""


def asset_dir() -> Path:
    """The installed gymnasium-robotics package's Fetch MJCF folder (found without importing
    the package, which prints a notice on import)."""
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError(
            "the Fetch tasks load their MJCF from gymnasium-robotics: "
            "pip install gymnasium-robotics==1.4.2"
        )
    return Path(spec.submodule_search_locations[0]) / "envs" / "assets" / "fetch"


def load_model(scene: str, has_object: bool) -> mujoco.MjModel:
    """gymnasium-robotics' `fetch/<scene>.xml` with the observation's sensors added and the
    mocap weld's relative pose set as its `reset_mocap_welds` sets it (both documented in
    docs/simulation.md)."""
    path = asset_dir() / f"{scene}.xml"
    if not path.exists():
        raise FileNotFoundError(f"{path} not found (gymnasium-robotics 1.4.2's Fetch scenes)")
    spec = mujoco.MjSpec.from_file(str(path))
    for name, (kind, objtype, objname) in sensors_of(has_object).items():
        sensor = spec.add_sensor()
        sensor.name, sensor.type, sensor.objtype, sensor.objname = name, kind, objtype, objname
    model = spec.compile()
    welds = model.eq_type == mujoco.mjtEq.mjEQ_WELD
    model.eq_data[welds, :7] = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    return model


def table_box(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """-> (low (3,), high (3,)), m: the box over the top of the table ('table0'), from its
    surface to WORKSPACE_HEIGHT above it: Fetch's declared workspace."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    geom = int(np.flatnonzero(model.geom_bodyid == model.body("table0").id)[0])
    centre, half = data.geom_xpos[geom], model.geom_size[geom]
    top = centre[2] + half[2]
    low = np.array([centre[0] - half[0], centre[1] - half[1], top])
    return low, np.array([centre[0] + half[0], centre[1] + half[1], top + WORKSPACE_HEIGHT])


def sensors_of(has_object: bool) -> dict[str, tuple]:
    return {**ROBOT_SENSORS, **(OBJECT_SENSORS if has_object else {})}


def _sensor_slice(model: mujoco.MjModel, name: str) -> slice:
    sensor = model.sensor(name)
    return slice(int(sensor.adr[0]), int(sensor.adr[0] + sensor.dim[0]))


def mat2euler(mat: jax.Array) -> jax.Array:
    """(..., 3, 3) rotation matrices -> (..., 3) Euler angles, by gymnasium-robotics'
    `rotations.mat2euler` formula (its branch at gimbal lock included)."""
    cy = jnp.sqrt(mat[..., 2, 2] ** 2 + mat[..., 1, 2] ** 2)
    regular = cy > _EULER_EPS
    z = jnp.where(
        regular,
        -jnp.arctan2(mat[..., 0, 1], mat[..., 0, 0]),
        -jnp.arctan2(-mat[..., 1, 0], mat[..., 1, 1]),
    )
    y = -jnp.arctan2(-mat[..., 0, 2], cy)
    x = jnp.where(regular, -jnp.arctan2(mat[..., 1, 2], mat[..., 2, 2]), 0.0)
    return jnp.stack([x, y, z], axis=-1)


class FetchRobot:
    """The Fetch arm in one of gymnasium-robotics' scenes.

    scene: 'reach', 'push', 'slide' or 'pick_and_place' (the MJCF file); initial_qpos:
    joint name -> value, set before the setup; gripper_extra_height: the setup's target
    height above the default; block_gripper: the fingers are held at 0 (reset after every
    step) and the gripper action is ignored; physics: 'native' (the model as loaded) or
    'mjx' (`envs.fetch_mjx`: the model with MJX's edits, on which the setup runs too).
    """

    name = "fetch"
    action_dim = 4
    action_scale = ACTION_SCALE

    def __init__(
        self,
        scene: str,
        initial_qpos: dict[str, tuple[float, ...] | float],
        gripper_extra_height: float,
        block_gripper: bool,
        n_threads: int = 0,
        physics: str = "native",
    ):
        self.scene = scene
        self.has_object = "object0:joint" in initial_qpos
        self.block_gripper = block_gripper
        self.backend = fetch_backend(load_model(scene, self.has_object), physics, n_threads)
        self.model = model = self.backend.model
        self.dt = N_SUBSTEPS * float(model.opt.timestep)
        """Seconds per env step; the observation's velocities are multiplied by it."""
        self.sensor_slices = {
            name: _sensor_slice(model, name) for name in sensors_of(self.has_object)
        }
        self.finger_qpos = np.array([model.joint(j).qposadr[0] for j in FINGERS])
        self.finger_dof = np.array([model.joint(j).dofadr[0] for j in FINGERS])
        # ctrl_set_action: position actuators (biastype != 0) aim relative to their joint.
        self.actuator_qpos = np.array(
            [model.jnt_qposadr[model.actuator_trnid[i, 0]] for i in range(model.nu)], int
        )
        self.relative_ctrl = np.array([model.actuator_biastype[i] != 0 for i in range(model.nu)])
        mocap_body = int(np.flatnonzero(model.body_mocapid >= 0)[0])
        # What mj_resetData puts in the mocap inputs (no sensor depends on them).
        self.reset_mocap = np.concatenate([model.body_pos[mocap_body], model.body_quat[mocap_body]])
        self._setup(initial_qpos, gripper_extra_height)
        self.obs_dim = 25 if self.has_object else 10
        self.layout = (
            ObsLayout(size=25, grip=(0, 3), object=(3, 6), rel=(6, 9), fingers=(9, 11))
            if self.has_object
            else ObsLayout(size=10, grip=(0, 3), object=(3, 3), rel=(3, 3), fingers=(3, 5))
        )
        """Reach has no object: its object and rel parts are empty."""
        low, high = table_box(model)
        self.workspace_low = jnp.asarray(low, jnp.float32)
        self.workspace_high = jnp.asarray(high, jnp.float32)
        """The table's top up to WORKSPACE_HEIGHT: where the tasks' objects and goals lie
        (slide's goals at its far end). Declared, not enforced: gymnasium-robotics' controller
        moves the mocap without clipping, and so does `controls`."""

    def _setup(self, initial_qpos: dict, gripper_extra_height: float) -> None:
        """gymnasium-robotics' `_env_setup`, in float64 on the host, once: the initial joints,
        then SETUP_STEPS steps of the mocap toward the gripper target. Sets the start state
        every reset returns to, the gripper's start position and (with an object) the
        height of an object resting on the table."""
        model, data = self.model, mujoco.MjData(self.model)
        for name, value in initial_qpos.items():
            joint = model.joint(name)
            value = np.atleast_1d(np.asarray(value, np.float64))
            data.qpos[joint.qposadr[0] : joint.qposadr[0] + value.size] = value
        mujoco.mj_forward(model, data)
        grip = model.site(GRIP).id
        offset = np.array(GRIPPER_TARGET_OFFSET) + [0.0, 0.0, gripper_extra_height]
        data.mocap_pos[0] = offset + data.site_xpos[grip]
        data.mocap_quat[0] = MOCAP_QUAT_OFFSET
        for _ in range(SETUP_STEPS):
            mujoco.mj_step(model, data, nstep=N_SUBSTEPS)
        # Read as gymnasium-robotics reads them: from the kinematics mj_step left behind.
        self.initial_gripper_xpos = data.site_xpos[grip].copy()
        self.height_offset = (
            float(data.site_xpos[model.site(OBJECT).id][2]) if self.has_object else 0.0
        )
        self.start_qpos, self.start_qvel = data.qpos.copy(), data.qvel.copy()
        # The gripper body's pose at the setup's end: `place` keeps its orientation.
        self.hand_from_grip = data.xpos[model.body(HAND).id] - self.initial_gripper_xpos
        self.start_hand_quat = data.xquat[model.body(HAND).id].copy()
        if self.has_object:
            self.object_qpos = int(model.joint("object0:joint").qposadr[0])
            self.object_dof = int(model.joint("object0:joint").dofadr[0])

    # ------------------------------------------------------------------ state
    def sensors(self, sensordata: jax.Array) -> dict[str, jax.Array]:
        return {name: sensordata[..., s] for name, s in self.sensor_slices.items()}

    def start(self, object_xy: jax.Array | None, grip: jax.Array | None = None) -> PhysicsState:
        """The setup's end state with the object moved to `object_xy` ((2,), m; or (3,),
        of which the xy: its height and orientation stay as the setup left them), sensed
        after a forward pass (`_reset_sim`). The grip starts where the setup left it
        (`initial_gripper_xpos`): ValueError for any other `grip`."""
        if grip is not None:
            raise ValueError("Fetch starts with the grip where the setup leaves it: grip=None")
        qpos = jnp.asarray(self.start_qpos, jnp.float32)
        if self.has_object:
            qpos = qpos.at[self.object_qpos : self.object_qpos + 2].set(object_xy[:2])
        physics = self.backend.init(qpos, jnp.asarray(self.start_qvel, jnp.float32))
        control = jnp.concatenate([jnp.zeros(self.model.nu), jnp.asarray(self.reset_mocap)])
        return physics.replace(sensordata=self.backend.sense(physics.data, control))

    def place(
        self,
        grip: jax.Array,
        object_pos: jax.Array,
        held: jax.Array,
        fingers_open: jax.Array | bool = True,
        held_below: jax.Array | float = 0.0,
    ) -> PhysicsState:
        """A start with the grip at `grip` ((3,), m) and the object at `object_pos` ((3,) m,
        its centre) or, where `held` (bool), closed in the fingers at the grip: the skills'
        starts (`envs.fetch_skills`). From the setup's end, with the object parked
        (PARKED_OBJECT), the mocap carries the gripper body (its orientation kept) to where
        the grip lies at `grip` for PLACE_STEPS env steps, the fingers opening (held, or
        `fingers_open`) or closing; then the object is put in place at rest, and for
        CLOSE_STEPS more the fingers close on a held one (put back in place before each
        step but the last; `held_below` m below the grip) or keep opening or closing.
        ValueError on a scene without an object."""
        if not self.has_object:
            raise ValueError(f"scene {self.scene!r} has no object to place")
        obj = slice(self.object_qpos, self.object_qpos + 7)
        qpos = jnp.asarray(self.start_qpos, jnp.float32).at[obj].set(jnp.asarray(PARKED_OBJECT))
        physics = self.backend.init(qpos, jnp.zeros(self.model.nv, jnp.float32))
        mocap = jnp.concatenate(
            [
                jnp.asarray(grip, jnp.float32) + jnp.asarray(self.hand_from_grip, jnp.float32),
                jnp.asarray(self.start_hand_quat + np.asarray(MOCAP_QUAT_OFFSET), jnp.float32),
            ]
        )
        opening = jnp.where(held | jnp.asarray(fingers_open), 1.0, -1.0)
        physics = self._hold(physics, mocap, opening, PLACE_STEPS)
        grip_now = self.sensors(self._sensed(physics, mocap))["grip_pos"]
        at = jnp.concatenate(
            [
                jnp.where(
                    held,
                    grip_now - jnp.array([0.0, 0.0, 1.0]) * held_below,
                    jnp.asarray(object_pos, jnp.float32),
                ),
                jnp.array([1.0, 0.0, 0.0, 0.0]),
            ]
        )
        gripper = jnp.where(held, -1.0, opening)
        for step in range(CLOSE_STEPS):
            # The block is put (back) in place at rest before each step but the last, so
            # that a held one cannot fall while the fingers close on it.
            if step < CLOSE_STEPS - 1:
                pinned = self.backend.qpos(physics).at[obj].set(at)
                dofs = slice(self.object_dof, self.object_dof + 6)
                qpos = jnp.where((step == 0) | held, pinned, self.backend.qpos(physics))
                qvel = self.backend.qvel(physics)
                qvel = jnp.where((step == 0) | held, qvel.at[dofs].set(0.0), qvel)
                physics = self.backend.set_qpos_qvel(physics, qpos, qvel)
            physics = self._hold(physics, mocap, gripper, 1)
        return physics.replace(sensordata=self._sensed(physics, mocap))

    def _finger_ctrl(self, physics: PhysicsState, gripper: jax.Array) -> jax.Array:
        """The actuators' controls for gripper command `gripper` (as `controls` sets them)."""
        joints = self.backend.qpos(physics)[self.actuator_qpos]
        return jnp.where(self.relative_ctrl, joints, 0.0) + gripper

    def _hold(self, physics, mocap: jax.Array, gripper: jax.Array, steps: int) -> PhysicsState:
        """`steps` env steps with the mocap held at `mocap` (position, quaternion); with the
        gripper blocked, the fingers are put back to 0 after each, as `step` does (without
        actuators, they would swing open and knock a block nearby)."""
        if not self.block_gripper:
            path = jnp.broadcast_to(mocap, (steps * N_SUBSTEPS, mocap.shape[0]))
            return self.backend.step(physics, self._finger_ctrl(physics, gripper), path)
        path = jnp.broadcast_to(mocap, (N_SUBSTEPS, mocap.shape[0]))

        def one(state: PhysicsState, _) -> tuple[PhysicsState, None]:
            state = self.backend.step(state, self._finger_ctrl(state, gripper), path)
            qpos = self.backend.qpos(state).at[self.finger_qpos].set(0.0)
            return self.backend.set_qpos_qvel(state, qpos, self.backend.qvel(state)), None

        return jax.lax.scan(one, physics, None, length=steps)[0]

    def _sensed(self, physics: PhysicsState, mocap: jax.Array) -> jax.Array:
        """The sensors of the state vector itself (not the last substep's start)."""
        control = jnp.concatenate([self._finger_ctrl(physics, jnp.float32(0.0)), mocap])
        return self.backend.sense(physics.data, control)

    def controls(self, physics: PhysicsState, action: jax.Array) -> jax.Array:
        """action (4,) in [-1, 1] -> one substep's control vector (ctrl, mocap position,
        mocap quaternion): the mocap at the gripper body's frame (as the MjData holds it)
        moved by action[:3] x 5 cm and turned by MOCAP_QUAT_OFFSET; each finger actuator
        aims action[3] from its joint's position (0 with the gripper blocked)."""
        sens = self.sensors(physics.sensordata)
        pos = sens["hand_pos"] + ACTION_SCALE * action[:3]
        quat = sens["hand_quat"] + jnp.asarray(MOCAP_QUAT_OFFSET)
        gripper = 0.0 if self.block_gripper else action[3]
        joints = self.backend.qpos(physics)[self.actuator_qpos]
        ctrl = jnp.where(self.relative_ctrl, joints, 0.0) + gripper
        return jnp.concatenate([ctrl, pos, quat])

    def step(self, physics: PhysicsState, control: jax.Array) -> PhysicsState:
        """N_SUBSTEPS substeps with `control` held, then the blocked gripper's finger reset;
        `sensordata` of the state the observation reads (see the module's docstring)."""
        nu = self.model.nu
        path = jnp.broadcast_to(control[nu:], (N_SUBSTEPS, control.shape[0] - nu))
        after, before = self.backend.step_with_previous(physics, control[:nu], path)
        qvel = self.backend.qvel(after)
        if self.block_gripper:  # _step_callback: fingers to 0, then mj_forward
            qpos = self.backend.qpos(after).at[self.finger_qpos].set(0.0)
            after = self.backend.set_qpos_qvel(after, qpos, qvel)
            sensed = after.data
        else:  # mj_step's kinematics: the last substep's start positions, the end's qvel
            previous = PhysicsState(data=before, sensordata=after.sensordata)
            sensed = self.backend.set_qpos_qvel(previous, self.backend.qpos(previous), qvel).data
        return after.replace(sensordata=self.backend.sense(sensed, control))

    # ------------------------------------------------------------------ observation
    def observe(self, physics: PhysicsState) -> jax.Array:
        """gymnasium-robotics' observation: grip position, [object position, object - grip,]
        finger joints (r, l), [object rotation (Euler), object velocity relative to the grip,
        object angular velocity,] grip velocity, finger velocities; velocities x dt."""
        sens = self.sensors(physics.sensordata)
        grip, grip_vel = sens["grip_pos"], sens["grip_linvel"] * self.dt
        fingers = self.backend.qpos(physics)[self.finger_qpos]
        finger_vel = self.backend.qvel(physics)[self.finger_dof] * self.dt
        if not self.has_object:
            return jnp.concatenate([grip, fingers, grip_vel, finger_vel])
        obj = sens["object_pos"]
        axes = (sens["object_xaxis"], sens["object_yaxis"], sens["object_zaxis"])
        rotation = mat2euler(jnp.stack(axes, axis=-1))  # the axes are xmat's columns
        object_vel = sens["object_linvel"] * self.dt - grip_vel
        object_angvel = sens["object_angvel"] * self.dt
        parts = (grip, obj, obj - grip, fingers, rotation, object_vel, object_angvel, grip_vel)
        return jnp.concatenate([*parts, finger_vel])

    def grasped(self, obs: jax.Array) -> jax.Array:
        """The object between the fingers, read from observations (..., 25): its centre
        within 3 cm of the grip site (a grasp from above holds the 5 cm block up to 2-3 cm
        below the grip: measured on the search's grasps, the median offset is 2.0 cm) and the
        fingers closed on it, neither shut nor open."""
        if not self.has_object:
            return jnp.zeros(obs.shape[:-1], bool)
        rel = obs[..., self.layout["rel"]]
        gap = jnp.sum(obs[..., self.layout["fingers"]], axis=-1)
        return (jnp.linalg.norm(rel, axis=-1) < 0.03) & (gap > 0.02) & (gap < 0.06)
