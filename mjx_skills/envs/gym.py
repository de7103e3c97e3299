"""Gymnasium goal-conditioned envs on native MuJoCo, for Stable-Baselines3 and friends.

Same XML, controller, start distributions, episode lengths and success predicates as the
JAX envs: physics steps in `mujoco.mj_step` on one MjData, and the task logic (reset,
action -> controls, sensors -> observation, reward) is the JAX env's own, called through
small jitted functions, so the two cannot drift apart.

    import gymnasium as gym, mjx_skills.envs.gym  # registers MjxSkills/<Task>-v0
    env = gym.make("MjxSkills/PickMove-v0")
    env = gym.make("MjxSkills/FetchPickAndPlace-v0")  # envs/gym_fetch.py

`GoalGymEnv` is what both adapters share (construction and its refusals, spaces, seeding,
the batched reward, drawing); `BaxterGymEnv` replays a Baxter task's mocap path on a host
MjData, `gym_fetch.FetchGymEnv` calls a Fetch task's own jitted reset and step.

Built on the mujoco bindings directly: gymnasium-robotics 1.4.2's MuJoCo base fails to
load models under mujoco 4.0.0 (an assertion on joint types).
"""

from __future__ import annotations

import os
import warnings

import gymnasium
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from gymnasium import spaces

from mjx_skills.config import EnvConfig
from mjx_skills.core.precision import require_float32
from mjx_skills.envs.baxter import smooth_path
from mjx_skills.envs.registry import BAXTER, ENVS, FETCH, make

_IMPORT_PID = os.getpid()


def _check_not_forked(cls: type) -> None:
    """JAX cannot run in a process forked from one where it started (its threads do not
    survive the fork: the first JAX call hangs). Fail at once, naming the fix."""
    if os.getpid() == _IMPORT_PID:
        return
    from jax._src import xla_bridge

    if xla_bridge.backends_are_initialized():
        raise RuntimeError(
            f"{cls.__name__} was created in a process forked after JAX had started, where JAX "
            "hangs; start worker processes with 'spawn': gymnasium.make_vec(..., "
            "vectorization_mode='async', vector_kwargs={'context': 'spawn'}), "
            "SubprocVecEnv(..., start_method='spawn'), or multiprocessing.get_context('spawn')"
        )


def _check_render_mode(cls: type, task: str, mode: object) -> None:
    """ValueError for a render mode this env cannot honour when built directly.

    gymnasium.make passes any other mode to the constructor with only a warning (and fails
    on a non-string), so refusing it here makes both ways of building the env refuse it.
    'human' and 'rgb_array_list' gymnasium.make accepts by building the env with 'rgb_array'
    and wrapping it (HumanRendering, RenderCollection): built directly, nothing would wrap
    it and render() would return None without a word, so they are refused, naming the way
    that works."""
    modes = cls.metadata["render_modes"]
    if mode is None or (isinstance(mode, str) and mode in modes):
        return
    listed = isinstance(mode, str) and mode.endswith("_list") and mode[: -len("_list")] in modes
    if mode == "human" or listed:
        wrapper = "HumanRendering" if mode == "human" else "RenderCollection"
        raise ValueError(
            f"render_mode={mode!r}: this env draws offscreen only ({modes}); "
            f"gymnasium.make({gym_id(task)!r}, render_mode={mode!r}) wraps it in "
            f"gymnasium.wrappers.{wrapper}, or wrap it yourself: gymnasium.wrappers.{wrapper}"
            f"({cls.__name__}(..., render_mode='rgb_array'))"
        )
    raise ValueError(
        f"render_mode={mode!r} is not a render mode of this env; valid: None, "
        + ", ".join(repr(m) for m in modes)
        + " (and through gymnasium.make: 'human', 'rgb_array_list')"
    )


