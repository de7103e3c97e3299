"""Values that grow or come from outside: counters past 2**31, seeds at the 32-bit limit,
64-bit JAX in the shell."""

import dataclasses
import json
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mjx_skills.cli_args import run_parser
from mjx_skills.config import SEED_LIMIT, EnvConfig, TrainConfig
from mjx_skills.training.epoch import (
    COUNT_BASE,
    Counters,
    build,
    committed,
    count_add,
    count_values,
    host_metrics,
    seed_keys,
)
from mjx_skills.training.metrics_log import MetricsWriter, read_metrics
from mjx_skills.training.runner import RunArgs, train_run


@settings(max_examples=30, deadline=None)
@given(
    start=st.integers(0, 2**60),
    steps=st.lists(st.integers(0, COUNT_BASE - 1), min_size=1, max_size=20),
)
def test_a_counter_adds_exactly_past_int32(start, steps):
    count = jnp.array([start // COUNT_BASE, start % COUNT_BASE], jnp.int32)
    added = jax.lax.scan(lambda c, n: (count_add(c, n), None), count, jnp.array(steps))[0]
    assert int(count_values(added)) == start + sum(steps)


def test_a_run_past_2_31_env_steps_logs_them(tmp_path, tiny_train):
    """Row 4: started near the int32 limit, an epoch's counters go past it and are logged
    as positive integers (they wrapped to -2147483638 before)."""
    cfg = TrainConfig(**tiny_train)
    env, _, epoch_fn, carry = build("ddpg_her", cfg, EnvConfig())
    start = 2**31 - 10

    def near(value):
        return jnp.array([[value // COUNT_BASE, value % COUNT_BASE]], jnp.int32)

    # committed, as `build`'s carry: another placement would compile the epoch again
    carry = committed(carry.replace(counters=Counters(near(start), near(start), near(0))))
    _, metrics = epoch_fn(carry, None)
    metrics = host_metrics(metrics)
    per_epoch = cfg.envs * cfg.cycles
    assert metrics["env_steps"][0] == start + per_epoch * env.episode_length > 2**31
    assert metrics["episodes"][0] == start + per_epoch
    writer = MetricsWriter(tmp_path)
    writer.write(1, metrics, wall_s=0.0)
    writer.close()
    assert read_metrics(tmp_path)[0]["env_steps"] == start + per_epoch * env.episode_length


def test_seeds_past_32_bits_are_refused():
    """Row 7: seed 2**32 is seed 0's stream; seed 2**32 - 1 with 3 seeds shares one."""
    for seed, seeds in ((SEED_LIMIT, 1), (SEED_LIMIT - 1, 3), (2**40, 1)):
        with pytest.raises(ValueError, match="'seed'"):
            TrainConfig(seed=seed, seeds=seeds)
    with pytest.raises(ValueError, match="'seeds': must be < 2"):
        TrainConfig(seed=0, seeds=10**12)  # the field at fault is named
    last = TrainConfig(seed=SEED_LIMIT - 3, seeds=3)
    assert len({tuple(np.asarray(k)) for k in seed_keys(last)}) == 3
    parser = run_parser("evaluate", None, episodes=1)
    assert parser.parse_args(["run", "--seed", str(SEED_LIMIT - 1)]).seed == SEED_LIMIT - 1
    for bad in (SEED_LIMIT, -1):
        with pytest.raises(SystemExit):
            parser.parse_args(["run", "--seed", str(bad)])


@settings(max_examples=50, deadline=None)
@given(a=st.integers(0, SEED_LIMIT - 1), b=st.integers(0, SEED_LIMIT - 1))
def test_distinct_accepted_seeds_are_distinct_streams(a, b):
    keys = [np.asarray(jax.random.PRNGKey(s)) for s in (a, b)]
    assert (a == b) == bool(np.array_equal(*keys))


def test_x64_is_refused_by_the_api_before_anything_is_written(tmp_path, tiny_train):
    jax.config.update("jax_enable_x64", True)
    try:
        with pytest.raises(ValueError, match="float32"):
            train_run(RunArgs(train=TrainConfig(**tiny_train, epochs=1, out=str(tmp_path))))
    finally:
        jax.config.update("jax_enable_x64", False)
    assert not list(tmp_path.iterdir())


def test_the_cli_under_jax_enable_x64_trains_the_float32_run(tmp_path, tiny_train):
    """Row 3: JAX_ENABLE_X64=1 in the shell trains exactly the float32 run (it changed the
    critic loss, 0.590 against 0.535, and broke resuming)."""
    reference = train_run(
        RunArgs(train=TrainConfig(**tiny_train, epochs=1, out=str(tmp_path / "a")))
    )
    argv = [
        "ddpg_her",
        "--task",
        "transit",
        "--epochs",
        "1",
        "--envs",
        "2",
        "--cycles",
        "2",
        "--updates-per-cycle",
        "5",
        "--eval-episodes",
        "2",
        "--replay-capacity",
        "2000",
        "--no-progress",
        "--out",
        str(tmp_path / "b"),
    ]
    env = {**os.environ, "JAX_ENABLE_X64": "1"}
    done = subprocess.run(
        [sys.executable, "-m", "mjx_skills.train", *argv], env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    assert "JAX_ENABLE_X64 is set" in done.stderr
    (run,) = (tmp_path / "b").glob("transit/ddpg_her/*")
    strip = lambda rows: [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]  # noqa: E731
    assert strip(read_metrics(run)) == strip(read_metrics(reference))
    config = json.loads((run / "config.json").read_text())
    assert config["train"] == {
        **dataclasses.asdict(TrainConfig(**tiny_train, epochs=1)),
        "out": str(tmp_path / "b"),
    }
