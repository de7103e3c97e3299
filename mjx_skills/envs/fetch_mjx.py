"""The Fetch tasks on MJX: the model edits MJX needs, which scenes it cannot take, and the
backend a `FetchRobot` steps with.

`mujoco.mjx.put_model` (mujoco-mjx 4.0, JAX implementation) refuses gymnasium-robotics'
Fetch model as shipped: it implements no contact margin for a geom pair that has a mesh in
it, and 17 of the model's geoms (15 robot meshes and the two finger boxes, which pair with
meshes) have margin 0.001. `MJX_EDITS` lists every edit the MJX path makes, each with its
reason; the native path makes none of them (it steps gymnasium-robotics' model as
`envs.fetch.load_model` builds it). What the edits and MJX together change is measured
against the native backend on the unedited model by `benchmarks/fetch_mjx_parity.py`
(`benchmarks/results/fetch_mjx_parity.jsonl`) and bounded by `tests/envs/test_fetch_mjx.py`.

A scene MJX cannot run even with the edits is in `MJX_REFUSALS` with MJX's own reason: Slide,
whose puck is a cylinder, and MJX has no cylinder-mesh collision. The other three run on MJX
when asked (physics='mjx'); 'auto' is native everywhere until a device measures the path.
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Callable
from typing import NamedTuple

import jax
import mujoco
import numpy as np

from mjx_skills.envs.physics import MjxBackend, NativeBackend


class ModelEdit(NamedTuple):
    """One change the MJX path makes to the model: `name`, `what` it changes, `why` MJX
    needs it, and `apply(model) -> number of elements changed` (in place)."""

    name: str
    what: str
    why: str
    apply: Callable[[mujoco.MjModel], int]


def _zero_mesh_pair_margins(model: mujoco.MjModel) -> int:
    """Margin 0 on every geom with a margin (Fetch: 17 geoms, all 0.001 m -> 0)."""
    edited = np.flatnonzero(model.geom_margin != 0)
    model.geom_margin[edited] = 0.0
    return int(edited.size)


def _exclude_robot_self_collisions(model: mujoco.MjModel) -> int:
    """Colliding robot geoms contype 2, conaffinity 1; every other colliding geom contype 1,
    conaffinity 3: robot-robot pairs no longer collide, all others as before (Fetch's
    colliding geoms are all contype 1, conaffinity 1; ValueError otherwise)."""
    colliding = (model.geom_contype | model.geom_conaffinity) != 0
    if np.any(model.geom_contype[colliding] != 1) or np.any(model.geom_conaffinity[colliding] != 1):
        raise ValueError("expected every colliding geom at contype 1, conaffinity 1")
    robot = np.array([model.body(b).name.startswith(ROBOT_PREFIX) for b in model.geom_bodyid])
    model.geom_contype[colliding & robot], model.geom_conaffinity[colliding & robot] = 2, 1
    model.geom_contype[colliding & ~robot], model.geom_conaffinity[colliding & ~robot] = 1, 3
    return int(np.sum(colliding & robot))


ROBOT_PREFIX = "robot0:"
"""The robot's bodies' names start with it."""

MJX_EDITS: tuple[ModelEdit, ...] = (
    ModelEdit(
        name="zero_geom_margin",
        what=(
            "geom_margin 0.001 m -> 0 on the 17 geoms that have one (the robot's 15 "
            "meshes and its two finger boxes): their contacts become active at touch "
            "instead of 1 mm before it; no other geom has a margin"
        ),
        why=(
            "mjx.put_model: '(PLANE, MESH) margin/gap not implemented' and '(BOX, MESH) "
            "margin/gap not implemented' (MJX has no margin for a pair with a mesh; the "
            "finger boxes pair with the arm's meshes)"
        ),
        apply=_zero_mesh_pair_margins,
    ),
    ModelEdit(
        name="exclude_robot_self_collisions",
        what=(
            "the robot's 17 colliding geoms no longer collide with each other (contype / "
            "conaffinity bits: robot 2/1, the rest 1/3); robot-world, robot-object and "
            "world-object pairs collide as before"
        ),
        why=(
            "MJX's mesh-mesh pairs of the arm against itself (convex hulls of hundreds "
            "of vertices) make XLA's compile of mjx.step exhaust a CPU machine's memory "
            "(killed by the OOM killer); without them a bare mjx.step compiles. The native reference's "
            "robot-robot contacts: benchmarks/fetch_mjx_parity.py counts them"
        ),
        apply=_exclude_robot_self_collisions,
    ),
)
"""Every edit of the MJX path, in the order applied; the native path applies none."""

MJX_REFUSALS: dict[str, str] = {
    "slide": (
        "mujoco.mjx.put_model refuses the Slide scene even with the MJX edits "
        "('(CYLINDER, MESH) collisions not implemented': the puck is a cylinder "
        "and mujoco-mjx's JAX implementation has no cylinder-mesh collision with the arm's "
        "meshes); use physics='native'"
    ),
}
"""Scene -> why MJX cannot run it (checked by tests/envs/test_fetch_mjx.py against put_model)."""


def edit_for_mjx(model: mujoco.MjModel, edits: tuple[ModelEdit, ...] = MJX_EDITS) -> mujoco.MjModel:
    """A copy of `model` with `edits` (default: every edit of the MJX path) applied; the
    argument is left untouched."""
    edited = copy.copy(model)  # MjModel's copy is a deep copy
    for edit in edits:
        edit.apply(edited)
    return edited


def resolve_physics(scene: str, physics: str, device: str | None = None) -> str:
    """`physics` ('native', 'mjx' or 'auto') resolved for `scene`: 'auto' is native on every
    device (`device`, unused until the MJX path is measured on one); ValueError for 'mjx' in
    a scene MJX cannot load, with MJX's reason (`MJX_REFUSALS`)."""
    del device
    if physics == "mjx" and scene in MJX_REFUSALS:
        raise ValueError(MJX_REFUSALS[scene])
    return "native" if physics == "auto" else physics


