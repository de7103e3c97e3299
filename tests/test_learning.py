"""Learning: DDPG+HER trains the transit skill to >= 90 % eval success (slow; runs in CI)."""

import numpy as np
import pytest

from mjx_skills.config import TrainConfig
from mjx_skills.logging import read_metrics
from mjx_skills.runner import Args, train_run


@pytest.mark.slow
def test_transit_learns(tmp_path):
    cfg = TrainConfig(task="transit", epochs=25, seeds=2, replay_capacity=100_000,
                      checkpoint_every=25, out=str(tmp_path), progress=False)  # fmt: skip
    rows = read_metrics(train_run(Args(train=cfg)))
    # Best epoch per seed, from evaluation with the frozen policy (20 episodes each).
    best = [max(r["eval_success"] for r in rows if r["seed"] == s) for s in range(2)]
    assert np.mean(best) >= 0.9, f"transit eval success per seed: {best}"
