"""Two physics backends behind one small interface, both callable inside jitted JAX code.

- `MjxBackend`: `mujoco.mjx.step` in a `lax.scan`; the backend for accelerators.
- `NativeBackend`: native MuJoCo stepping a whole batch with `mujoco.rollout` (one thread
  per core) inside `jax.pure_callback`; on a CPU it is 17-57x faster than MJX.

Both keep the full physics state in a `PhysicsState` pytree and return `sensordata` with the
same meaning: the sensors of the state at the start of the last substep (MuJoCo computes
sensors in the forward pass that precedes integration, in C as in MJX). Env code reads only
`sensordata` and the generic `qpos`/`qvel` accessors, so it is written once for both.

The native backend also serves envs that need more than that (the Fetch tasks, which
replay gymnasium-robotics' own timing): the mocap quaternion as a control input
(`mocap_quat=True`), the state before the last substep (`step_with_previous`) and the
sensors of any state vector (`sense`).
"""

from __future__ import annotations

import contextlib
import io
import threading
from collections.abc import Callable
from typing import Any, Protocol

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import rollout

from mjx_skills.config import PHYSICS
from mjx_skills.core.workers import usable_cores

# mujoco.mjx prints "Failed to import warp" when its optional Warp backend is absent, as it
# is on a CPU; keep that out of every CLI run's output.
with contextlib.redirect_stdout(io.StringIO()):
    from mujoco import mjx

# The native state vector: MuJoCo's "full physics" state (time, qpos, qvel, act, ...).
# Mocap positions (and, for envs that ask, quaternions) are inputs, passed per step together
# with ctrl.
_NATIVE_STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS
_NATIVE_CONTROL_SPEC = mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_MOCAP_POS
_NATIVE_CONTROL_SPEC_QUAT = _NATIVE_CONTROL_SPEC | mujoco.mjtState.mjSTATE_MOCAP_QUAT


@struct.dataclass
class PhysicsState:
    data: Any
    """`mjx.Data` (mjx backend) or MuJoCo's full-physics state vector (native backend)."""
    sensordata: jax.Array
    """(nsensordata,) sensors of the state at the start of the last substep."""


class PhysicsBackend(Protocol):
    model: mujoco.MjModel

    def init(self, qpos: jax.Array, qvel: jax.Array) -> PhysicsState: ...

    def step(self, state: PhysicsState, ctrl: jax.Array, mocap_path: jax.Array) -> PhysicsState:
        """Advance len(mocap_path) substeps; ctrl (nu,) is held, the mocap body follows
        mocap_path (n_substeps, 3)."""
        ...

    def settle(
        self,
        state: PhysicsState,
        mocap_pos: jax.Array,
        phases: tuple[tuple[jax.Array, int], ...],
        edit: Callable[[jax.Array, jax.Array], tuple[jax.Array, jax.Array]],
    ) -> PhysicsState:
        """Two phases at a fixed mocap position, (ctrl, n_substeps) each, with
        `edit(qpos, qvel) -> (qpos, qvel)` applied between them (resets use it)."""
        ...

    def qpos(self, state: PhysicsState) -> jax.Array: ...

    def qvel(self, state: PhysicsState) -> jax.Array: ...


