"""Solvability: the scripted controllers solve every task and skill over 64 random episodes.

This is the proof that physics, start distributions and predicates allow the tasks.
"""

import jax
import pytest

from mjx_skills.envs import ENVS
from mjx_skills.envs.controllers import rollout_scripted

# Success of the scripted controllers measured on 64 episodes (seed 1); the bar is 90 %
# except where the closing note of issue 3 says why a task's script falls short.
REQUIRED = {name: 0.9 for name in ENVS}


@pytest.mark.parametrize("name", list(ENVS))
def test_scripted_controller_solves(name, env_factory):
    env = env_factory(name)
    final, _ = jax.jit(lambda k: rollout_scripted(env, k, 64))(jax.random.PRNGKey(1))
    rate = float(final.metrics["success"].mean())
    assert rate >= REQUIRED[name], f"{name}: scripted success {rate:.2f}"
