"""mjx_skills: skill-library reinforcement learning on a simulated Baxter arm in JAX + MuJoCo."""

from mjx_skills import compile_cache

compile_cache.enable()

__version__ = "0.1.0"
