"""Success predicates on hand-built states; compute_reward agrees with is_success."""

import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.envs import ENVS
from mjx_skills.envs.baxter import OBS_FINGERS, OBS_GRIP, OBS_OBJECT, OBS_REL


@pytest.mark.parametrize("name", list(ENVS))
def test_reward_agrees_with_success(name, env_factory):
    env = env_factory(name)
    goal = jnp.tile(jnp.array([0.7, -0.3, 0.0]), env.goal_dim // 3)  # two-cube tasks: 6-D
    offsets = np.random.default_rng(0).uniform(-0.08, 0.08, (500, env.goal_dim))
    offsets = jnp.array(offsets * np.random.default_rng(1).uniform(0, 1, (500, 1)), jnp.float32)
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


def test_skill_goal_parameters_map_into_their_boxes(env_factory):
    transit, grasp, transfer = (env_factory(n) for n in ("transit", "grasp", "transfer"))
    obs = jnp.zeros(25).at[OBS_OBJECT].set(jnp.array([0.7, -0.2, transit.table_z + 0.02]))
    np.testing.assert_allclose(
        transit.goal_from_param(-jnp.ones(3), obs), transit.workspace_low, atol=1e-6
    )
    np.testing.assert_allclose(
        transit.goal_from_param(jnp.ones(3), obs), transit.workspace_high, atol=1e-6
    )
    lift = [grasp.goal_from_param(jnp.array([p]), obs)[2] - obs[OBS_OBJECT][2] for p in (-1.0, 1.0)]
    np.testing.assert_allclose(lift, [0.05, 0.08], atol=1e-6)
    assert transfer.goal_from_param(-jnp.ones(3), obs)[2] >= transfer.table_z
    assert (transit.param_dim, grasp.param_dim, transfer.param_dim) == (3, 1, 3)
    assert len(transit.state_dims) == 6 and max(transfer.state_dims) < transfer.obs_dim


def test_transfer_terminates_when_the_cube_drops(env_factory):
    env = env_factory("transfer")
    goal = jnp.array([0.7, -0.2, 0.1])
    start = jnp.array([0.7, -0.3, 0.0])
    held = jnp.zeros(25).at[OBS_GRIP].set(start).at[OBS_OBJECT].set(start)
    held = held.at[OBS_FINGERS].set(0.017)
    fallen = jnp.array([0.0, 0.0, -0.08])
    dropped = held.at[OBS_OBJECT].set(start + fallen).at[OBS_REL].set(fallen)
    assert not bool(env.terminated(held, goal))
    assert bool(env.terminated(dropped, goal))
    assert bool(env.terminated(held.at[OBS_OBJECT].set(goal), goal))
