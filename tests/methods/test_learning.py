"""Learning (slow; runs in CI): DDPG+HER trains transit; the library's search beats flat
exploration on pick_move; MPAS learns take_out."""

import numpy as np
import pytest

from mjx_skills.config import TrainConfig
from mjx_skills.skills.library import DEFAULT_DIR
from mjx_skills.training.metrics_log import read_metrics
from mjx_skills.training.runner import RunArgs, train_run


@pytest.mark.slow
def test_transit_learns(tmp_path):
    cfg = TrainConfig(
        task="transit",
        epochs=20,
        seeds=2,
        replay_capacity=100_000,
        checkpoint_every=20,
        out=str(tmp_path),
        progress=False,
    )
    rows = read_metrics(train_run(RunArgs(train=cfg)))
    # Evaluation with the frozen policy (20 episodes per epoch), last 3 epochs, per seed.
    last = [
        np.mean([r["eval_success"] for r in rows if r["seed"] == s and r["epoch"] > 17])
        for s in range(2)
    ]
    assert np.mean(last) >= 0.9, f"transit eval success over the last 3 epochs, per seed: {last}"


def _last_mean(rows, last: int) -> float:
    final = max(r["epoch"] for r in rows)
    return float(np.mean([r["eval_success"] for r in rows if r["epoch"] > final - last]))


needs_library = pytest.mark.skipif(
    not (DEFAULT_DIR / "manifest.json").exists(), reason="no built skill library"
)


@pytest.mark.slow
@needs_library
def test_the_skill_library_search_beats_flat_exploration_on_pick_move(tmp_path):
    """The thesis's main claim at a CI budget: same learner, seeds and epochs; only the
    explorer differs. (DDPG+HER+SL's mean passed 0.4 by epoch 40 in the committed runs;
    DDPG+HER stays at 0.)"""
    cfg = TrainConfig(
        task="pick_move", epochs=45, seeds=2, checkpoint_every=45, out=str(tmp_path), progress=False
    )
    flat = _last_mean(read_metrics(train_run(RunArgs(train=cfg, method="ddpg_her"))), 5)
    searched = _last_mean(read_metrics(train_run(RunArgs(train=cfg, method="ddpg_her_sl"))), 5)
    assert searched >= 0.2 and searched > flat + 0.15, (searched, flat)


@pytest.mark.slow
@needs_library
def test_mpas_learns_take_out(tmp_path):
    """Issue #12's bar at half its budget: the mean of 2 seeds over the last 5 of 15 epochs
    >= 0.5 (the committed runs: 0.86 over epochs 11-15; chance, the untrained
    meta-controller, scores 0.0-0.05)."""
    cfg = TrainConfig(
        task="take_out", epochs=15, seeds=2, checkpoint_every=15, out=str(tmp_path), progress=False
    )
    rows = read_metrics(train_run(RunArgs(train=cfg, method="mpas")))
    assert _last_mean(rows, 5) >= 0.5, [r["eval_success"] for r in rows]
