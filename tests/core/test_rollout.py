"""The shared rollout scan with a stateful behaviour, and the trainer's device counters.

A toy behaviour commits to one random action for 3 steps (as a skill commits to its goal);
a 2-D point env without physics keeps the compile to seconds.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import struct

from mjx_skills.config import DDPGConfig, TrainConfig
from mjx_skills.core.learner import Learner
from mjx_skills.core.rollout import Behaviour, Episode, example_episode, run_episodes, stateless
from mjx_skills.methods.ddpg_her import make_ddpg_her
from mjx_skills.training import epoch
from tests.fakes import tiny_train

HOLD = 3


@struct.dataclass
class PointState:
    obs: jax.Array
    achieved_goal: jax.Array
    desired_goal: jax.Array
    metrics: dict


class PointEnv:
    """A point moved by 0.1 x action in the plane; success within 0.05 of the goal."""

    obs_dim, goal_dim, action_dim, episode_length = 2, 2, 2, 7
    n_objects = 0  # GoalEnv: the point itself reaches the goal, no object

    def compute_reward(self, achieved, desired):
        return (jnp.linalg.norm(achieved - desired, axis=-1) < 0.05).astype(jnp.float32) - 1.0

    def _state(self, pos, goal):
        d = jnp.linalg.norm(pos - goal)
        metrics = {
            "success": (d < 0.05).astype(jnp.float32),
            "distance": d,
            "physics_resets": jnp.zeros(()),
        }
        return PointState(obs=pos, achieved_goal=pos, desired_goal=goal, metrics=metrics)

    def reset(self, key):
        k_pos, k_goal = jax.random.split(key)
        return self._state(jax.random.uniform(k_pos, (2,)), jax.random.uniform(k_goal, (2,)))

    def step(self, state, action):
        return self._state(state.obs + 0.1 * jnp.clip(action, -1, 1), state.desired_goal)


def hold_behaviour() -> Behaviour:
    """Draw a uniform random action, keep it for HOLD steps, draw again."""

    def init(key, n):
        return {"action": jnp.zeros((n, 2)), "age": jnp.zeros((n,), jnp.int32)}

    def step(pstate, key, env_state):
        new = pstate["age"] % HOLD == 0
        fresh = jax.random.uniform(key, pstate["action"].shape, minval=-1.0, maxval=1.0)
        action = jnp.where(new[:, None], fresh, pstate["action"])
        pstate = {"action": action, "age": pstate["age"] + 1}
        return pstate, action, {"skill_calls": new.astype(jnp.int32), "committed": ~new}

    return Behaviour(init=init, step=step)


@pytest.fixture(scope="module")
def episodes():
    env = PointEnv()
    return jax.jit(lambda k: run_episodes(env, hold_behaviour(), k, 16))(jax.random.PRNGKey(0))


def test_a_stateful_behaviour_commits_for_its_horizon(episodes):
    ep, final, records = episodes
    T = PointEnv.episode_length
    assert ep.actions.shape == (16, T, 2) and ep.obs.shape == (16, T + 1, 2)
    a = np.asarray(ep.actions)
    for start in range(0, T, HOLD):
        block = a[:, start : start + HOLD]
        np.testing.assert_array_equal(block, np.repeat(block[:, :1], block.shape[1], axis=1))
        if start + HOLD < T:  # the next block draws a new action
            assert np.all(np.any(a[:, start] != a[:, start + HOLD], axis=-1))
    np.testing.assert_array_equal(records["skill_calls"].sum(axis=1), -(-T // HOLD))
    # The stored observations are the states the actions were taken in.
    np.testing.assert_allclose(ep.obs[:, 1:], ep.obs[:, :-1] + 0.1 * ep.actions, atol=1e-6)
    np.testing.assert_array_equal(final.obs, ep.obs[:, -1])


def test_replay_layout_comes_from_the_episode():
    layout = example_episode(PointEnv())
    assert isinstance(layout, Episode)
    assert layout.obs.shape == (8, 2) and layout.g.shape == (7, 2)
    assert layout.actions.dtype == jnp.float32


def test_trainer_counts_steps_episodes_and_skill_calls():
    env = PointEnv()
    cfg = TrainConfig(
        **tiny_train(task="point", envs=3, updates_per_cycle=2, replay_capacity=700, seeds=2)
    )
    ddpg_her = make_ddpg_her(env, cfg, DDPGConfig(hidden=(16,)))
    learner = Learner(**{**ddpg_her._asdict(), "explore": lambda a, aux, e: hold_behaviour()})
    run_epoch = jax.jit(jax.vmap(epoch.make_train_epoch(learner, env, cfg), in_axes=(0, None)))
    init = jax.vmap(lambda k: epoch.init_carry(learner, env, cfg, k))
    carry = jax.jit(init)(epoch.seed_keys(cfg))
    for n in (1, 2):
        carry, metrics = run_epoch(carry, None)
        metrics = epoch.host_metrics(metrics)  # the counters' values
        episodes = n * cfg.envs * cfg.cycles
        np.testing.assert_array_equal(metrics["episodes"], episodes)
        np.testing.assert_array_equal(metrics["env_steps"], episodes * env.episode_length)
        np.testing.assert_array_equal(metrics["skill_calls"], episodes * -(-7 // HOLD))
        # The behaviour's other records are logged as shares: 4 of 7 steps are committed.
        np.testing.assert_allclose(metrics["explore_committed"], 4 / 7, rtol=1e-6)
    assert int(carry.replay.size[0]) == 2 * cfg.envs * cfg.cycles


def test_explore_reads_the_previous_epochs_evaluated_success():
    """`Progress.success`, what an explorer may drive eps with (`--search.eps-floor-by-success`),
    is each seed's eval success of the epoch before (0 in the first), and the epoch is its own."""
    env = PointEnv()
    cfg = TrainConfig(
        **tiny_train(
            task="point", updates_per_cycle=1, eval_episodes=16, replay_capacity=300, seeds=3
        )
    )
    base = make_ddpg_her(env, cfg, DDPGConfig(hidden=(8,)))

    def explore(agent, aux, progress):
        def step(pstate, key, state):
            n = state.obs.shape[0]
            seen = {"seen_success": progress.success, "seen_epoch": progress.epoch}
            return pstate, jnp.zeros((n, 2)), jax.tree.map(lambda x: jnp.full((n,), x), seen)

        return Behaviour(init=lambda key, n: (), step=step)

    # Straight at the goal: succeeds where the goal lies within reach, a share of the episodes.
    towards = stateless(lambda key, obs, goal: jnp.clip((goal - obs) / 0.1, -1.0, 1.0))
    learner = base._replace(explore=explore, evaluate=lambda agent, aux: towards)
    run_epoch = jax.jit(jax.vmap(epoch.make_train_epoch(learner, env, cfg), in_axes=(0, None)))
    carry = jax.jit(jax.vmap(lambda k: epoch.init_carry(learner, env, cfg, k)))(
        epoch.seed_keys(cfg)
    )
    before = np.zeros(cfg.seeds)
    for n in range(3):
        carry, metrics = run_epoch(carry, None)
        np.testing.assert_allclose(metrics["explore_seen_success"], before, atol=1e-6)
        np.testing.assert_array_equal(metrics["explore_seen_epoch"], n)
        before = np.asarray(metrics["eval_success"])
        assert before.max() > 0.0 and np.ptp(before) > 0.0  # seeds differ: each reads its own
