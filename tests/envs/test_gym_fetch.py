"""The Fetch gym adapter (envs/gym_fetch.py): registered beside gymnasium-robotics' ids,
env_checker passes, its episodes are the JAX env's own, seeds reproduce, refusals."""

import functools

import gymnasium
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from mjx_skills.envs import FETCH
from mjx_skills.envs.fetch_scripted import SCRIPTED
from mjx_skills.envs.gym import gym_id
from mjx_skills.envs.gym_fetch import FetchGymEnv


@functools.cache
def adapter(task: str) -> FetchGymEnv:
    """One adapter per task and test session (its reset and step compile once)."""
    return FetchGymEnv(task)


@functools.cache
def jax_rollout(task: str):
    """The JAX env's own episode: a jitted scan of its step over a (T, 4) action array
    from a State -> the stacked States after each step."""
    env = adapter(task).task

    def run(state, actions):
        def body(s, a):
            s = env.step(s, a)
            return s, s

        return jax.lax.scan(body, state, actions)[1]

    return jax.jit(run)


def scripted_episode(env: FetchGymEnv, task: str, noise: int, **reset) -> tuple[list, np.ndarray]:
    """An episode of the adapter to its truncation: the scripted controller (the push
    controller for Slide) plus N(0, 0.2) noise drawn from seed `noise`; `reset`: reset's
    keywords -> (the results of reset and every step,
    the actions sent)."""
    policy = jax.jit(SCRIPTED.get(task, SCRIPTED["fetch_push"]))
    rng = np.random.default_rng(noise)
    results = [env.reset(**reset)]
    actions = []
    while len(results) == 1 or not (results[-1][2] or results[-1][3]):
        obs = results[-1][0]
        action = np.asarray(policy(obs["observation"], obs["desired_goal"]))
        actions.append(np.clip(action + rng.normal(0.0, 0.2, 4), -1, 1).astype(np.float32))
        results.append(env.step(actions[-1]))
    return results, np.stack(actions)


# ---------------------------------------------------------------- registration and checkers
def test_our_ids_stand_beside_gymnasium_robotics_own():
    import gymnasium_robotics

    gymnasium.register_envs(gymnasium_robotics)
    for task in FETCH:
        theirs = FETCH[task].__name__ + "-v4"
        assert gymnasium.spec(theirs).entry_point.startswith("gymnasium_robotics")
        assert gymnasium.spec(gym_id(task)).entry_point == "mjx_skills.envs.gym_fetch:FetchGymEnv"
    env = gymnasium.make("MjxSkills/FetchPickAndPlace-v0")
    assert isinstance(env.unwrapped, FetchGymEnv)
    assert env.unwrapped.task.episode_length == 50
    assert env.observation_space["observation"].shape == (25,)


@pytest.mark.parametrize("task", list(FETCH))
def test_env_checker_passes(task):
    env = gymnasium.make(gym_id(task))
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs) and isinstance(info["is_success"], bool)


def test_sb3_env_checker_passes():
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(adapter("fetch_push"), warn=True)


# ---------------------------------------------------------------- behaviour
@pytest.mark.parametrize("task", ["fetch_push", "fetch_pick_and_place"])
def test_an_episode_from_a_seed_is_the_jax_envs_rollout(task):
    """The adapter's episode from reset(seed=...) (scripted, contact included) against the
    JAX env's own jitted scan of the same actions from the same start: every step's
    observation within 1e-5, the same rewards, successes and truncation."""
    env = adapter(task)
    results, actions = scripted_episode(env, task, 5, seed=5)
    start = env._reset(env._start_key(5, None))  # the start reset(seed=5) drew
    np.testing.assert_array_equal(results[0][0]["observation"], np.asarray(start.obs))
    states = jax_rollout(task)(start, jnp.asarray(actions))
    assert len(actions) == env.task.episode_length == 50
    for t, (obs, reward, terminated, truncated, info) in enumerate(results[1:]):
        np.testing.assert_allclose(obs["observation"], states.obs[t], atol=1e-5, err_msg=str(t))
        np.testing.assert_allclose(obs["achieved_goal"], states.achieved_goal[t], atol=1e-5)
        np.testing.assert_array_equal(obs["desired_goal"], states.desired_goal[t])
        assert reward == float(states.reward[t]) and terminated is False
        assert info["is_success"] == bool(states.metrics["success"][t])
        assert truncated == (t == len(actions) - 1)
    moved = np.linalg.norm(results[-1][0]["achieved_goal"] - results[0][0]["achieved_goal"])
    assert moved > 0.02  # the object was pushed or carried: contact was part of the episode


