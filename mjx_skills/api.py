"""Trained policies from Python: load a run, act in its env, evaluate, render.

    import jax
    from mjx_skills.api import load

    policy = load(RUN_DIR)                    # the run's last checkpoint, trained seed 0
    policy.success(episodes=20)               # its eval success on 20 fresh episodes
    key = jax.random.PRNGKey(0)
    state = policy.reset(key, n=8)            # 8 envs: a batched env State
    memory = policy.init(key, n=8)            # per-env memory (the skill in flight, ...)
    memory, action = policy.act(memory, key, state)  # (8, action_dim), one jitted program
    state = policy.step(state, action)

`act` is the method's deterministic evaluation behaviour (`Learner.evaluate`), the one the
trainer evaluates: the DDPG actor for DDPG+HER, the actor or the critic's pick among the
library's proposals for DDPG+HER+SL+Fast, the meta-controller and its skills for PAS and
MPAS. It reads the whole env State (a skill acts on the scene, not only on the
observation), and it is pure: `jax.jit` or `jax.lax.scan` it with the env's `step`.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path
from typing import Any

import jax
import numpy as np

from mjx_skills.core import plugins
from mjx_skills.core.precision import use_float32
from mjx_skills.evaluate import TrainedRun, evaluate_jax, load_trained, seed_agent
from mjx_skills.training.epoch import compiler_options


@dataclasses.dataclass(frozen=True)
class Policy:
    """One trained seed of a run, ready to act in the run's env (`load`)."""

    run: TrainedRun
    seed: int
    """Which trained seed acts (0 .. seeds - 1)."""

    @property
    def env(self) -> Any:
        """The run's task env (a `GoalEnv`), with evaluation starts."""
        return self.run.env

    @property
    def epoch(self) -> int:
        """The epoch of the checkpoint the policy was restored from."""
        return self.run.epoch

    def _jit(self, fn):
        return jax.jit(fn, compiler_options=compiler_options(self.env))

    # Built once per policy: each jitted function compiles once per input shape.
    @functools.cached_property
    def _behaviour(self):
        return self.run.learner.evaluate(seed_agent(self.run, self.seed), self.run.aux)

    @functools.cached_property
    def _act(self):
        return self._jit(self._behaviour.step)

    @functools.cached_property
    def _reset(self):
        return self._jit(jax.vmap(self.env.reset))

    @functools.cached_property
    def _step(self):
        return self._jit(jax.vmap(self.env.step))

    def reset(self, key: jax.Array, n: int) -> Any:
        """`n` fresh episodes' start states (a batched env State; key -> n reset keys)."""
        return self._reset(jax.random.split(key, n))

    def init(self, key: jax.Array, n: int) -> Any:
        """The policy's memory for `n` envs at the start of their episodes."""
        return self._behaviour.init(key, n)

    def act(self, memory: Any, key: jax.Array, state: Any) -> tuple[Any, jax.Array]:
        """(memory, batched env State) -> (memory, actions (n, action_dim) in [-1, 1])."""
        memory, action, _ = self._act(memory, key, state)
        return memory, action

    def step(self, state: Any, action: jax.Array) -> Any:
        """One env step of every env: (batched State, actions (n, action_dim)) -> State."""
        return self._step(state, action)

    def success(self, episodes: int = 20, key: jax.Array | None = None) -> float:
        """Share of `episodes` fresh episodes (from `key`, default PRNGKey(0)) that this seed
        solves, success read at the last step as the trainer's evaluation."""
        key = jax.random.PRNGKey(0) if key is None else key
        success, _ = evaluate_jax(self.run, key, episodes)
        return float(success[self.seed])

    def render(
        self, key: jax.Array | None = None, episodes: int = 1, width: int = 480, height: int = 360
    ) -> np.ndarray:
        """Frames (episodes x (T + 1), height, width, 3) uint8 of `episodes` evaluation
        episodes, drawn by MuJoCo's offscreen renderer with each episode's goal marked
        (`mjx_skills.render`; needs an OpenGL backend: `MUJOCO_GL=egl` or `osmesa`)."""
        from mjx_skills.render import DEFAULT_VIEW, draw_frames, record_episodes

        key = jax.random.PRNGKey(0) if key is None else key
        qpos, grip, _, goals = record_episodes(self.run, key, episodes, self.seed)
        view = getattr(self.env, "render_view", DEFAULT_VIEW)
        return draw_frames(self.env.model, qpos, grip, width, height, None, view, goals)


def load(run_dir: str | Path, seed: int = 0, physics: str = "native") -> Policy:
    """The policy of trained seed `seed` of the run in `run_dir` (a directory
    `python -m mjx_skills.train` wrote), restored from its newest checkpoint without writing
    anything; `physics` ('native' or 'mjx') is the backend its env steps on.
    A run of a task of your own needs the module that registers it: set MJX_SKILLS_IMPORT
    (`core.plugins`) before calling. FileNotFoundError: not a run or no checkpoint;
    ValueError: a seed the run did not train."""
    use_float32()
    plugins.load_all()  # a run of a task of your own: MJX_SKILLS_IMPORT names its module
    run = load_trained(Path(run_dir), physics=physics)
    seeds = run.args.train.seeds
    if not 0 <= seed < seeds:
        raise ValueError(f"seed {seed}: the run trained seeds 0..{seeds - 1}")
    return Policy(run, seed)
