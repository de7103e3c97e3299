"""Goal-conditioned envs on two physics backends (MJX and native MuJoCo): the Baxter scenes
and gymnasium-robotics' Fetch tasks (native only)."""

from mjx_skills.envs.registry import BAXTER, ENVS, FETCH, SKILLS, TASKS, make

__all__ = ["BAXTER", "ENVS", "FETCH", "SKILLS", "TASKS", "make"]