MJX_COMPILER_OPTIONS = {
    "xla_disable_hlo_passes": "while-loop-invariant-code-motion,simplify-while-loops"
}
"""XLA options of every program that steps the Fetch model on MJX: two of XLA's passes over
while loops are disabled, each of which blew a compile of the edited model past the memory
of a 24 GB CPU machine. With while-loop invariant code motion, a `lax.scan` of two
`mjx.step`s grew past 9 GB (a bare step: under 1.5 GB). With the while-loop simplifier, an
episode (a scan of 50 env steps of 20 substeps) peaked at 6.2 GB and a training epoch passed
9 GB; without it they peak at 2.4 GB and 4.9 GB, and the episode runs as fast (2 envs x 50
steps: 78 s with it, 77 s without, on the 2-core CPU). Measured by hand with an RSS watchdog
(py-spy showed the growth inside `WhileLoopSimplifier::Run`); only the Fetch MJX programs get
these options, so Baxter's are unchanged."""


def fetch_backend(
    model: mujoco.MjModel, physics: str, n_threads: int = 0
) -> MjxBackend | NativeBackend:
    """The backend a FetchRobot steps `model` with, mocap quaternion as an input: native on
    the model as it is, or MJX on `edit_for_mjx(model)` (`physics` resolved: 'native' or
    'mjx'). The backend's `model` is the model it steps."""
    if physics == "mjx":
        with warnings.catch_warnings():
            # put_model warns of every arm mesh with a coplanar face of more than 20 vertices
            # (15 warnings): gymnasium-robotics' meshes, which the MJX path keeps as shipped.
            warnings.filterwarnings("ignore", "Mesh .* has a coplanar face", UserWarning)
            backend = MjxBackend(edit_for_mjx(model), mocap_quat=True)
        backend.compiler_options = MJX_COMPILER_OPTIONS
        return backend
    return NativeBackend(model, n_threads, mocap_quat=True)


