"""One registry of every robot and every env: `make(name, **config_overrides)`, the robot a
task declares (`robot_of`), the tasks of a robot (`tasks_of`)."""

from __future__ import annotations

import dataclasses

from mjx_skills.config import EnvConfig
from mjx_skills.core.types import GoalEnv
from mjx_skills.envs.baxter import BaxterEnv, BaxterRobot
from mjx_skills.envs.fetch import FetchRobot
from mjx_skills.envs.fetch_push_skills import FETCH_PUSH_SKILLS
from mjx_skills.envs.fetch_skills import FETCH_SKILLS
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
"""gymnasium-robotics' Fetch tasks (envs/fetch_tasks.py); the library methods run them with
a library of the Fetch skills (`FETCH_SKILLS`)."""
ENVS: dict[str, type] = {**BAXTER, **FETCH, **FETCH_SKILLS, **FETCH_PUSH_SKILLS}
"""Every env by name: Baxter's skills and tasks, Fetch's tasks and Fetch's skills
(`envs/fetch_skills.py`, the skill library of Fetch; `envs/fetch_push_skills.py`, its push
library's)."""
ROBOTS: dict[str, type] = {BaxterRobot.name: BaxterRobot, FetchRobot.name: FetchRobot}
"""Robot name -> its class, an `envs.robot.Robot` (each task declares one: `robot_name`)."""
TASKS = (
    "pick_move",
    "put_in_container",
    "put_on",
    "take_out",
    "container_wall",
    "pick_move_two",
    "two_in_container",
)

"""The Baxter tasks (the skills' envs are registered with their skills: `skills.registry`)."""


def check_name(name: str) -> None:
    """ValueError naming the valid tasks if `name` is not one."""
    if name not in ENVS:
        raise ValueError(
            f"unknown task {name!r}; valid: {', '.join(ENVS)} (a task of your own: pass the "
            "module that registers it with --import MODULE or MJX_SKILLS_IMPORT)"
        )


def check_robot(name: str) -> None:
    """ValueError naming the valid robots if `name` is not one."""
    if name not in ROBOTS:
        raise ValueError(f"unknown robot {name!r}; valid: {', '.join(ROBOTS)}")


def robot_of(task: str) -> str:
    """The name of the robot task `task` declares ('baxter', 'fetch'); ValueError naming the
    valid tasks for an unknown one."""
    check_name(task)
    return ENVS[task].robot_name


def tasks_of(robot: str) -> tuple[str, ...]:
    """The tasks (and skills) of robot `robot`, in registry order; ValueError naming the
    valid robots for an unknown one."""
    check_robot(robot)
    return tuple(name for name, cls in ENVS.items() if cls.robot_name == robot)


def make(name: str, config: EnvConfig | None = None, **overrides) -> GoalEnv:
    """Build env `name` from `config` (default EnvConfig) with field overrides."""
    check_name(name)
    config = config or EnvConfig()
    fields = {f.name for f in dataclasses.fields(EnvConfig)}
    unknown = set(overrides) - fields
    if unknown:
        raise ValueError(f"unknown EnvConfig field(s) {sorted(unknown)}; valid: {sorted(fields)}")
    return ENVS[name](dataclasses.replace(config, **overrides))


def register_task(name: str, cls: type) -> None:
    """Add task `name` to the registry, as the package's own: `make`, `--task`, sweeps and
    experiment files see it. `cls` is built from an `EnvConfig` and declares `robot_name`,
    a registered robot (a Baxter task subclasses `envs.baxter.BaxterEnv`, e.g. a task of
    `envs.tasks`; docs/extending.md). Call it from your own module and pass the module to
    the commands with `--import` (`core.plugins`). ValueError, naming what is wrong, for a
    name already taken, not a name, or an unknown robot."""
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"task name {name!r}: letters, digits and _ (a Python identifier)")
    if name in ENVS:
        raise ValueError(
            f"task {name!r} is registered already ({ENVS[name].__qualname__}); choose another name"
        )
    check_robot(getattr(cls, "robot_name", None))
    ENVS[name] = cls


def register_robot(cls: type) -> None:
    """Add a robot (an `envs.robot.Robot` class with a `name`) to `ROBOTS`, so that tasks
    declaring it can be registered. ValueError for a name already taken."""
    name = getattr(cls, "name", None)
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"robot {cls!r}: its `name` must be an identifier, got {name!r}")
    if name in ROBOTS:
        raise ValueError(f"robot {name!r} is registered already ({ROBOTS[name].__qualname__})")
    ROBOTS[name] = cls
