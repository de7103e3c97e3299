"""Where MJX spends a physics step on this machine: each pipeline stage jitted and timed
alone, vmapped over a batch of pick_move states (from the env's own resets).

    python benchmarks/mjx_profile.py [--batch 256] [--task pick_move]

Prints one JSON row per stage (ms per batched call and share of mjx.step) and a last line
with all of them.
"""

from __future__ import annotations

import argparse
import json
import time

import jax
import mujoco
import numpy as np
from mujoco import mjx

from mjx_skills.core import compile_cache
from mjx_skills.envs import make


def batched_data(env, batch: int) -> mjx.Data:
    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), batch))
    model, data = env.model, mujoco.MjData(env.model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    frames = []
    for state in np.asarray(states.physics.data, np.float64):
        mujoco.mj_setState(model, data, state, spec)
        data.mocap_pos[0] = data.site("grip").xpos
        mujoco.mj_forward(model, data)
        frames.append(mjx.put_data(model, data))
    return jax.tree.map(lambda *x: jax.numpy.stack(x), *frames)


def time_ms(fn, *args, repeats: int = 5) -> float:
    jax.block_until_ready(fn(*args))
    t0 = time.perf_counter()
    for _ in range(repeats):
        jax.block_until_ready(fn(*args))
    return (time.perf_counter() - t0) / repeats * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--task", default="pick_move")
    parser.add_argument("--batch", type=int, default=256)
    parser.add_argument("--iterations", type=int, default=None, help="solver iterations")
    parser.add_argument("--ls-iterations", type=int, default=None)
    args = parser.parse_args()
    compile_cache.enable()
    overrides = {
        k: v
        for k, v in (("solver_iterations", args.iterations), ("ls_iterations", args.ls_iterations))
        if v is not None
    }
    env = make(args.task, physics="native", **overrides)
    m = mjx.put_model(env.model)
    d = batched_data(env, args.batch)
    d_pos = jax.jit(jax.vmap(lambda d: mjx.fwd_position(m, d)))(d)
    d_fwd = jax.jit(
        jax.vmap(lambda d: mjx.fwd_acceleration(m, mjx.fwd_actuation(m, mjx.fwd_velocity(m, d))))
    )(d_pos)
    stages = {
        "step": (lambda d: mjx.step(m, d), d),
        "fwd_position (kinematics, inertia, collision, constraints)": (
            lambda d: mjx.fwd_position(m, d),
            d,
        ),
        "collision": (lambda d: mjx.collision(m, d), d),
        "make_constraint": (lambda d: mjx.make_constraint(m, d), d),
        "fwd_velocity + actuation + acceleration": (
            lambda d: mjx.fwd_acceleration(m, mjx.fwd_actuation(m, mjx.fwd_velocity(m, d))),
            d_pos,
        ),
        "solve (constraint solver)": (lambda d: mjx.solve(m, d), d_fwd),
        "sensors (pos + vel)": (lambda d: mjx.sensor_vel(m, mjx.sensor_pos(m, d)), d_fwd),
    }
    times = {}
    for name, (fn, data) in stages.items():
        times[name] = time_ms(jax.jit(jax.vmap(fn)), data)
        row = {
            "stage": name,
            "batch": args.batch,
            "ms": round(times[name], 2),
            "share_of_step": round(times[name] / times["step"], 3),
        }
        print(json.dumps(row), flush=True)
    print(
        json.dumps(
            {
                "task": args.task,
                "batch": args.batch,
                **overrides,
                "physics_steps_per_s": round(args.batch / times["step"] * 1e3),
                **{k: round(v, 2) for k, v in times.items()},
            }
        )
    )


if __name__ == "__main__":
    main()
