"""Goal-conditioned envs on two physics backends (MJX and native MuJoCo), each a task of a
robot (`envs.robot.Robot`): the Baxter scenes and gymnasium-robotics' Fetch tasks (native
only)."""

from mjx_skills.envs.registry import (
    BAXTER,
    ENVS,
    FETCH,
    ROBOTS,
    TASKS,
    make,
    register_robot,
    register_task,
    robot_of,
    tasks_of,
)

__all__ = [
    "BAXTER",
    "ENVS",
    "FETCH",
    "ROBOTS",
    "TASKS",
    "make",
    "register_robot",
    "register_task",
    "robot_of",
    "tasks_of",
]
