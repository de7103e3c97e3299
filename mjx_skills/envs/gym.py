"""Gymnasium goal-conditioned envs on native MuJoCo, for Stable-Baselines3 and friends.

Same XML, controller, start distributions, episode lengths and success predicates as the
JAX envs: physics steps in `mujoco.mj_step` on one MjData, and the task logic (reset,
action -> controls, sensors -> observation, reward) is the JAX env's own, called through
small jitted functions, so the two cannot drift apart.

    import gymnasium as gym, mjx_skills.envs.gym  # registers MjxSkills/<Task>-v0
    env = gym.make("MjxSkills/PickMove-v0")

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
from mjx_skills.envs.registry import BAXTER, FETCH, make

_IMPORT_PID = os.getpid()


def _check_not_forked() -> None:
    """JAX cannot run in a process forked from one where it started (its threads do not
    survive the fork: the first JAX call hangs). Fail at once, naming the fix."""
    if os.getpid() == _IMPORT_PID:
        return
    from jax._src import xla_bridge

    if xla_bridge.backends_are_initialized():
        raise RuntimeError(
            "BaxterGymEnv was created in a process forked after JAX had started, where JAX "
            "hangs; start worker processes with 'spawn': gymnasium.make_vec(..., "
            "vectorization_mode='async', vector_kwargs={'context': 'spawn'}), "
            "SubprocVecEnv(..., start_method='spawn'), or multiprocessing.get_context('spawn')"
        )


def _check_render_mode(task: str, mode: object) -> None:
    """ValueError for a render mode this env cannot honour when built directly.

    gymnasium.make passes any other mode to the constructor with only a warning (and fails
    on a non-string), so refusing it here makes both ways of building the env refuse it.
    'human' and 'rgb_array_list' gymnasium.make accepts by building the env with 'rgb_array'
    and wrapping it (HumanRendering, RenderCollection): built directly, nothing would wrap
    it and render() would return None without a word, so they are refused, naming the way
    that works."""
    modes = BaxterGymEnv.metadata["render_modes"]
    if mode is None or (isinstance(mode, str) and mode in modes):
        return
    listed = isinstance(mode, str) and mode.endswith("_list") and mode[: -len("_list")] in modes
    if mode == "human" or listed:
        wrapper = "HumanRendering" if mode == "human" else "RenderCollection"
        raise ValueError(
            f"render_mode={mode!r}: this env draws offscreen only ({modes}); "
            f"gymnasium.make({gym_id(task)!r}, render_mode={mode!r}) wraps it in "
            f"gymnasium.wrappers.{wrapper}, or wrap it yourself: gymnasium.wrappers.{wrapper}"
            "(BaxterGymEnv(..., render_mode='rgb_array'))"
        )
    raise ValueError(
        f"render_mode={mode!r} is not a render mode of this env; valid: None, "
        + ", ".join(repr(m) for m in modes)
        + " (and through gymnasium.make: 'human', 'rgb_array_list')"
    )


class BaxterGymEnv(gymnasium.Env):
    """One Baxter task as a gymnasium goal env. `config`: EnvConfig fields (e.g.
    episode_length=10); the env truncates its episodes after the task's episode length
    itself, with or without gymnasium's TimeLimit. An unknown task, EnvConfig field or
    render mode is a ValueError listing the valid ones (`_check_render_mode` says why
    'human' is refused here but accepted by gymnasium.make)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 7}

    def __init__(self, task: str = "pick_move", render_mode: str | None = None, **config):
        _check_not_forked()
        require_float32()  # the JAX env's task logic as trained: float32, never float64
        if task in FETCH:
            raise ValueError(
                f"{task}: the gym adapter hosts the Baxter envs only; gymnasium-robotics' own "
                f"{FETCH[task].__name__}-v4 is the Fetch task as a gymnasium env"
            )
        _check_render_mode(task, render_mode)
        if config.pop("physics", "native") != "native":
            raise ValueError("physics: the gym adapter steps native MuJoCo; leave it unset")
        self.task = make(task, EnvConfig(physics="native"), **config)
        self.model = self.task.model
        self.data = mujoco.MjData(self.model)
        self.render_mode = render_mode
        self._renderer = None
        self._drawn = None  # the MjData render() draws: a copy of `data`, forwarded
        t = self.task
        self._reset = jax.jit(t.reset)
        # One jitted call before and one after the substeps: each call from Python pays a
        # dispatch, so the step's task logic is grouped into as few calls as possible.
        self._plan = jax.jit(self._plan_fn)
        self._observe = jax.jit(self._observe_fn)
        self._reward = jax.jit(t.compute_reward)
        obs_box = spaces.Box(-np.inf, np.inf, (t.obs_dim,), np.float32)
        goal_box = spaces.Box(-np.inf, np.inf, (t.goal_dim,), np.float32)
        self.observation_space = spaces.Dict(
            {"observation": obs_box, "achieved_goal": goal_box, "desired_goal": goal_box}
        )
        self.action_space = spaces.Box(-1.0, 1.0, (t.action_dim,), np.float32)
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
        require_float32()  # x64 switched on after the env was built
        super().reset(seed=seed)
        # options={"jax_key": key} starts from exactly what the JAX env's reset(key) does.
        if options and "jax_key" in options:
            key = jnp.asarray(options["jax_key"])
        else:
            key = jax.random.PRNGKey(int(self.np_random.integers(2**31)))
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
        action = np.asarray(action, np.float32)  # sanitised as the JAX env does, in _plan
        if action.shape != self.action_space.shape:
            raise ValueError(
                f"action of shape {action.shape}; this env takes one action of shape "
                f"{self.action_space.shape} (a batch is a vector env's)"
            )
        grip = np.asarray(self.data.sensordata[self.task.sensor_slices["grip_pos"]], np.float32)
        ctrl, path = self._plan(grip, action)
        self.data.qacc_warmstart[:] = 0.0  # each step starts cold, as mujoco.rollout does
        self._substeps(np.asarray(ctrl), np.asarray(path))
        obs, reward = self._obs()
        self._steps += 1
        truncated = self._steps >= self.task.episode_length
        return obs, reward, False, truncated, {"is_success": reward == 0.0}

    def compute_reward(self, achieved_goal, desired_goal, info):
        """Vectorised sparse reward (0 success, -1 otherwise) over leading batch axes."""
        return np.asarray(
            self._reward(jnp.asarray(achieved_goal), jnp.asarray(desired_goal)), np.float32
        )

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            self._renderer = self._make_renderer()
            self._drawn = mujoco.MjData(self.model)
        # The state is drawn from a copy brought up to date by mj_forward: reset's
        # mj_setState leaves the positions stale (a fresh env drew a black frame, a later
        # reset the cube 0.28 m from where it was) and after mj_step they lag a substep.
        # mj_forward on `data` itself would recompute the sensors that the next step reads.
        mujoco.mj_copyData(self._drawn, self.model, self.data)
        mujoco.mj_forward(self.model, self._drawn)
        self._renderer.update_scene(self._drawn)
        return self._renderer.render()

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


def gym_id(task: str) -> str:
    return "MjxSkills/" + "".join(part.capitalize() for part in task.split("_")) + "-v0"


# No max_episode_steps: the env truncates after its own episode length, which a user's
# episode_length=... changes (a TimeLimit fixed at registration would not follow it).
# The Baxter envs only: the adapter replays their mocap path and sensors; the Fetch tasks
# are gymnasium-robotics' own envs already (FetchReach-v4, ...).
for _name in BAXTER:
    if gym_id(_name) not in gymnasium.registry:
        gymnasium.register(
            gym_id(_name), "mjx_skills.envs.gym:BaxterGymEnv", kwargs={"task": _name}
        )
