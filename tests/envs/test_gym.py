"""The gymnasium adapter: env_checker passes, and it matches the JAX env step for step."""

import warnings

import gymnasium
import jax
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import mjx_skills.envs.gym  # noqa: F401  (registers MjxSkills/*-v0)
from mjx_skills.envs import BAXTER as ENVS  # the adapter hosts the Baxter envs
from mjx_skills.envs.controllers import make_scripted_policy
from mjx_skills.envs.gym import BaxterGymEnv, gym_id


@pytest.mark.parametrize("name", list(ENVS))
def test_env_checker_passes(name):
    env = gymnasium.make(gym_id(name))
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert env.unwrapped.task.episode_length == ENVS[name].default_episode_length


@pytest.mark.parametrize(
    "make",
    [
        lambda: gymnasium.make(gym_id("pick_move"), episode_length=10),
        lambda: BaxterGymEnv("pick_move", episode_length=10),
        lambda: gymnasium.make(gym_id("transit")),
    ],
    ids=["gym.make", "direct", "default"],
)
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


ODD_ACTIONS = np.array(
    [
        [np.inf, 0, 0, 1],
        [-np.inf, np.inf, 0, -1],
        [np.nan, 0, np.nan, 1],
        [1e30, -1e30, 0, 1],
        [1e-30, 0, -1e-30, -1],
        [0.5, -0.25, 0.1, 0.3],
    ],
    np.float32,
)
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

    run = subprocess.run(
        [sys.executable, "-c", VECTOR, context], capture_output=True, text=True, timeout=300
    )
    if context == "spawn":
        assert "OK (2, 25)" in run.stdout, run.stdout + run.stderr
    else:  # the worker's error (with the fix) on stderr; the parent's pipe broke at once
        assert "ERROR" in run.stdout, run.stdout
        assert "forked after JAX had started" in run.stderr and "'spawn'" in run.stderr


# ---------------------------------------------------------------- construction
BAD_RENDER_MODES = ["rgb_aray", "RGB_ARRAY", "Human", "", "human", "rgb_array_list", 1, ("x",)]
"""Typos, the wrong case, modes gymnasium.make reaches by wrapping, values not strings."""


class _Stub(gymnasium.Env):
    """BaxterGymEnv's metadata and nothing else: how gymnasium.make treats a render mode."""

    metadata = BaxterGymEnv.metadata
    observation_space = action_space = gymnasium.spaces.Discrete(1)

    def __init__(self, render_mode=None):
        self.render_mode = render_mode


def make_verdict(mode) -> str:
    """What gymnasium.make does with `mode` for an env of these render modes: 'refused'
    (it raises, or builds the env anyway with only a warning), 'wrapped' (it builds the env
    with another mode and wraps it) or 'accepted'."""
    spec = gymnasium.envs.registration.EnvSpec("Stub-v0", entry_point=_Stub)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            env = gymnasium.make(spec, render_mode=mode, disable_env_checker=True)
        except Exception:
            return "refused"
    if any("not in the possible render_modes" in str(w.message) for w in caught):
        return "refused"
    return "accepted" if env.unwrapped.render_mode == mode else "wrapped"


@pytest.mark.parametrize("mode", BAD_RENDER_MODES, ids=repr)
def test_the_adapter_refuses_the_render_modes_gymnasium_make_refuses(mode):
    """render_mode="rgb_aray" or "human" was taken and render() returned None, silently."""
    verdict = make_verdict(mode)
    assert verdict != "accepted"
    with pytest.raises(ValueError, match="'rgb_array'") as refused:
        BaxterGymEnv("transit", render_mode=mode)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gymnasium's own words on the mode
        if verdict == "wrapped":  # the error names the way that works, and it does
            assert f"gymnasium.make('MjxSkills/Transit-v0', render_mode={mode!r})" in str(
                refused.value
            )
            env = gymnasium.make(gym_id("transit"), render_mode=mode)
            assert env.render_mode == mode and env.unwrapped.render_mode == "rgb_array"
        else:
            with pytest.raises((ValueError, AttributeError)):
                gymnasium.make(gym_id("transit"), render_mode=mode)


def test_unknown_tasks_and_config_fields_list_the_valid_ones():
    """An unknown EnvConfig field was a TypeError from EnvConfig's constructor."""
    assert make_verdict("rgb_array") == make_verdict(None) == "accepted"
    assert BaxterGymEnv("transit", render_mode="rgb_array").render_mode == "rgb_array"
    with pytest.raises(ValueError, match="unknown task 'pick_mov'; valid: transit, grasp"):
        BaxterGymEnv("pick_mov")
    with pytest.raises(ValueError, match=r"unknown EnvConfig field\(s\) \['episode_len'\]; valid"):
        gymnasium.make(gym_id("transit"), episode_len=10)
    with pytest.raises(ValueError, match="episode_length"):  # the valid names are listed
        BaxterGymEnv("transit", episode_len=10)
    with pytest.raises(ValueError, match="steps native MuJoCo"):
        BaxterGymEnv("transit", physics="mjx")
    assert BaxterGymEnv("transit", physics="native").task.config.physics == "native"


# ---------------------------------------------------------------- rendering
class FakeRenderer:
    """mujoco.Renderer without OpenGL: keeps what each frame would draw."""

    def __init__(self, model, height, width):
        self.shape, self.drawn = (height, width, 3), []

    def update_scene(self, data, camera=-1):
        self.drawn.append((data.geom_xpos.copy(), data.mocap_pos.copy()))

    def render(self):
        return np.zeros(self.shape, np.uint8)

    def close(self):
        pass


