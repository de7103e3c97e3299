"""What the MJX path of the Fetch tasks changes, against the native backend on the unedited
model (the backend `tests/envs/test_fetch.py` holds to gymnasium-robotics' own env):

- `edits`: native MuJoCo on the MJX-edited model (`envs.fetch_mjx.MJX_EDITS`) against the
  reference: the edits' effect alone;
- `mjx`: MJX on the edited model against the reference: the edits and MJX together;
- `mjx_vs_edits`: MJX against native on the same edited model: MJX alone;
- `setup`: how far the setup (10 env steps, host float64) on the edited model ends from
  the reference's (the MJX env's own start): the largest |qpos| difference.

All three rollouts of a task start from the same state (the reference's setup, with its
`reset` draws of object and goal) and take the same uniform random actions
(`envs.fetch_mjx.lockstep`); a deviation is the largest over every step and env
(`envs.fetch_mjx.deviations`: positions m, velocities m/s or rad/s, the object's
orientation rad, qpos entries).

    python benchmarks/fetch_mjx_parity.py [--tasks fetch_reach ...] [--envs 2] [--steps 50]
        [--no-mjx]

Prints one JSON row per task (benchmarks/results/fetch_mjx_parity.jsonl). MJX compiles for
minutes on a CPU: a row costs one MJX compile.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
import warnings

import jax
import mujoco
import numpy as np

from mjx_skills.core import compile_cache
from mjx_skills.envs import make
from mjx_skills.envs.fetch_mjx import (
    MJX_EDITS,
    ROBOT_PREFIX,
    deviations,
    edit_for_mjx,
    lockstep,
    with_start,
)
from mjx_skills.envs.physics import NativeBackend

TASKS = ("fetch_reach", "fetch_push", "fetch_pick_and_place")
"""The Fetch tasks MJX runs (Slide: `fetch_mjx.MJX_REFUSALS`)."""


def native_on_edited_model(env):
    """A copy of the native env `env` stepping the MJX-edited model natively (its setup, as
    the reference's, unchanged: the start is set by the caller)."""
    backend = NativeBackend(edit_for_mjx(env.model), mocap_quat=True)
    env = with_start(env, env.robot.start_qpos, env.robot.start_qvel)
    env.backend = env.robot.backend = backend
    env.model = env.robot.model = backend.model
    return env


def robot_self_contacts(model: mujoco.MjModel, qpos: np.ndarray) -> int:
    """Robot-robot contacts (`fetch_mjx.ROBOT_PREFIX` bodies) of `model` over the states
    qpos (..., nq), each after `mj_forward`: what the self-collision edit removes."""
    robot = np.array([model.body(b).name.startswith(ROBOT_PREFIX) for b in model.geom_bodyid])
    data, count = mujoco.MjData(model), 0
    for q in qpos.reshape(-1, model.nq):
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        count += sum(bool(robot[c.geom].all()) for c in data.contact[: data.ncon])
    return count


def measure(task: str, n_envs: int, n_steps: int, seed: int, with_mjx: bool = True) -> dict:
    """One row; `with_mjx=False`: the native rollouts only (the edits' effect; no MJX
    compile), its MJX entries null."""
    reference = make(task, physics="native")
    on_mjx = make(task, physics="mjx")  # put_model and the setup only: nothing compiled yet
    setup = float(np.abs(on_mjx.robot.start_qpos - reference.robot.start_qpos).max())
    start = (reference.robot.start_qpos, reference.robot.start_qvel)
    envs = {"reference": reference, "edits": native_on_edited_model(reference)}
    if with_mjx:
        envs["mjx"] = with_start(on_mjx, *start)
    t0 = time.perf_counter()
    runs = lockstep(envs, jax.random.PRNGKey(seed), n_envs, n_steps)
    seconds = time.perf_counter() - t0
    ref = runs["reference"]
    goal_part = reference.layout["object" if reference.goal_is_object else "grip"]
    moved = np.linalg.norm(ref["obs"][-1][:, goal_part] - ref["obs"][0][:, goal_part], axis=-1)
    return {
        "task": task,
        "envs": n_envs,
        "steps": n_steps,
        "seed": seed,
        "edits": deviations(ref, runs["edits"], reference),
        "mjx": deviations(ref, runs["mjx"], reference) if with_mjx else None,
        "mjx_vs_edits": deviations(runs["edits"], runs["mjx"], reference) if with_mjx else None,
        "setup": {"joints": setup},
        "physics_resets": {name: run["resets"] for name, run in runs.items()},
        "moved_max_m": float(moved.max()),
        "reference_robot_self_contacts": robot_self_contacts(reference.model, ref["qpos"]),
        "model_edits": [edit.name for edit in MJX_EDITS],
        "seconds_with_compile": round(seconds, 1),
        "device": jax.default_backend(),
        "mujoco": mujoco.__version__,
        "machine": platform.machine(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS)
    parser.add_argument("--envs", type=int, default=2)
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-mjx", action="store_true", help="native rollouts only")
    args = parser.parse_args()
    compile_cache.enable()
    warnings.filterwarnings("ignore", message="Mesh .* coplanar face")
    for task in args.tasks:
        row = measure(task, args.envs, args.steps, args.seed, not args.no_mjx)
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