class GoalGymEnv(gymnasium.Env):
    """What the adapters share: one task of `family` (registry name -> class) as a
    gymnasium goal env with Dict observations (observation (obs_dim,), achieved_goal and
    desired_goal (goal_dim,), float32) and actions (action_dim,) in [-1, 1]. `config`:
    EnvConfig fields (e.g. episode_length=10); the env truncates its episodes after the
    task's episode length itself, with or without gymnasium's TimeLimit. A task of another
    family, an unknown task, EnvConfig field or render mode is a ValueError listing the
    valid ones (`_check_render_mode` says why 'human' is refused here but accepted by
    gymnasium.make). Subclasses set `family`, `other` (the adapter of the other family)
    and `_draw_state`."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 7}
    family: dict[str, type] = {}
    other = ""

    def __init__(self, task: str, render_mode: str | None = None, **config):
        _check_not_forked(type(self))
        require_float32()  # the JAX env's task logic as trained: float32, never float64
        if task in ENVS and task not in self.family:
            raise ValueError(
                f"{task}: {type(self).__name__} hosts {', '.join(self.family)}; {self.other}"
            )
        _check_render_mode(type(self), task, render_mode)
        if config.pop("physics", "native") != "native":
            raise ValueError("physics: the gym adapter steps native MuJoCo; leave it unset")
        self.task = make(task, EnvConfig(physics="native"), **config)
        self.model = self.task.model
        self.render_mode = render_mode
        self._renderer = None
        self._drawn = None  # the MjData render() draws: brought up to date, then forwarded
        t = self.task
        self._reward = jax.jit(t.compute_reward)
        obs_box = spaces.Box(-np.inf, np.inf, (t.obs_dim,), np.float32)
        goal_box = spaces.Box(-np.inf, np.inf, (t.goal_dim,), np.float32)
        self.observation_space = spaces.Dict(
            {"observation": obs_box, "achieved_goal": goal_box, "desired_goal": goal_box}
        )
        self.action_space = spaces.Box(-1.0, 1.0, (t.action_dim,), np.float32)

    def _action(self, action) -> np.ndarray:
        """`action` as float32 (action_dim,), or ValueError naming its shape and the one
        this env takes (NaN and out-of-range values the JAX env sanitises itself)."""
        action = np.asarray(action, np.float32)
        if action.shape != self.action_space.shape:
            raise ValueError(
                f"action of shape {action.shape}; this env takes one action of shape "
                f"{self.action_space.shape} (a batch is a vector env's)"
            )
        return action

    def _start_key(self, seed: int | None, options: dict | None) -> jax.Array:
        """The JAX key of the episode's reset: options={"jax_key": key} starts from exactly
        what the JAX env's reset(key) does; otherwise a draw of the env's np_random, which
        reset(seed=...) seeds (the same seed, the same episode)."""
        require_float32()  # x64 switched on after the env was built
        super().reset(seed=seed)
        if options and "jax_key" in options:
            return jnp.asarray(options["jax_key"])
        return jax.random.PRNGKey(int(self.np_random.integers(2**31)))

    def compute_reward(self, achieved_goal, desired_goal, info):
        """Vectorised sparse reward (0 success, -1 otherwise), float32 of the leading batch
        axes of achieved_goal and desired_goal (..., goal_dim); `info` is not read."""
        return np.asarray(
            self._reward(jnp.asarray(achieved_goal), jnp.asarray(desired_goal)), np.float32
        )

    def render(self):
        """(480, 640, 3) uint8 of the current state with render_mode='rgb_array', else None;
        RuntimeError naming MUJOCO_GL where no OpenGL context can be made."""
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            self._renderer = self._make_renderer()
            self._drawn = mujoco.MjData(self.model)
        # The state is drawn from a copy brought up to date by mj_forward: a state vector
        # set by mj_setState leaves the positions stale (a fresh env drew a black frame, a
        # later reset the cube 0.28 m from where it was) and after mj_step they lag a
        # substep. mj_forward on the env's own MjData would recompute the sensors it reads.
        self._draw_state(self._drawn)
        mujoco.mj_forward(self.model, self._drawn)
        view = getattr(self.task, "render_view", None)
        camera = -1 if view is None else _free_camera(view)
        self._renderer.update_scene(self._drawn, camera=camera)
        return self._renderer.render()

    def _draw_state(self, drawn: mujoco.MjData) -> None:
        """Put the env's current state (joints and weld target) into `drawn`."""
        raise NotImplementedError

    def _make_renderer(self):
        """mujoco.Renderer, or a RuntimeError naming MUJOCO_GL; the env steps on either way."""
        try:
            with warnings.catch_warnings():  # glfw also warns what the error below says
                warnings.simplefilter("ignore")
                return mujoco.Renderer(self.model, 480, 640)
        except Exception as err:  # noqa: BLE001 - each GL backend fails in its own way
            why = (str(err).strip().splitlines() or [type(err).__name__])[0]
            gl = os.environ.get("MUJOCO_GL", "")
            raise RuntimeError(
                f"render(): no OpenGL context could be made (MUJOCO_GL={gl!r}: {why}); without "
                "a display set MUJOCO_GL=egl (or osmesa) before mujoco is first imported, "
                "e.g. MUJOCO_GL=egl python ...; the env still steps"
            ) from err

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _free_camera(view: dict) -> mujoco.MjvCamera:
    """A free camera at `view` (lookat, distance, azimuth, elevation: a task's render_view)."""
    camera = mujoco.MjvCamera()
    camera.lookat[:] = view["lookat"]
    camera.distance, camera.azimuth, camera.elevation = (
        view["distance"],
        view["azimuth"],
        view["elevation"],
    )
    return camera


