"""Success predicates on hand-built states; compute_reward agrees with is_success."""

import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.envs import ENVS


@pytest.mark.parametrize("name", list(ENVS))
def test_reward_agrees_with_success(name, env_factory):
    env = env_factory(name)
    goal = jnp.array([0.7, -0.3, 0.0])
    offsets = jnp.array(np.random.default_rng(0).uniform(-0.08, 0.08, (500, 3)), jnp.float32)
    achieved = goal + offsets
    success = env.is_success(achieved, goal)
    reward = env.compute_reward(achieved, goal)
    np.testing.assert_array_equal(np.asarray(reward), np.where(np.asarray(success), 0.0, -1.0))
    assert 0 < int(success.sum()) < 500  # both outcomes occur


def test_point_predicates(env_factory):
    env = env_factory("pick_move")
    goal = jnp.array([0.7, -0.2, 0.0])
    assert bool(env.is_success(goal + jnp.array([0.02, 0.0, 0.0]), goal))
    assert not bool(env.is_success(goal + jnp.array([0.02, 0.02, 0.02]), goal))  # 3.5 cm


def test_container_predicate(env_factory):
    env = env_factory("put_in_container")
    goal = env.goal
    assert bool(env.is_success(goal + jnp.array([0.04, 0.0, 0.01]), goal))  # 4 cm off centre
    assert not bool(env.is_success(goal + jnp.array([0.0, 0.0, 0.03]), goal))  # held above
    assert not bool(env.is_success(goal + jnp.array([0.06, 0.0, 0.0]), goal))  # outside


def test_put_on_requires_contact_height(env_factory):
    env = env_factory("put_on")
    goal = env.goal
    assert bool(env.is_success(goal + jnp.array([0.02, 0.0, 0.005]), goal))
    assert not bool(env.is_success(goal + jnp.array([0.0, 0.0, 0.02]), goal))  # hovering 2 cm
