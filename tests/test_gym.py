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


ODD_ACTIONS = np.array([
    [np.inf, 0, 0, 1], [-np.inf, np.inf, 0, -1], [np.nan, 0, np.nan, 1], [1e30, -1e30, 0, 1],
    [1e-30, 0, -1e-30, -1], [0.5, -0.25, 0.1, 0.3],
], np.float32)  # fmt: skip
"""+-inf, NaN, huge and tiny values (and one ordinary action for reference)."""


@pytest.mark.parametrize("task", list(ENVS))
def test_the_adapter_and_the_jax_env_agree_on_odd_actions(task, env_factory):
    """From the same reset, one step of each odd action moves grip and cube alike in both
    (an inf once moved the grip 0 cm in the JAX env and 4.7 cm in the adapter)."""
    key = jax.random.PRNGKey(11)
    jax_env = env_factory(task)
    start = jax.jit(jax_env.reset)(key)
    moved = jax.jit(jax.vmap(jax_env.step, in_axes=(None, 0)))(start, ODD_ACTIONS)
    gym_env = BaxterGymEnv(task)
    for i, action in enumerate(ODD_ACTIONS):
        before, _ = gym_env.reset(options={"jax_key": key})
        after, *_ = gym_env.step(action)
        want = np.asarray(moved.obs[i, :6])
        np.testing.assert_allclose(after["observation"][:6], want, atol=0.005, err_msg=str(action))
        assert np.all(np.isfinite(after["observation"]))
    grip_moves = np.linalg.norm(np.asarray(moved.obs[:, :3]) - np.asarray(start.obs[:3]), axis=1)
    assert grip_moves[0] > 0.03 and grip_moves[1] > 0.03  # +-inf act as +-1: a 5 cm move
    assert grip_moves[2] < grip_moves[0]  # NaN acts as 0 on its axis


def test_scripted_pick_move_succeeds_and_moves_the_cube_alike_in_both(env_factory):
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
    # The cube moved (picked and carried) the same way in both: its final positions agree.
    start = np.asarray(jax.jit(jax_env.reset)(key).obs[3:6])
    assert np.linalg.norm(np.asarray(state.obs[3:6]) - start) > 0.05
    np.testing.assert_allclose(obs["observation"][3:6], np.asarray(state.obs[3:6]), atol=0.01)


VECTOR = """
import sys, gymnasium, numpy as np
import mjx_skills.envs.gym
from mjx_skills.envs.gym import gym_id
context = sys.argv[1]
try:
    envs = gymnasium.make_vec(gym_id("transit"), num_envs=2, vectorization_mode="async",
                              vector_kwargs={"context": context})
    obs, _ = envs.reset(seed=0)
    obs, reward, *_ = envs.step(np.zeros((2, 4), np.float32))
    print("OK", obs["observation"].shape)
    envs.close()
except Exception as err:
    print("ERROR", type(err).__name__, err)
"""


@pytest.mark.parametrize("context", ["spawn", "fork"])
def test_async_vector_envs_spawn_or_fail_at_once_when_forked(context):
    """A forked worker hung in its first JAX call (3 of 3 tries); spawned ones work."""
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", VECTOR, context], capture_output=True,
                         text=True, timeout=300)  # fmt: skip
    if context == "spawn":
        assert "OK (2, 25)" in run.stdout, run.stdout + run.stderr
    else:  # the worker's error (with the fix) on stderr; the parent's pipe broke at once
        assert "ERROR" in run.stdout, run.stdout
        assert "forked after JAX had started" in run.stderr and "'spawn'" in run.stderr
