"""Baxter goal-conditioned envs on two physics backends (MJX and native MuJoCo)."""

from mjx_skills.envs.registry import ENVS, SKILLS, TASKS, make

__all__ = ["ENVS", "SKILLS", "TASKS", "make"]
