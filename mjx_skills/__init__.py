"""mjx_skills: skill-library reinforcement learning on a simulated Baxter arm in JAX + MuJoCo.

Importing the package has no side effects; the CLI and the tests switch on JAX's persistent
compilation cache (`mjx_skills.core.compile_cache.enable`).
"""

__version__ = "0.2.0"
