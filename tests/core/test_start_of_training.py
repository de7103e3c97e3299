"""The start of training as mrl's Fetch benchmark has it (all off by default, as the thesis):
uniform random actions for the first env steps (`--random-steps`), no gradient step before
the replay holds enough transitions (`--ddpg.warm-up`), and every goal relabelled until it
holds more (`--ddpg.future-warm-up`); and what its normaliser and relabelling read
(`--ddpg.goal-stats`, `--ddpg.relabel-actual`). On the 2-D point env of test_rollout (no
physics)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.agents import ddpg as ddpg_agent
from mjx_skills.config import DDPGConfig, TrainConfig
from mjx_skills.core import normalizer, replay, rollout
from mjx_skills.core.rollout import stateless
from mjx_skills.methods import ddpg_her
from mjx_skills.training import epoch
from tests.core.test_rollout import PointEnv
from tests.fakes import tiny_train

T = PointEnv.episode_length
ENVS = 3
STILL = stateless(lambda key, obs, goal: jnp.zeros_like(obs))
"""A behaviour that never moves: any non-zero stored action is a random one."""


def _stored_actions(random_steps: int, epochs: int = 1) -> np.ndarray:
    """(episodes, T, 2) actions the replay holds after `epochs` epochs of 2 cycles of ENVS
    episodes each, the method's behaviour being STILL."""
    env = PointEnv()
    cfg = TrainConfig(
        **tiny_train(task="point", envs=ENVS, updates_per_cycle=1, replay_capacity=700),
        random_steps=random_steps,
    )
    base = ddpg_her.make_ddpg_her(env, cfg, DDPGConfig(hidden=(8,)))
    learner = base._replace(explore=lambda agent, aux, progress: STILL)
    run_epoch = jax.jit(epoch.make_train_epoch(learner, env, cfg))
    carry = epoch.init_carry(learner, env, cfg, jax.random.PRNGKey(0))
    for _ in range(epochs):
        carry, _ = run_epoch(carry, None)
    return np.asarray(carry.replay.data.actions[: int(carry.replay.size)])


def test_random_steps_act_uniformly_at_random_for_the_cycles_that_start_below_them():
    actions = _stored_actions(random_steps=ENVS * T)  # exactly the first cycle
    first, second = actions[:ENVS], actions[ENVS:]
    assert np.all(second == 0.0), "the method acts again once random_steps are taken"
    assert np.all(np.abs(first) <= 1.0) and np.all(first != 0.0)
    # Uniform on [-1, 1]: mean 0 and std 1 / sqrt(3) (42 draws: loose bounds).
    assert abs(first.mean()) < 0.3 and 0.4 < first.std() < 0.75
    # One step more reaches into the second cycle, which is then random throughout.
    assert np.all(_stored_actions(random_steps=ENVS * T + 1) != 0.0)


def test_no_random_steps_leave_the_method_acting():
    assert np.all(_stored_actions(random_steps=0, epochs=2) == 0.0)


def _buffer_and_fresh(episodes: int):
    env = PointEnv()
    wander = stateless(lambda key, obs, goal: jax.random.uniform(key, obs.shape, minval=-1.0))
    fresh, _, _ = rollout.run_episodes(env, wander, jax.random.PRNGKey(1), episodes)
    buffer = replay.init(100 * T, rollout.example_episode(env), T=T)
    return env, replay.add(buffer, fresh), fresh


def _update(config: DDPGConfig, episodes: int = 4):
    """(agent before, agent after, buffer) of one her_update of 3 steps on `episodes` stored
    episodes."""
    env, buffer, fresh = _buffer_and_fresh(episodes)
    agent = ddpg_agent.init(jax.random.PRNGKey(2), env.obs_dim, env.goal_dim, 2, config)
    after, _ = ddpg_her.her_update(agent, buffer, fresh, jax.random.PRNGKey(3), env, 3, config)
    return agent, after, buffer


def _same(a, b) -> bool:
    return all(
        bool(jnp.array_equal(x, y))
        for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True)
    )