class MjxBackend:
    """MJX: the whole step is traced into the caller's XLA program."""

    compiler_options: dict[str, str] | None = None
    """XLA options every program stepping this backend is compiled with (`jax.jit(...,
    compiler_options=...)`; None: XLA's defaults)."""

    name = "mjx"

    def __init__(self, model: mujoco.MjModel, mocap_quat: bool = False):
        """`mocap_quat`: each substep's mocap input is position and quaternion (7 numbers
        per mocap body), as `NativeBackend`'s. NotImplementedError where `mjx.put_model`
        refuses the model."""
        self.model = model
        self.mocap_quat = mocap_quat
        self.mjx_model = mjx.put_model(model)
        self._data0 = mjx.make_data(model)

    def init(self, qpos: jax.Array, qvel: jax.Array) -> PhysicsState:
        data = self._data0.replace(qpos=qpos, qvel=qvel)
        return PhysicsState(data=data, sensordata=jnp.zeros(self.model.nsensordata, jnp.float32))

    def step(self, state: PhysicsState, ctrl: jax.Array, mocap_path: jax.Array) -> PhysicsState:
        def substep(d, mocap):
            return mjx.step(self.mjx_model, self._with_mocap(d, mocap)), None

        data, _ = jax.lax.scan(substep, self._cold(state.data, ctrl), mocap_path)
        return PhysicsState(data=data, sensordata=data.sensordata)

    def step_with_previous(
        self, state: PhysicsState, ctrl: jax.Array, mocap_path: jax.Array
    ) -> tuple[PhysicsState, Any]:
        """`step`, and also the data before the last substep: the end's `mjx.Data` with the
        qpos that substep started from (all that `sense` reads of it but qvel, which
        callers set)."""

        def substep(carry, mocap):
            d = self._with_mocap(carry[0], mocap)
            return (mjx.step(self.mjx_model, d), d.qpos), None

        data = self._cold(state.data, ctrl)
        (data, previous_qpos), _ = jax.lax.scan(substep, (data, data.qpos), mocap_path)
        return PhysicsState(data=data, sensordata=data.sensordata), data.replace(qpos=previous_qpos)

    @staticmethod
    def _cold(data: Any, ctrl: jax.Array) -> Any:
        # Each env step starts the solver cold, as mujoco.rollout does on the native side
        # (its state vector carries no warmstart): the two backends then agree closely.
        return data.replace(ctrl=ctrl, qacc_warmstart=jnp.zeros_like(data.qacc_warmstart))

    def _with_mocap(self, data: Any, mocap: jax.Array) -> Any:
        """One substep's mocap input: (3 * nmocap,) positions, or (7 * nmocap,) positions and
        quaternions with `mocap_quat` (MuJoCo normalises the quaternion)."""
        if not self.mocap_quat:
            return data.replace(mocap_pos=mocap.reshape(-1, 3))
        mocap = mocap.reshape(-1, 7)
        return data.replace(mocap_pos=mocap[:, :3], mocap_quat=mocap[:, 3:])

    def sense(self, data: Any, control: jax.Array) -> jax.Array:
        """(nsensordata,) the position and velocity sensors of `data`'s qpos and qvel with
        `control`'s mocap inputs (one substep's ctrl and mocap, as `NativeBackend.sense`):
        kinematics and sensors only, no collision or solver (cheap to compile). Sensors of
        the acceleration stage are left as `data` holds them."""
        data = self._with_mocap(data, control[self.model.nu :])
        data = mjx.com_pos(self.mjx_model, mjx.kinematics(self.mjx_model, data))
        data = mjx.sensor_pos(self.mjx_model, data)
        data = mjx.com_vel(self.mjx_model, data)
        return mjx.sensor_vel(self.mjx_model, data).sensordata

    def settle(self, state, mocap_pos, phases, edit):
        # One scan over both phases, the edit selected in at its substep: each mjx.step in a
        # program costs minutes of XLA compile on a CPU, so a reset holds only one.
        (ctrl_a, n_a), (ctrl_b, n_b) = phases

        def substep(d, i):
            qpos, qvel = edit(d.qpos, d.qvel)
            at_edit = i == n_a
            d = d.replace(
                qpos=jnp.where(at_edit, qpos, d.qpos),
                qvel=jnp.where(at_edit, qvel, d.qvel),
                ctrl=jnp.where(i < n_a, ctrl_a, ctrl_b),
                mocap_pos=mocap_pos.reshape(-1, 3),
            )
            return mjx.step(self.mjx_model, d), None

        data, _ = jax.lax.scan(substep, state.data, jnp.arange(n_a + n_b))
        return PhysicsState(data=data, sensordata=data.sensordata)

    def qpos(self, state: PhysicsState) -> jax.Array:
        return state.data.qpos

    def qvel(self, state: PhysicsState) -> jax.Array:
        return state.data.qvel

    def set_qpos_qvel(self, state: PhysicsState, qpos: jax.Array, qvel: jax.Array) -> PhysicsState:
        return state.replace(data=state.data.replace(qpos=qpos, qvel=qvel))


