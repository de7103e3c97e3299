"""The Fetch tasks (`envs/fetch_tasks.py`) as gymnasium goal envs: `MjxSkills/FetchReach-v0`,
`MjxSkills/FetchPush-v0`, `MjxSkills/FetchSlide-v0` and `MjxSkills/FetchPickAndPlace-v0`,
registered by `import mjx_skills.envs.gym` beside gymnasium-robotics' own FetchReach-v4, ...

    import gymnasium as gym, mjx_skills.envs.gym
    env = gym.make("MjxSkills/FetchPickAndPlace-v0")

One env whose reset and step are the JAX env's own, jitted (`FetchTask.reset(key)`,
`FetchTask.step(state, action)`: native MuJoCo in a host callback), so an episode is the
JAX env's episode from the same key, and the JAX env equals gymnasium-robotics' step for
step (`tests/envs/test_fetch.py`). What it shares with the Baxter adapter (construction and its
refusals, spaces, seeding, the batched reward, drawing) is `gym.GoalGymEnv`.
"""

from __future__ import annotations

import gymnasium
import jax
import mujoco
import numpy as np

from mjx_skills.envs.gym import GoalGymEnv
from mjx_skills.envs.registry import FETCH


class FetchGymEnv(GoalGymEnv):
    """One Fetch task ('fetch_reach', 'fetch_push', 'fetch_slide', 'fetch_pick_and_place')
    as a gymnasium goal env (`gym.GoalGymEnv`): observation (25,) (Reach (10,)), goals (3,)
    in m, actions (4,) in [-1, 1] (NaN acts as 0, the rest is clipped, as in the JAX env);
    reward 0 within 5 cm of the goal, else -1; info["is_success"] is gymnasium-robotics'
    success (distance < threshold: at exactly the threshold the reward is 0 and success
    False). Episodes truncate after 50 steps (episode_length=... changes it); none ends
    by termination. EnvConfig fields of the Baxter scenes, or physics other than native,
    are a ValueError (`fetch_tasks.refuse_unsupported`)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 25}
    family = FETCH
    other = "the Baxter tasks are BaxterGymEnv's (envs/gym.py)"

    def __init__(
        self, task: str = "fetch_pick_and_place", render_mode: str | None = None, **config
    ):
        super().__init__(task, render_mode, **config)
        self._reset = jax.jit(self.task.reset)
        self._step = jax.jit(self.task.step)
        self.state = None
        """The JAX env's State of the current episode (None before the first reset)."""

    def _result(self) -> tuple[dict[str, np.ndarray], dict]:
        state = self.state
        obs = {
            "observation": np.asarray(state.obs, np.float32),
            "achieved_goal": np.asarray(state.achieved_goal, np.float32),
            "desired_goal": np.asarray(state.desired_goal, np.float32),
        }
        return obs, {"is_success": bool(state.metrics["success"])}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """-> (observation dict, info). options={"jax_key": key} starts from the JAX env's
        reset(key); otherwise reset(seed=s) starts the same episode for the same s."""
        self.state = self._reset(self._start_key(seed, options))
        return self._result()

    def step(self, action):
        """action (4,) -> (observation dict, reward, terminated False, truncated, info);
        gymnasium.error.ResetNeeded before the first reset."""
        if self.state is None:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        self.state = self._step(self.state, self._action(action))
        obs, info = self._result()
        return obs, float(self.state.reward), False, bool(self.state.done), info

    def _draw_state(self, drawn: mujoco.MjData) -> None:
        if self.state is None:  # before the first reset: the model's default pose
            mujoco.mj_resetData(self.model, drawn)
            return
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        physics = np.asarray(self.state.physics.data, np.float64)
        mujoco.mj_setState(self.model, drawn, physics, spec)
        # The state vector has no mocap: the weld's target is drawn at the gripper body.
        sensed = np.asarray(self.state.physics.sensordata, np.float64)
        drawn.mocap_pos[0] = sensed[self.task.robot.sensor_slices["hand_pos"]]