# ---------------------------------------------------------------- measuring the MJX path
def with_start(env, start_qpos: np.ndarray, start_qvel: np.ndarray):
    """A shallow copy of a Fetch task `env` whose resets return to the setup state
    (start_qpos (nq,), start_qvel (nv,)) given instead of its own: to start two envs (say
    native and MJX, whose setups ran on different models) from the same state."""
    env, robot = copy.copy(env), copy.copy(env.robot)
    robot.start_qpos, robot.start_qvel = np.array(start_qpos), np.array(start_qvel)
    env.robot = robot
    return env


def lockstep(envs: dict, key: jax.Array, n_envs: int, n_steps: int) -> dict[str, dict]:
    """Every env of `envs` (name -> Fetch task of one scene) run from the same starts with
    the same actions, in one jitted program: the starts are the first env's `reset` draws
    (object position and goal), the actions uniform in [-1, 1]^4, both from `key`.
    -> name -> {'obs': (n_steps + 1, n_envs, obs_dim), 'qpos': (n_steps + 1, n_envs, nq),
    'resets': the physics resets counted} as numpy arrays (float32)."""
    first = next(iter(envs.values()))
    k_start, k_act = jax.random.split(key)
    actions = jax.random.uniform(k_act, (n_steps, n_envs, first.action_dim), minval=-1.0)

    def run(k_start, actions):
        drawn = jax.vmap(first.reset)(jax.random.split(k_start, n_envs))
        obj = None
        if first.goal_is_object:
            adr = first.robot.object_qpos
            obj = first.backend.qpos(drawn.physics)[:, adr : adr + 2]
        states = {
            name: jax.vmap(env.start_state)(obj, drawn.desired_goal) for name, env in envs.items()
        }

        def record(states):
            return {
                name: (s.obs, envs[name].backend.qpos(s.physics), s.metrics["physics_resets"])
                for name, s in states.items()
            }

        def body(states, action):
            states = {n: jax.vmap(envs[n].step)(s, action) for n, s in states.items()}
            return states, record(states)

        _, traj = jax.lax.scan(body, states, actions)
        return record(states), traj

    options = {}
    for env in envs.values():
        options.update(env.backend.compiler_options or {})
    start, traj = jax.jit(run, compiler_options=options or None)(k_start, actions)
    out = {}
    for name in envs:
        obs, qpos, resets = (
            np.concatenate([np.asarray(a)[None], np.asarray(b)])
            for a, b in zip(start[name], traj[name], strict=True)
        )
        out[name] = {"obs": obs, "qpos": qpos, "resets": float(resets[-1].sum())}
    return out


def deviations(ref: dict, other: dict, env) -> dict[str, float]:
    """The largest deviation of `other` from `ref` (two `lockstep` trajectories of `env`'s
    scene) over every step and env: 'position' (m: the observation's grip, object, object -
    grip and finger parts), 'velocity' (m/s or rad/s: its velocity parts divided by dt),
    'angle' (rad: the object's orientation, from its free joint's quaternion; 0 without an
    object) and 'joints' (every qpos entry: m or rad)."""
    layout = env.layout
    positions = [
        layout[p] for p in ("grip", "object", "rel", "fingers") if layout[p].stop > layout[p].start
    ]
    velocities = slice(layout["fingers"].stop + (3 if env.goal_is_object else 0), layout.size)
    diff = np.abs(ref["obs"] - other["obs"])
    out = {
        "position": float(max(diff[..., s].max() for s in positions)),
        "velocity": float(diff[..., velocities].max() / env.dt),
        "angle": 0.0,
        "joints": float(np.abs(ref["qpos"] - other["qpos"]).max()),
    }
    if env.goal_is_object:
        adr = env.robot.object_qpos + 3
        q1, q2 = (np.asarray(x["qpos"][..., adr : adr + 4], np.float64) for x in (ref, other))
        q1, q2 = (q / np.linalg.norm(q, axis=-1, keepdims=True) for q in (q1, q2))
        q2 *= np.where(np.sum(q1 * q2, -1) < 0, -1.0, 1.0)[..., None]  # q and -q: one turn
        # The rotation between them turns by 4 arcsin(|q1 - q2| / 2): exact near 0 too.
        chord = np.linalg.norm(q1 - q2, axis=-1)
        out["angle"] = float((4.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0))).max())
    return out