def test_reset_seed_reproduces_the_episode_and_jax_key_starts_the_jax_reset():
    env, twin = adapter("fetch_pick_and_place"), FetchGymEnv("fetch_pick_and_place")
    ours, actions = scripted_episode(env, "fetch_pick_and_place", 1, seed=11)
    again, _ = scripted_episode(twin, "fetch_pick_and_place", 1, seed=11)
    for a, b in zip(ours, again, strict=True):
        for key in a[0]:
            np.testing.assert_array_equal(a[0][key], b[0][key])
    other, _ = env.reset(seed=12)
    assert np.linalg.norm(other["desired_goal"] - ours[0][0]["desired_goal"]) > 1e-3
    key = jax.random.PRNGKey(4)
    obs, _ = env.reset(options={"jax_key": key})
    np.testing.assert_array_equal(obs["desired_goal"], np.asarray(env.task.reset(key).desired_goal))


def test_compute_reward_is_batched_and_gives_the_step_rewards():
    env = adapter("fetch_push")
    results, _ = scripted_episode(env, "fetch_push", 0, seed=0)
    achieved = np.stack([r[0]["achieved_goal"] for r in results[1:]])
    desired = np.stack([r[0]["desired_goal"] for r in results[1:]])
    rewards = env.compute_reward(achieved, desired, {})
    assert rewards.shape == (50,) and rewards.dtype == np.float32
    np.testing.assert_array_equal(rewards, [r[1] for r in results[1:]])
    assert set(rewards.tolist()) == {0.0, -1.0}  # the scripted push reached the goal
    grid = env.compute_reward(achieved[None].repeat(2, 0), desired[None].repeat(2, 0), {})
    assert grid.shape == (2, 50)


@pytest.mark.parametrize(
    "make",
    [
        lambda: gymnasium.make(gym_id("fetch_reach"), episode_length=10),
        lambda: FetchGymEnv("fetch_reach", episode_length=10),
    ],
    ids=["gym.make", "direct"],
)
def test_episodes_truncate_after_the_episode_length(make):
    env = make()
    env.reset(seed=0)
    flags = [env.step(np.zeros(4, np.float32))[2:4] for _ in range(10)]
    assert flags == [(False, False)] * 9 + [(False, True)]
    env.reset(seed=1)
    assert env.step(np.zeros(4, np.float32))[3] is False


# ---------------------------------------------------------------- refusals and rendering
@pytest.mark.parametrize("mode", ["rgb_aray", "Human", "", "human", "rgb_array_list", 1])
def test_bad_render_modes_are_refused_as_the_baxter_adapter_refuses_them(mode):
    with pytest.raises(ValueError, match="'rgb_array'") as refused:
        FetchGymEnv("fetch_reach", render_mode=mode)
    if mode in ("human", "rgb_array_list"):
        assert f"gymnasium.make('MjxSkills/FetchReach-v0', render_mode={mode!r})" in str(
            refused.value
        )
        assert "FetchGymEnv(..., render_mode='rgb_array')" in str(refused.value)


def test_other_tasks_options_and_stepping_before_reset_are_refused():
    with pytest.raises(ValueError, match="pick_move: FetchGymEnv hosts fetch_reach, .*Baxter"):
        FetchGymEnv("pick_move")
    with pytest.raises(ValueError, match="unknown task 'fetch_pik'"):
        FetchGymEnv("fetch_pik")
    with pytest.raises(ValueError, match="timestep"):  # a Baxter scene's field
        FetchGymEnv("fetch_push", timestep=0.001)
    with pytest.raises(ValueError, match="steps native MuJoCo"):
        FetchGymEnv("fetch_push", physics="mjx")
    with pytest.raises(gymnasium.error.ResetNeeded):
        FetchGymEnv("fetch_reach").step(np.zeros(4, np.float32))
    env = FetchGymEnv("fetch_reach")
    env.reset(seed=0)
    for shape in ((7,), (2, 4), ()):
        with pytest.raises(ValueError, match=r"this env takes one action of shape \(4,\)"):
            env.step(np.zeros(shape, np.float32))


class FakeRenderer:
    """mujoco.Renderer without OpenGL: keeps the object's drawn position and the camera."""

    def __init__(self, model, height, width):
        self.model, self.shape, self.drawn = model, (height, width, 3), []

    def update_scene(self, data, camera=-1):
        self.drawn.append((data.xpos[self.model.body("object0").id].copy(), camera))

    def render(self):
        return np.zeros(self.shape, np.uint8)

    def close(self):
        pass


def test_render_draws_the_current_state_from_their_camera(monkeypatch):
    monkeypatch.setattr(mujoco, "Renderer", FakeRenderer)
    env = FetchGymEnv("fetch_push", render_mode="rgb_array")
    obs, _ = env.reset(seed=3)
    for action in np.random.default_rng(0).uniform(-1, 1, (3, 4)).astype(np.float32):
        assert env.render().shape == (480, 640, 3)
        drawn, camera = env._renderer.drawn[-1]
        # Push's observation is of the end state (a forward pass follows each step).
        np.testing.assert_allclose(drawn, obs["observation"][3:6], atol=1e-5)
        assert camera.distance == env.task.render_view["distance"]
        obs, *_ = env.step(action)
