"""A task of your own, registered from outside the package: lift the cube 10 cm straight up
from where it rests (50 steps), on the Baxter robot and its pick_move scene.

    python -m mjx_skills.train ddpg_her --import examples/lift_task/lift.py --task lift
    python -m mjx_skills.sweep --import examples/lift_task/lift.py --tasks lift --methods ddpg_her

(docs/extending.md, "Adding a task"; tests/core/test_plugins.py runs it.)
"""

import jax
import jax.numpy as jnp

from mjx_skills.envs.registry import register_task
from mjx_skills.envs.tasks import PickMove

LIFT = 0.10
"""How far above its resting place the goal is (m)."""


class Lift(PickMove):
    """PickMove's scene, starts and success (within 3 cm of the goal), with the goal 10 cm
    straight above the cube's start."""

    def sample_start(self, key):
        k_grip, k_obj = jax.random.split(key)
        obj = self.sample_object(k_obj)
        return self.sample_workspace(k_grip), obj, obj + jnp.array([0.0, 0.0, LIFT])


register_task("lift", Lift)