@pytest.mark.parametrize("warm_up, trains", [(4 * T, False), (4 * T - 1, True)])
def test_warm_up_holds_the_networks_until_the_replay_holds_more_transitions(warm_up, trains):
    config = DDPGConfig(hidden=(8,), batch_size=16, warm_up=warm_up)
    before, after, _ = _update(config)  # 4 episodes of T steps stored
    assert _same(before.actor_params, after.actor_params) is not trains
    assert _same(before.critic_params, after.critic_params) is not trains
    # The normalisers see the episodes either way.
    assert float(after.obs_norm.count) == 4 * (T + 1) > float(before.obs_norm.count)


@pytest.mark.parametrize(
    "goal_stats, per_episode", [("desired_and_achieved", 2 * T + 1), ("desired", T)]
)
def test_the_goal_normaliser_sees_the_goals_goal_stats_names(goal_stats, per_episode):
    config = DDPGConfig(hidden=(8,), batch_size=16, goal_stats=goal_stats)
    _, after, buffer = _update(config)
    assert float(after.goal_norm.count) == 4 * per_episode
    desired = np.asarray(buffer.data.g[:4]).reshape(-1, 2)
    achieved = np.asarray(buffer.data.ag[:4]).reshape(-1, 2)
    seen = desired if goal_stats == "desired" else np.concatenate([desired, achieved])
    np.testing.assert_allclose(
        normalizer.mean_std(after.goal_norm, 1e-2)[0], seen.mean(0), atol=1e-5
    )


@pytest.mark.parametrize("future_warm_up, relabelled", [(4 * T + 1, True), (4 * T, False)])
@pytest.mark.parametrize("actual", [0.0, 0.4])
def test_future_warm_up_relabels_every_goal_while_the_replay_holds_fewer(
    future_warm_up, relabelled, actual, monkeypatch
):
    seen = []
    sample = ddpg_her.her.sample_batch
    monkeypatch.setattr(
        ddpg_her.her, "sample_batch", lambda *a, **k: seen.append(sample(*a, **k)) or seen[-1]
    )
    config = DDPGConfig(
        hidden=(8,),
        batch_size=64,
        relabel_prob=0.0,
        relabel_actual=actual,
        future_warm_up=future_warm_up,
    )
    _, _, buffer = _update(config)
    goals = np.asarray(seen[0]["goal"])
    stored = buffer.size
    achieved = np.asarray(buffer.data.ag[:stored]).reshape(-1, 2)
    desired = np.asarray(buffer.data.g[:stored]).reshape(-1, 2)
    is_achieved = (goals[:, None] == achieved[None]).all(-1).any(1)
    is_desired = (goals[:, None] == desired[None]).all(-1).any(1)
    # Random goals in the unit square: no episode's goal is a point it reached. During the
    # warm-up every goal is a future one, no actual share; after it (relabel_prob 0) each
    # is a desired goal, its own or (relabel_actual) another transition's.
    assert bool(np.all(is_achieved)) is relabelled
    assert bool(np.all(is_desired)) is not relabelled


@pytest.mark.parametrize(
    "field, value", [("warm_up", -1), ("future_warm_up", -1), ("random_steps", 2**30 + 1)]
)
def test_bad_start_settings_name_the_field(field, value):
    make = TrainConfig if field == "random_steps" else DDPGConfig
    with pytest.raises(ValueError, match=field):
        make(**{field: value})
    with pytest.raises(ValueError, match="future_warm_up"):
        DDPGConfig(her_strategy="none", future_warm_up=10)


@pytest.mark.parametrize(
    "fields",
    [
        {"relabel_prob": 0.8, "relabel_actual": 0.4},
        {"relabel_actual": -0.1},
        {"her_strategy": "none", "relabel_actual": 0.2},
    ],
)
def test_bad_actual_shares_name_the_field(fields):
    with pytest.raises(ValueError, match="relabel_actual"):
        DDPGConfig(**fields)


@pytest.mark.parametrize("future, actual", [(0.8, 0.2), (0.9, 0.1), (0.4, 0.4), (0.0, 1.0)])
def test_actual_shares_up_to_the_rest_are_accepted(future, actual):
    config = DDPGConfig(relabel_prob=future, relabel_actual=actual)
    assert config.relabel_actual == actual