def forwarded(model, data):
    """A fresh MjData at `data`'s joints and weld target, brought up to date by mj_forward."""
    fresh = mujoco.MjData(model)
    fresh.qpos[:], fresh.mocap_pos[:] = data.qpos, data.mocap_pos
    mujoco.mj_forward(model, fresh)
    return fresh


def test_render_draws_the_current_state_and_leaves_the_dynamics_alone(monkeypatch):
    """After reset a fresh env drew every body at the origin (a black frame) and a second
    episode drew the cube 0.279 m from where it was; after a step the arm lagged a substep."""
    monkeypatch.setattr(mujoco, "Renderer", FakeRenderer)
    drawn, plain = BaxterGymEnv("pick_move", render_mode="rgb_array"), BaxterGymEnv("pick_move")
    cube = drawn.model.geom("object").id
    actions = np.random.default_rng(1).uniform(-1, 1, (2, 6, 4)).astype(np.float32)
    for seed, episode in enumerate(actions):
        obs, _ = drawn.reset(seed=seed)
        expected, _ = plain.reset(seed=seed)
        for i in range(len(episode) + 1):
            assert drawn.render().shape == (480, 640, 3)
            geom_xpos, mocap_pos = drawn._renderer.drawn[-1]
            np.testing.assert_allclose(
                geom_xpos, forwarded(drawn.model, drawn.data).geom_xpos, atol=1e-9
            )
            adr = drawn.task.object_qpos_adr
            np.testing.assert_allclose(geom_xpos[cube], drawn.data.qpos[adr : adr + 3], atol=1e-6)
            # The sensors read the positions at the start of the last substep.
            np.testing.assert_allclose(geom_xpos[cube], obs["observation"][3:6], atol=1e-3)
            if i == 0:  # the weld's target is where reset held it: at the grip
                np.testing.assert_allclose(mocap_pos[0], obs["observation"][:3], atol=1e-6)
            for key in obs:  # drawing changed nothing the env computes
                np.testing.assert_array_equal(obs[key], expected[key])
            if i < len(episode):
                obs, *_ = drawn.step(episode[i])
                expected, *_ = plain.step(episode[i])


def test_a_renderer_that_cannot_start_is_a_clear_error_and_the_env_steps_on(monkeypatch):
    def no_gl(*args, **kwargs):
        raise mujoco.FatalError("an OpenGL platform library has not been loaded")

    monkeypatch.setattr(mujoco, "Renderer", no_gl)
    env, plain = BaxterGymEnv("transit", render_mode="rgb_array"), BaxterGymEnv("transit")
    obs, _ = env.reset(seed=2)
    expected, _ = plain.reset(seed=2)
    for _ in range(3):
        with pytest.raises(RuntimeError, match="MUJOCO_GL=egl") as failed:
            env.render()
        assert "has not been loaded" in str(failed.value)
        obs, *_ = env.step(np.full(4, 0.5, np.float32))
        expected, *_ = plain.step(np.full(4, 0.5, np.float32))
        np.testing.assert_array_equal(obs["observation"], expected["observation"])


GL_FRAMES = """
import json, mujoco, numpy as np
from mjx_skills.core import compile_cache
compile_cache.enable()
from mjx_skills.envs.gym import BaxterGymEnv
env = BaxterGymEnv("pick_move", render_mode="rgb_array")
try:
    reference = mujoco.Renderer(env.model, 480, 640)
except Exception as err:
    raise SystemExit("NO GL: " + str(err).splitlines()[0])
def frame_error():
    fresh = mujoco.MjData(env.model)
    fresh.qpos[:], fresh.mocap_pos[:] = env.data.qpos, env.data.mocap_pos
    mujoco.mj_forward(env.model, fresh)
    reference.update_scene(fresh)
    frame = env.render()
    return [int(np.abs(frame.astype(int) - reference.render()).max()), float(frame.std())]
errors = []
for seed in (0, 1):
    env.reset(seed=seed)
    errors.append(frame_error())
    for _ in range(4):
        env.step(np.array([0.5, -0.5, -1.0, 1.0], np.float32))
    errors.append(frame_error())
print(json.dumps(errors))
"""


def test_rendered_frames_are_the_frames_of_the_current_state():
    """With OpenGL (MuJoCo picks its backend on import: a fresh process per backend tried),
    each frame equals one drawn from a fresh MjData at the env's joints: the first was black."""
    import json
    import os
    import subprocess
    import sys

    for backend in ("egl", "osmesa", "glfw"):
        env = {**os.environ, "MUJOCO_GL": backend}
        command = [sys.executable, "-c", GL_FRAMES]
        run = subprocess.run(command, capture_output=True, text=True, timeout=300, env=env)
        if "NO GL" not in run.stderr:
            break
    else:
        pytest.skip("no OpenGL backend draws here")
    assert run.returncode == 0, run.stderr
    for worst, std in json.loads(run.stdout.splitlines()[-1]):
        assert worst == 0 and std > 10


@pytest.mark.parametrize("shape", [(7,), (2, 4), (), (3,)])
def test_an_action_of_another_shape_is_refused_naming_the_shape(shape):
    env = BaxterGymEnv("transit")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"this env takes one action of shape \(4,\)"):
        env.step(np.zeros(shape, np.float32))


def test_x64_is_refused_at_construction_and_at_reset():
    """The task logic runs in float32 as trained; under x64 it would run in float64."""
    env = BaxterGymEnv("transit")
    jax.config.update("jax_enable_x64", True)
    try:
        with pytest.raises(ValueError, match="float32"):
            BaxterGymEnv("transit")
        with pytest.raises(ValueError, match="float32"):
            env.reset(seed=0)
    finally:
        jax.config.update("jax_enable_x64", False)
    obs, _ = env.reset(seed=0)
    assert obs["observation"].dtype == np.float32