class BaxterGymEnv(GoalGymEnv):
    """One Baxter task as a gymnasium goal env (`GoalGymEnv`): physics steps in
    `mujoco.mj_step` on one host MjData, the task logic is the JAX env's own."""

    family = BAXTER
    other = "the Fetch tasks are FetchGymEnv's (envs/gym_fetch.py, MjxSkills/Fetch*-v0)"

    def __init__(self, task: str = "pick_move", render_mode: str | None = None, **config):
        super().__init__(task, render_mode, **config)
        self.data = mujoco.MjData(self.model)
        t = self.task
        self._reset = jax.jit(t.reset)
        # One jitted call before and one after the substeps: each call from Python pays a
        # dispatch, so the step's task logic is grouped into as few calls as possible.
        self._plan = jax.jit(self._plan_fn)
        self._observe = jax.jit(self._observe_fn)
        self._goal = np.zeros(t.goal_dim, np.float32)
        self._steps = 0

    # ------------------------------------------------------------------ physics
    def _plan_fn(self, grip: jax.Array, action: jax.Array) -> tuple[jax.Array, jax.Array]:
        """-> finger controls and the mocap path (n_substeps, 3) of the JAX env's step."""
        ctrl, target = self.task.action_to_controls(grip, self.task.sanitize_action(action)[0])
        return ctrl, smooth_path(grip, target, self.task.config.n_substeps)

    def _observe_fn(self, sensordata: jax.Array, goal: jax.Array):
        """-> observation, achieved goal and reward from the sensors, as the JAX env."""
        sensors = self.task.sensors(sensordata)
        achieved = self.task.achieved_goal(sensors)
        return self.task.observation(sensors), achieved, self.task.compute_reward(achieved, goal)

    def _substeps(self, ctrl, mocap_path) -> None:
        self.data.ctrl[:] = ctrl
        for mocap_pos in mocap_path:
            self.data.mocap_pos[0] = mocap_pos
            mujoco.mj_step(self.model, self.data)

    # ------------------------------------------------------------------ gymnasium API
    def _obs(self) -> tuple[dict[str, np.ndarray], float]:
        """-> (goal-env observation, reward)."""
        obs, achieved, reward = self._observe(
            np.asarray(self.data.sensordata, np.float32), self._goal
        )
        return {
            "observation": np.asarray(obs, np.float32),
            "achieved_goal": np.asarray(achieved, np.float32),
            "desired_goal": self._goal.copy(),
        }, float(reward)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        key = self._start_key(seed, options)
        # The JAX env's own (jitted, native-backend) reset places arm and cube; its state
        # vector and sensors are loaded into this MjData.
        state = self._reset(key)
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        mujoco.mj_setState(self.model, self.data, np.asarray(state.physics.data, np.float64), spec)
        self.data.sensordata[:] = np.asarray(state.physics.sensordata)
        # The state vector has no mocap: the weld's target is where reset held it, at the
        # grip (each step sets it before every substep, so only a drawn frame reads this).
        self.data.mocap_pos[0] = self.data.sensordata[self.task.sensor_slices["grip_pos"]]
        self._goal = np.asarray(state.desired_goal, np.float32)
        self._steps = 0
        obs, reward = self._obs()
        return obs, {"is_success": reward == 0.0}

    def step(self, action):
        action = self._action(action)  # sanitised as the JAX env does, in _plan
        grip = np.asarray(self.data.sensordata[self.task.sensor_slices["grip_pos"]], np.float32)
        ctrl, path = self._plan(grip, action)
        self.data.qacc_warmstart[:] = 0.0  # each step starts cold, as mujoco.rollout does
        self._substeps(np.asarray(ctrl), np.asarray(path))
        obs, reward = self._obs()
        self._steps += 1
        truncated = self._steps >= self.task.episode_length
        return obs, reward, False, truncated, {"is_success": reward == 0.0}

    def _draw_state(self, drawn: mujoco.MjData) -> None:
        mujoco.mj_copyData(drawn, self.model, self.data)


def gym_id(task: str) -> str:
    """Registry name -> gym id: 'pick_move' -> 'MjxSkills/PickMove-v0',
    'fetch_push' -> 'MjxSkills/FetchPush-v0'."""
    return "MjxSkills/" + "".join(part.capitalize() for part in task.split("_")) + "-v0"


# No max_episode_steps: the env truncates after its own episode length, which a user's
# episode_length=... changes (a TimeLimit fixed at registration would not follow it).
# The Fetch ids stand beside gymnasium-robotics' own (FetchPickAndPlace-v4, ...).
_ENTRY_POINTS = {
    **dict.fromkeys(BAXTER, "mjx_skills.envs.gym:BaxterGymEnv"),
    **dict.fromkeys(FETCH, "mjx_skills.envs.gym_fetch:FetchGymEnv"),
}
for _name, _entry_point in _ENTRY_POINTS.items():
    if gym_id(_name) not in gymnasium.registry:
        gymnasium.register(gym_id(_name), _entry_point, kwargs={"task": _name})
