"""The push library of Fetch (SL_fetch_push: approach and push, envs/fetch_push_skills.py) for
FetchPush: the search's proposals for its skills, `build_library --library`, `--preset
fetch_push` (what `make train TASK=fetch_push` passes), and a tiny library built and used by
DDPG+HER+SL on fetch_push end to end."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import jax
import numpy as np
import pytest

from mjx_skills import build_library, methods
from mjx_skills.config import DDPGConfig, LibraryConfig, SearchConfig, TrainConfig
from mjx_skills.envs import make
from mjx_skills.envs.fetch_push_skills import BEHIND, LINE_UP, PUSH_HEIGHT, PUSH_RANGE, RAISE
from mjx_skills.skills import library, lookahead, registry
from mjx_skills.training.metrics_log import read_metrics
from mjx_skills.training.runner import RunArgs, train_run

PUSH = registry.LIBRARIES["SL_fetch_push"]
N, B = 8, 32


def _proposals(obs, task_goal):
    lib = library.empty_like(PUSH, DDPGConfig(), LibraryConfig(), memory_size=2)
    cfg = SearchConfig(branching=B, height=1, object_goal_noise=0.0, transfer_goal_noise=0.0)
    draws = lookahead.draw_edges(lookahead.env_keys(jax.random.PRNGKey(1), N), cfg, len(PUSH))
    skill, goals, ok = lookahead.sample_edges(
        lib, cfg, obs, task_goal, lookahead.level_draws(draws, 0, B)
    )
    assert np.asarray(ok).all() and set(np.unique(skill)) == {0, 1}  # both may start
    return np.asarray(skill), np.asarray(goals)


def test_the_search_proposes_approach_behind_the_block_and_push_towards_the_goal():
    """Approach: BEHIND behind the block opposite the task's goal, PUSH_HEIGHT's top above
    its centre where the grip is already over that point (within LINE_UP), RAISE higher
    where it is not (over the block first). Push: towards the task's goal, as far as a push
    trains for (PUSH_RANGE) or to the goal if nearer."""
    env = make("fetch_push")
    state = jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), N))
    obs, task_goal = np.asarray(state.obs), np.asarray(state.desired_goal)
    block = obs[:, None, 3:6].repeat(B, 1)
    toward = (task_goal[:, None].repeat(B, 1) - block)[..., :2]
    unit = toward / np.linalg.norm(toward, axis=-1, keepdims=True)
    start = obs[:, 3:5] - BEHIND * unit[:, 0]  # (N, 2) where a push towards the goal starts
    lined_up = obs.copy()
    lined_up[:, 0:2] = start + 0.5 * LINE_UP
    box = make("fetch_approach")
    low, high = np.asarray(box.box_low)[:2] + 1e-6, np.asarray(box.box_high)[:2] - 1e-6
    for where, rise in ((obs, RAISE), (lined_up, 0.0)):
        far = np.linalg.norm(where[:, 0:2] - start, axis=-1) > LINE_UP
        assert far.all() if rise else not far.any()
        skill, goals = _proposals(where, task_goal)
        step = goals - block
        approach = skill == PUSH.index("fetch_approach")
        inside = np.all((goals[..., :2] > low) & (goals[..., :2] < high), -1)
        free = approach & inside  # not clipped onto the edge of approach's box
        assert free.mean() > 0.3
        np.testing.assert_allclose(np.linalg.norm(step[free][:, :2], axis=-1), BEHIND, atol=1e-5)
        np.testing.assert_allclose(np.sum(step[free][:, :2] * unit[free], -1), -BEHIND, atol=1e-5)
        np.testing.assert_allclose(step[free][:, 2], PUSH_HEIGHT[1] + rise, atol=1e-5)
    push = skill == PUSH.index("fetch_push_block")
    np.testing.assert_allclose(step[push][:, 2], 0.0, atol=1e-6)  # along the table
    length, distance = (
        np.linalg.norm(step[push][:, :2], axis=-1),
        np.linalg.norm(toward[push], axis=-1),
    )
    np.testing.assert_allclose(np.sum(step[push][:, :2] * unit[push], -1), length, atol=1e-5)
    shortest, longest = (np.minimum(distance, r) for r in PUSH_RANGE)
    assert np.all((length > shortest - 1e-5) & (length < longest + 1e-5))
    assert np.ptp(length) > 0.03  # lengths drawn, not one


def test_build_library_builds_a_named_library_into_its_own_directory():
    push = build_library.SkillsArgs(robot="fetch", library="SL_fetch_push")
    assert push.names() == PUSH
    assert push.directory() == Path("experiments/skill_library_SL_fetch_push")
    first = build_library.SkillsArgs(robot="fetch", library="SL1_fetch")
    assert first.names() == registry.LIBRARIES["SL1_fetch"]
    assert first.directory() == Path("experiments/skill_library_fetch")
    with pytest.raises(ValueError, match="--library SL1: not a library of the fetch skills; valid"):
        build_library.SkillsArgs(robot="fetch", library="SL1").names()
    with pytest.raises(ValueError, match="--library and --skills both choose"):
        build_library.SkillsArgs(robot="fetch", library="SL1_fetch", skills=PUSH).names()


def test_the_fetch_push_preset_gives_every_library_method_the_push_library():
    for method, spec in methods.METHODS.items():
        options = methods.preset_options(method, "fetch_push")
        if spec.library_group is None:
            assert options == methods.preset_options(method)
            continue
        group = options[spec.library_group]
        assert group.library == "SL_fetch_push"
        assert group.library_dir == str(registry.default_dir("fetch", "SL_fetch_push"))
        methods.check_task(method, "fetch_push", options)  # the Fetch robot's: accepted


@pytest.mark.parametrize(
    "method, experiment",
    [("ddpg_her_sl", "headline_fetch_push"), ("ddpg_her", "headline_fetch_push_her")],
)
def test_the_fetch_push_preset_trains_the_headline_and_its_baseline_learner(method, experiment):
    """`make train TASK=fetch_push` (--preset fetch_push) trains what the FetchPush headline
    and its matched baseline trained, but for the budget and seeds; an explicit flag wins,
    and no other preset or method changes its learner."""
    from mjx_skills import train
    from mjx_skills.sweeps.experiments import load_experiment

    (cell,) = load_experiment(experiment).cells()
    stored = cell.run_args(out="")
    args = train.parse([method, "--preset", "fetch_push", "--task", "fetch_push"])
    budget = {f: getattr(stored.train, f) for f in ("epochs", "seed", "seeds", "out", "progress")}
    assert dataclasses.replace(args.train, **budget) == stored.train
    assert args.options == stored.options and args.env == stored.env
    assert args.train.updates_per_cycle != TrainConfig().updates_per_cycle  # the tuned one
    own = train.parse([method, "--preset", "fetch_push", "--updates-per-cycle", "100"])
    assert own.train.updates_per_cycle == 100
    assert methods.preset_train(method, "fetch") == TrainConfig()
    assert methods.preset_train("ddpg_her_sl_fast", "fetch_push") == TrainConfig()


def test_a_push_library_is_built_and_ddpg_her_sl_trains_fetch_push_with_it(
    tmp_path, monkeypatch, tiny_train
):
    """build_library --library SL_fetch_push (1 epoch per skill, 100 runs each), then one
    epoch of DDPG+HER+SL on fetch_push searching over it: the skills run in the task."""
    for name in PUSH:
        monkeypatch.setitem(
            registry.SKILLS, name, dataclasses.replace(registry.SKILLS[name], epochs=1)
        )
    tiny = LibraryConfig(samples=100, collect_envs=100, fit_epochs=2, skill_eval_episodes=4)
    args = build_library.SkillsArgs(
        config=tiny, robot="fetch", library="SL_fetch_push", out=str(tmp_path / "lib")
    )
    out = build_library.build(dataclasses.replace(args, progress=False))
    manifest = library.read_manifest(out)
    assert library.library_robot(manifest) == "fetch" and list(manifest["models"]) == list(PUSH)
    assert manifest["dims"]["fetch_push_block"]["param_dim"] == 2
    search = SearchConfig(branching=3, height=2, library="SL_fetch_push", library_dir=str(out))
    fields = {**tiny_train, "task": "fetch_push", "epochs": 1, "out": str(tmp_path / "runs")}
    run = train_run(
        RunArgs(train=TrainConfig(**fields), method="ddpg_her_sl", options={"search": search})
    )
    (row,) = read_metrics(run)
    assert row["env_steps"] == fields["envs"] * fields["cycles"] * 50
    assert math.isfinite(row["critic_loss"])
    assert row["skill_calls"] > 0  # the push library's skills ran in FetchPush