class NativeBackend:
    """Native MuJoCo through `mujoco.rollout` in a host callback.

    The callback is batch-aware (`vmap_method="broadcast_all"`): under any number of vmaps
    it receives all envs at once and hands them to rollout's thread pool. The state vector
    crosses the boundary as float32 (JAX's default dtype); rounding a position to float32
    moves it by less than a micrometre.
    """

    compiler_options: dict[str, str] | None = None
    """XLA options every program stepping this backend is compiled with (`jax.jit(...,
    compiler_options=...)`; None: XLA's defaults)."""

    name = "native"

    def __init__(self, model: mujoco.MjModel, n_threads: int = 0, mocap_quat: bool = False):
        """`mocap_quat`: each substep's mocap input is position and quaternion (7 numbers
        per mocap body) instead of the position only."""
        self.model = model
        self.control_spec = _NATIVE_CONTROL_SPEC_QUAT if mocap_quat else _NATIVE_CONTROL_SPEC
        self.n_threads = n_threads or usable_cores()
        self._datas = [mujoco.MjData(model) for _ in range(self.n_threads)]
        self._pool = rollout.Rollout(nthread=self.n_threads) if self.n_threads > 1 else None
        self._lock = threading.Lock()
        self.nstate = mujoco.mj_stateSize(model, _NATIVE_STATE_SPEC)
        self._qpos_slice = slice(1, 1 + model.nq)
        self._qvel_slice = slice(1 + model.nq, 1 + model.nq + model.nv)
        data = mujoco.MjData(model)
        self._state0 = np.empty(self.nstate)
        mujoco.mj_getState(model, data, self._state0, _NATIVE_STATE_SPEC)

    def init(self, qpos: jax.Array, qvel: jax.Array) -> PhysicsState:
        state = jnp.asarray(self._state0, jnp.float32)
        state = state.at[self._qpos_slice].set(qpos).at[self._qvel_slice].set(qvel)
        return PhysicsState(data=state, sensordata=jnp.zeros(self.model.nsensordata, jnp.float32))

    def step(self, state: PhysicsState, ctrl: jax.Array, mocap_path: jax.Array) -> PhysicsState:
        """mocap_path: (n_substeps, 3), or (n_substeps, 7) position and quaternion with
        `mocap_quat`."""
        return self._run(state.data, _controls(ctrl, mocap_path), previous=False)[0]

    def step_with_previous(
        self, state: PhysicsState, ctrl: jax.Array, mocap_path: jax.Array
    ) -> tuple[PhysicsState, jax.Array]:
        """`step`, and also the state vector before the last substep (the state whose
        kinematics MuJoCo's MjData still holds after `mj_step`)."""
        return self._run(state.data, _controls(ctrl, mocap_path), previous=True)

    def sense(self, data: jax.Array, control: jax.Array) -> jax.Array:
        """(nsensordata,) the sensors of the state vector `data` itself: one substep's rollout
        from it with `control` (one substep's ctrl and mocap inputs), of which only the
        sensors, computed before the substep integrates, are kept."""
        return self._run(data, control[None], previous=False)[0].sensordata

    def _run(self, data: jax.Array, control: jax.Array, previous: bool):
        """-> (PhysicsState after len(control) substeps, the state vector before the last
        substep if `previous` else None)."""
        n_substeps = control.shape[0]
        vector = jax.ShapeDtypeStruct(data.shape, jnp.float32)
        out_shape = (vector, jax.ShapeDtypeStruct((self.model.nsensordata,), jnp.float32))
        out = jax.pure_callback(
            lambda s, c: self._rollout_host(s, c, n_substeps, previous),
            out_shape + ((vector,) if previous else ()),
            data,
            control.astype(jnp.float32),
            vmap_method="broadcast_all",
        )
        return PhysicsState(data=out[0], sensordata=out[1]), (out[2] if previous else None)

    def _rollout_host(
        self, state: np.ndarray, control: np.ndarray, n_substeps: int, previous: bool = False
    ):
        lead = state.shape[:-1]
        state64 = np.asarray(state, np.float64).reshape(-1, self.nstate)
        control64 = np.asarray(control, np.float64).reshape(state64.shape[0], n_substeps, -1)
        with self._lock:
            if self._pool is None:
                states, sensors = rollout.rollout(
                    self.model,
                    self._datas[0],
                    state64,
                    control64,
                    control_spec=self.control_spec,
                    nstep=n_substeps,
                )
            else:
                states, sensors = self._pool.rollout(
                    self.model,
                    self._datas,
                    state64,
                    control64,
                    control_spec=self.control_spec,
                    nstep=n_substeps,
                )
        new_state = states[:, -1].astype(np.float32).reshape(*lead, self.nstate)
        sensordata = sensors[:, -1].astype(np.float32).reshape(*lead, -1)
        if not previous:
            return new_state, sensordata
        before = state64 if n_substeps == 1 else states[:, -2]
        return new_state, sensordata, before.astype(np.float32).reshape(*lead, self.nstate)

    def settle(self, state, mocap_pos, phases, edit):
        (ctrl_a, n_a), (ctrl_b, n_b) = phases
        state = self.step(state, ctrl_a, jnp.broadcast_to(mocap_pos, (n_a, 3)))
        state = self.set_qpos_qvel(state, *edit(self.qpos(state), self.qvel(state)))
        return self.step(state, ctrl_b, jnp.broadcast_to(mocap_pos, (n_b, 3)))

    def qpos(self, state: PhysicsState) -> jax.Array:
        return state.data[..., self._qpos_slice]

    def qvel(self, state: PhysicsState) -> jax.Array:
        return state.data[..., self._qvel_slice]

    def set_qpos_qvel(self, state: PhysicsState, qpos: jax.Array, qvel: jax.Array) -> PhysicsState:
        data = state.data.at[..., self._qpos_slice].set(qpos).at[..., self._qvel_slice].set(qvel)
        return state.replace(data=data)


def _controls(ctrl: jax.Array, mocap_path: jax.Array) -> jax.Array:
    """(n_substeps, ncontrol): ctrl held over the substeps, then each substep's mocap input."""
    n_substeps = mocap_path.shape[0]
    ctrl = jnp.broadcast_to(ctrl, (n_substeps, ctrl.shape[-1]))
    return jnp.concatenate([ctrl, mocap_path.reshape(n_substeps, -1)], axis=-1)


def make_backend(model: mujoco.MjModel, physics: str, n_threads: int = 0) -> PhysicsBackend:
    """`physics`: 'native', 'mjx', or 'auto' (native on a CPU, mjx on a GPU/TPU)."""
    if physics not in PHYSICS:
        raise ValueError(f"unknown physics backend {physics!r}; valid: {', '.join(PHYSICS)}")
    if physics == "auto":
        physics = "native" if jax.default_backend() == "cpu" else "mjx"
    if physics == "mjx":
        return MjxBackend(model)
    return NativeBackend(model, n_threads)
