"""Env steps per second of `vmap(env.step)` inside a jitted scan, on both physics backends,
against plain native MuJoCo (C, one thread, no JAX) stepping the same scene.

    python benchmarks/physics.py [--task pick_move] [--batches 16 256 1024] [--mjx-steps 5]
    python benchmarks/physics.py --task fetch_push --batches 1 16 256

Prints one JSON row per (backend, batch); the last line is the batch-256 summary with the
ratios over the plain one-thread figure. A Fetch task (native only: MJX refuses its model)
is timed against gymnasium-robotics' own env instead, one env in a Python loop of
`env.step()` (built through `mjx_skills.envs.fetch_reference`), in the same run: the
ratio is ours over theirs. Results: benchmarks/results/physics.jsonl (Baxter) and
benchmarks/results/physics_fetch.jsonl; `benchmarks/speed_report.py` makes docs of both.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Callable

import jax
import mujoco
import numpy as np
from mujoco import rollout

from mjx_skills.core import compile_cache
from mjx_skills.envs import FETCH, make
from mjx_skills.envs.fetch import N_SUBSTEPS


def scan_timer(env, batch: int, n_steps: int) -> tuple[Callable[[], float], float]:
    """-> (a function that runs a scan of n_steps random actions and returns env steps per
    second, compile seconds); compiled and run once (warm-up) before it returns."""
    key = jax.random.PRNGKey(0)
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(key, batch))
    actions = jax.random.uniform(key, (n_steps, batch, 4), minval=-1.0, maxval=1.0)

    @jax.jit
    def run(state, actions):
        def body(s, a):
            s = jax.vmap(env.step)(s, a)
            return s, s.obs[:, 0]

        return jax.lax.scan(body, state, actions)

    t0 = time.perf_counter()
    compiled = run.lower(state, actions).compile()
    compile_s = time.perf_counter() - t0
    jax.block_until_ready(compiled(state, actions))  # warm-up

    def timed() -> float:
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(state, actions))
        return batch * n_steps / (time.perf_counter() - t0)

    return timed, compile_s


def env_steps_per_s(env, batch: int, n_steps: int) -> tuple[float, float]:
    """-> (env steps per second, compile seconds) for a scan of n_steps random actions."""
    timed, compile_s = scan_timer(env, batch, n_steps)
    return timed(), compile_s


def raw_native_env_steps_per_s(env, batch: int, n_steps: int) -> float:
    """Plain MuJoCo: rollout's C loop on one thread, the same substeps per env step, from
    the env's own reset states, the mocap target wandering by up to 5 cm per step."""
    model = env.model
    starts = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(1), batch))
    initial = np.asarray(starts.physics.data, np.float64)
    grip = np.asarray(starts.obs[:, :3], np.float64)
    n_sub = env.config.n_substeps
    rng = np.random.default_rng(0)
    wander = np.cumsum(rng.uniform(-0.05, 0.05, (batch, n_steps, 3)), axis=1)
    mocap = np.repeat(grip[:, None] + wander, n_sub, axis=1)
    fingers = np.repeat(rng.uniform(-0.02, 0.02, (batch, n_steps, 1)), n_sub, axis=1)
    control = np.concatenate([fingers, fingers, mocap], axis=-1)
    control_spec = mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_MOCAP_POS
    data = mujoco.MjData(model)
    t0 = time.perf_counter()
    rollout.rollout(model, data, initial, control, control_spec=control_spec)
    return batch * n_steps / (time.perf_counter() - t0)


def reference_timer(task: str, n_steps: int, episode: int = 50) -> Callable[[], float]:
    """gymnasium-robotics' own env of `task`, one env: a function that runs n_steps of its
    `env.step()` with uniform random actions, reset every `episode` steps (resets untimed),
    and returns env steps per second."""
    from mjx_skills.envs.fetch_reference import reference_env

    env = reference_env(task)
    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (n_steps, 4)).astype(np.float32)

    def timed() -> float:
        elapsed = 0.0
        for start in range(0, n_steps, episode):
            env.reset(seed=start)
            t0 = time.perf_counter()
            for action in actions[start : start + episode]:
                env.step(action)
            elapsed += time.perf_counter() - t0
        return n_steps / elapsed

    return timed


