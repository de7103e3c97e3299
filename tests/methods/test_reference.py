"""DDPG+HER through the generic trainer gives bitwise the metrics the DDPG-only trainer gave.

tests/data/ddpg_her_reference.json was recorded with the trainer before the method registry
(the commit is in the file) on a CPU; the refactor had to keep every random key, every
reduction and every update in the same order.
"""

import json
from pathlib import Path

import jax
import numpy as np
import pytest

from mjx_skills.config import EnvConfig, TrainConfig
from mjx_skills.training.epoch import build, host_metrics

REFERENCE = Path(__file__).resolve().parents[1] / "data" / "ddpg_her_reference.json"


@pytest.mark.skipif(
    jax.default_backend() != "cpu", reason="the reference holds CPU bits (native physics)"
)
def test_ddpg_her_metrics_equal_the_recorded_reference():
    ref = json.loads(REFERENCE.read_text())
    cfg = dict(ref["config"])
    physics, epochs = cfg.pop("physics"), cfg.pop("epochs")
    _, _, epoch_fn, carry = build(
        "ddpg_her", TrainConfig(**cfg, progress=False), EnvConfig(physics=physics)
    )
    for epoch in range(epochs):
        carry, metrics = epoch_fn(carry, None)
        for name, want in ref["metrics_per_epoch"][epoch].items():
            got = host_metrics(metrics)[name]  # counters as their values
            np.testing.assert_array_equal(got, np.asarray(want, np.float32), err_msg=name)
