"""The gymnasium adapter: env_checker passes, and it matches the JAX env step for step."""

import gymnasium
import jax
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import mjx_skills.envs.gym  # noqa: F401  (registers MjxSkills/*-v0)
from mjx_skills.envs import ENVS
from mjx_skills.envs.controllers import make_scripted_policy
from mjx_skills.envs.gym import BaxterGymEnv, gym_id


@pytest.mark.parametrize("name", list(ENVS))
def test_env_checker_passes(name):
    env = gymnasium.make(gym_id(name))
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert env.unwrapped.task.episode_length == ENVS[name].default_episode_length


@pytest.mark.parametrize("make", [
    lambda: gymnasium.make(gym_id("pick_move"), episode_length=10),
    lambda: BaxterGymEnv("pick_move", episode_length=10),
    lambda: gymnasium.make(gym_id("transit")),
], ids=["gym.make", "direct", "default"])  # fmt: skip
def test_episodes_truncate_after_the_task_episode_length(make):
    """episode_length=10 ended after 50 steps with gym.make and never without it."""
    env = make()
    length = env.unwrapped.task.episode_length
    env.reset(seed=0)
    flags = [env.step(np.zeros(4, np.float32))[2:4] for _ in range(length)]
    assert flags[:-1] == [(False, False)] * (length - 1)
    assert flags[-1] == (False, True)
    env.reset(seed=1)  # a new episode counts from zero again
    assert env.step(np.zeros(4, np.float32))[3] is False


def test_vectorised_compute_reward():
    env = BaxterGymEnv("pick_move")
    goal = np.zeros((5, 3), np.float32)
    achieved = goal + np.array([[0.0, 0, 0], [0.02, 0, 0], [0.04, 0, 0], [0, 0.1, 0], [0, 0, 0.01]])
    np.testing.assert_array_equal(env.compute_reward(achieved, goal, {}), [0, 0, -1, -1, 0])


def test_transit_matches_the_jax_env(env_factory):
    key = jax.random.PRNGKey(3)
    actions = np.random.default_rng(0).uniform(-1, 1, (20, 4)).astype(np.float32)
    jax_env = env_factory("transit")
    state = jax.jit(jax_env.reset)(key)
    step = jax.jit(jax_env.step)
    for a in actions:
        state = step(state, a)
    gym_env = BaxterGymEnv("transit")
    obs, _ = gym_env.reset(options={"jax_key": key})
    for a in actions:
        obs, *_ = gym_env.step(a)
    np.testing.assert_allclose(obs["observation"][:6], np.asarray(state.obs[:6]), atol=0.005)


def test_scripted_pick_move_succeeds_in_both(env_factory):
    key = jax.random.PRNGKey(7)
    jax_env = env_factory("pick_move")
    policy = jax.jit(make_scripted_policy(jax_env))
    state, step = jax.jit(jax_env.reset)(key), jax.jit(jax_env.step)
    gym_env = BaxterGymEnv("pick_move")
    obs, _ = gym_env.reset(options={"jax_key": key})
    for _ in range(jax_env.episode_length):
        state = step(state, policy(state.obs, state.desired_goal))
        obs, reward, *_ = gym_env.step(np.asarray(policy(obs["observation"], obs["desired_goal"])))
    assert float(state.metrics["success"]) == 1.0
    assert reward == 0.0