def fetch_rows(
    task: str, batches: list[int], n_steps: int, reference_steps: int, repeats: int
) -> list[dict]:
    """One row per batch: our native-in-jit env against gymnasium-robotics' step loop (one
    env: the same rate at any batch, one env after another). The two are timed in turn,
    `repeats` times, so that both see the same load on a shared machine; each rate is the
    median of its timings, the ratio the median of the pairs' ratios (`load_1min`: the
    1-minute load average before the batch's timings)."""
    import gymnasium_robotics

    env = make(task, physics="native")
    theirs_timer = reference_timer(task, reference_steps)
    rows = []
    for batch in batches:
        load = os.getloadavg()[0]
        ours_timer, compile_s = scan_timer(env, batch, n_steps)
        pairs = np.array([(theirs_timer(), ours_timer()) for _ in range(repeats)])
        theirs, ours = np.median(pairs, axis=0)
        ratios = pairs[:, 1] / pairs[:, 0]
        rows.append(
            {
                "task": task,
                "batch": batch,
                "cores": os.cpu_count(),
                "device": jax.default_backend(),
                "substeps": N_SUBSTEPS,
                "reference": f"gymnasium-robotics {gymnasium_robotics.__version__} env.step()",
                "repeats": repeats,
                "reference_env_steps_per_s": round(float(theirs), 1),
                "reference_physics_steps_per_s": round(float(theirs) * N_SUBSTEPS, 1),
                "native_jit_env_steps_per_s": round(float(ours), 1),
                "native_jit_physics_steps_per_s": round(float(ours) * N_SUBSTEPS, 1),
                "ratio_native_jit_vs_reference": round(float(np.median(ratios)), 3),
                "ratio_min": round(float(ratios.min()), 3),
                "ratio_max": round(float(ratios.max()), 3),
                "native_compile_s": round(compile_s, 1),
                "load_1min": round(load, 2),
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--task", default="pick_move")
    parser.add_argument("--batches", type=int, nargs="+", default=[16, 256, 1024])
    parser.add_argument("--native-steps", type=int, default=50)
    parser.add_argument("--mjx-steps", type=int, default=5)
    parser.add_argument("--skip-mjx", action="store_true")
    parser.add_argument(
        "--reference-steps", type=int, default=500, help="Fetch: gymnasium-robotics' steps"
    )
    parser.add_argument("--repeats", type=int, default=5, help="Fetch: timings of each side")
    args = parser.parse_args()
    compile_cache.enable()
    if args.task in FETCH:
        fetch_rows(args.task, args.batches, args.native_steps, args.reference_steps, args.repeats)
        return
    cores = os.cpu_count()
    native_env = make(args.task, physics="native")
    mjx_env = None if args.skip_mjx else make(args.task, physics="mjx")
    rows = {}
    for batch in args.batches:
        raw = raw_native_env_steps_per_s(native_env, batch, args.native_steps)
        native, native_compile = env_steps_per_s(native_env, batch, args.native_steps)
        row = {
            "task": args.task,
            "batch": batch,
            "cores": cores,
            "device": jax.default_backend(),
            "native_raw_env_steps_per_s": round(raw, 1),
            "native_jit_env_steps_per_s": round(native, 1),
            "ratio_native_jit": round(native / raw, 3),
            "native_compile_s": round(native_compile, 1),
        }
        if mjx_env is not None:
            mjx_sps, mjx_compile = env_steps_per_s(mjx_env, batch, args.mjx_steps)
            row.update(
                mjx_env_steps_per_s=round(mjx_sps, 1),
                ratio_mjx=round(mjx_sps / raw, 4),
                mjx_compile_s=round(mjx_compile, 1),
            )
        rows[batch] = row
        print(json.dumps(row), flush=True)
    summary = rows.get(256, rows[args.batches[-1]])
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
