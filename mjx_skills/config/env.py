"""The envs' settings (`--env.*`) and the names of backends and libraries."""

from __future__ import annotations

import dataclasses
import typing
from typing import Literal

from mjx_skills.config.checks import _check, check_numbers

Physics = Literal["auto", "native", "mjx"]
PHYSICS = typing.get_args(Physics)  # the backends (`envs.physics.make_backend`), named once
Library = Literal["SL1", "SL2", "SL3"]
LIBRARIES = typing.get_args(Library)
"""The thesis's skill libraries by name (their skills, and yours: `skills.registry.LIBRARIES`)."""


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    """Simulation and control settings shared by every Baxter env."""

    physics: Physics = "auto"
    """Physics backend: 'native' (MuJoCo C via mujoco.rollout, the CPU default), 'mjx'
    (accelerators) or 'auto' (native on a CPU, mjx on a GPU/TPU)."""
    timestep: float = 0.005
    """Physics timestep in s. The thesis uses 0.002 x 75 substeps; a held cube stays put at
    0.005 s (tests/envs/test_physics.py) and 2.5x fewer substeps make every env step cheaper."""
    n_substeps: int = 30
    """Substeps per env step: 0.005 s x 30 = 0.15 s, the thesis's control period."""
    solver_iterations: int = 20
    """Solver iterations (MuJoCo's default: 100; 20 converge for a four-contact grasp)."""
    ls_iterations: int = 10
    """Line-search iterations of the solver."""
    action_scale: float = 0.05
    """End-effector displacement in m for an action of 1 (thesis: 5 cm)."""
    settle_substeps: int = 40
    """Substeps a reset lets the weld carry the gripper from home to its start (0.2 s)."""
    grasp_settle_substeps: int = 30
    """Substeps a reset closes the fingers for tasks that start with the cube held."""
    posture_stiffness: float = 5.0
    """Stiffness (N m / rad) of the weak joint springs toward the home posture (they keep
    the redundant arm out of joint limits)."""
    max_qvel: float = 100.0
    """A joint speed above this (or a NaN) counts as diverged physics: the env is reset."""
    native_threads: int = 0
    """Threads of the native backend's rollout pool; 0 = one per core."""
    episode_length: int = 0
    """Env steps per episode; 0 = the task's default from the thesis."""
    distance_threshold: float = 0.0
    """Success tolerance in m; 0 = the task's default (3 cm for most tasks)."""
    held_start_prob: float = 0.0
    """Share of training resets starting with the cube closed in the fingers where it lies
    (the original code trains grasp with 0.5, HER's trick); evaluation never does."""
    goal_start_prob: float = 0.0
    """Share of training resets of several-cube tasks with one cube (whose goal rests on a
    surface) starting at its goal: a reverse curriculum (Florensa et al. 2017). Evaluation
    never does; one-cube tasks refuse it."""
    object_reward: bool = False
    """Several cubes: the step-wise sparse reward (Li et al. 2020), minus the share of cubes
    not at their goals (-1, -0.5, 0), instead of -1 until all are. Success is unchanged."""
    single_goal: bool = False
    """One desired goal for every episode, the mean of the task's goal distribution: the
    thesis's PAS baseline after its reference [21] (docs/results.md). Off: the thesis's."""

    def __post_init__(self) -> None:
        check_numbers(self)
        _check(self.timestep > 0, "timestep", "must be > 0")
        for name in (
            "n_substeps",
            "solver_iterations",
            "ls_iterations",
            "settle_substeps",
            "grasp_settle_substeps",
        ):
            _check(getattr(self, name) >= 1, name, "must be >= 1")
        _check(self.action_scale > 0, "action_scale", "must be > 0")
        for name in ("held_start_prob", "goal_start_prob"):
            _check(0.0 <= getattr(self, name) <= 1.0, name, "must lie in [0, 1]")
        _check(self.max_qvel > 0, "max_qvel", "must be > 0")

    def for_evaluation(self) -> EnvConfig:
        """This config without its training-only starts (held, goal): evaluation's."""
        return dataclasses.replace(self, held_start_prob=0.0, goal_start_prob=0.0)
