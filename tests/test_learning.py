"""Learning: DDPG+HER trains the transit skill to >= 90 % eval success (slow; runs in CI)."""

import numpy as np
import pytest

from mjx_skills.config import TrainConfig
from mjx_skills.logging import read_metrics
from mjx_skills.runner import RunArgs, train_run


@pytest.mark.slow
def test_transit_learns(tmp_path):
    cfg = TrainConfig(task="transit", epochs=20, seeds=2, replay_capacity=100_000,
                      checkpoint_every=20, out=str(tmp_path), progress=False)  # fmt: skip
    rows = read_metrics(train_run(RunArgs(train=cfg)))
    # Evaluation with the frozen policy (20 episodes per epoch), last 3 epochs, per seed.
    last = [
        np.mean([r["eval_success"] for r in rows if r["seed"] == s and r["epoch"] > 17])
        for s in range(2)
    ]
    assert np.mean(last) >= 0.9, f"transit eval success over the last 3 epochs, per seed: {last}"
