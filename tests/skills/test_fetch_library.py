"""The committed skill library of Fetch (experiments/skill_library_fetch, `make skills
ROBOT=fetch`): what its manifest records, and every library method training a Fetch task
with it."""

from __future__ import annotations

import math

import pytest

from mjx_skills.config import PASConfig, SearchConfig, TrainConfig
from mjx_skills.core.files import read_json
from mjx_skills.skills import registry
from mjx_skills.skills.library import library_robot, load, read_manifest
from mjx_skills.training.metrics_log import read_metrics
from mjx_skills.training.runner import LIBRARY, RunArgs, train_run
from tests.fakes import tiny_train

FETCH_DIR = registry.default_dir("fetch")
FETCH = registry.LIBRARIES["SL1_fetch"]


def test_the_fetch_library_holds_the_fetch_skills_at_the_quality_bar():
    manifest = read_manifest(FETCH_DIR)
    assert library_robot(manifest) == "fetch" and list(manifest["models"]) == list(FETCH)
    assert not manifest["commit"].endswith("+dirty")  # built from a clean commit
    assert all(manifest["skill_success"][n] >= 0.9 for n in FETCH)  # docs/skill_library.md
    steps = manifest["env_steps"]
    assert set(steps["train"]) == set(steps["collect"]) == set(FETCH)
    lib, _ = load(FETCH_DIR)
    assert lib.names == FETCH


@pytest.mark.parametrize("method", ["ddpg_her_sl", "pas"])
def test_a_library_method_trains_fetch_pick_and_place_with_it(method, tmp_path):
    group = "search" if method == "ddpg_her_sl" else "pas"
    where = {"library": "SL1_fetch", "library_dir": str(FETCH_DIR)}
    options = {
        "search": {"search": SearchConfig(branching=3, height=2, **where)},
        "pas": {"pas": PASConfig(updates_per_cycle=3, **where)},
    }[group]
    updates = 3 if method == "ddpg_her_sl" else TrainConfig().updates_per_cycle  # PAS: its own
    train = TrainConfig(
        **tiny_train(
            task="fetch_pick_and_place",
            epochs=1,
            cycles=1,
            updates_per_cycle=updates,
            replay_capacity=3000,
            out=str(tmp_path),
        )
    )
    run_dir = train_run(RunArgs(train=train, method=method, options=options))
    (row,) = read_metrics(run_dir)
    # the run records the library it started with, down to its skills' source digests
    assert read_json(run_dir / LIBRARY)["skills"] == registry.fingerprint("SL1_fetch")
    assert row["env_steps"] == 2 * 50 and math.isfinite(row["critic_loss"])
    assert row["skill_calls"] > 0  # the Fetch skills ran
