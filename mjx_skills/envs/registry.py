"""One registry of every env: `make(name, **config_overrides)`."""

from __future__ import annotations

import dataclasses

from mjx_skills.config import EnvConfig
from mjx_skills.core.types import GoalEnv
from mjx_skills.envs.baxter import BaxterEnv
from mjx_skills.envs.fetch_tasks import FETCH_TASKS, FetchTask
from mjx_skills.envs.skills import Grasp, Transfer, Transit
from mjx_skills.envs.tasks import ContainerWall, PickMove, PutInContainer, PutOn, TakeOut
from mjx_skills.envs.two_objects import PickMoveTwo, TwoInContainer

BAXTER: dict[str, type[BaxterEnv]] = {
    "transit": Transit,
    "grasp": Grasp,
    "transfer": Transfer,
    "pick_move": PickMove,
    "put_in_container": PutInContainer,
    "put_on": PutOn,
    "take_out": TakeOut,
    "container_wall": ContainerWall,
    "pick_move_two": PickMoveTwo,
    "two_in_container": TwoInContainer,
}
"""The Baxter skills and tasks: what the skill library, its methods and the gym adapter serve."""
FETCH: dict[str, type[FetchTask]] = dict(FETCH_TASKS)
"""gymnasium-robotics' Fetch tasks (envs/fetch_tasks.py): flat methods (ddpg_her) only."""
ENVS: dict[str, type] = {**BAXTER, **FETCH}
SKILLS = ("transit", "grasp", "transfer")
TASKS = ("pick_move", "put_in_container", "put_on", "take_out", "container_wall",
         "pick_move_two", "two_in_container")  # fmt: skip


def check_name(name: str) -> None:
    if name not in ENVS:
        raise ValueError(f"unknown task {name!r}; valid: {', '.join(ENVS)}")


def make(name: str, config: EnvConfig | None = None, **overrides) -> GoalEnv:
    """Build env `name` from `config` (default EnvConfig) with field overrides."""
    check_name(name)
    config = config or EnvConfig()
    fields = {f.name for f in dataclasses.fields(EnvConfig)}
    unknown = set(overrides) - fields
    if unknown:
        raise ValueError(f"unknown EnvConfig field(s) {sorted(unknown)}; valid: {sorted(fields)}")
    return ENVS[name](dataclasses.replace(config, **overrides))
