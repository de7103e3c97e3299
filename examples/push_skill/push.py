"""A skill of your own, registered from outside the package: push the cube along the table to
a goal up to 15 cm away (20 steps), on the Baxter robot and its pick_move scene.

    python -m mjx_skills.build_library --import examples/push_skill/push.py --out DIR
    python -m mjx_skills.train ddpg_her_sl --import examples/push_skill/push.py \\
        --task pick_move --search.library SL_push --search.library-dir DIR

The first command builds a library of the four Baxter skills (the thesis's three and push):
push is trained, its data collected and its coarse model and classifier fitted exactly as
the others'. The second explores pick_move by look-ahead search over all four; the search
proposes push goals on the table towards the task's goal (`propose_push`). `--task push`
trains the skill alone. (docs/extending.md, "Adding a skill"; tests/skills/test_skill_plugins.py
runs it.)
"""

import jax
import jax.numpy as jnp

from mjx_skills.envs.baxter import OBS_FINGERS, OBS_GRIP, OBS_OBJECT, BaxterEnv
from mjx_skills.envs.skills import OBJECT_REGION
from mjx_skills.skills.registry import Skill, register_library, register_skill

REACH = 0.15
"""How far (m) a push may carry the cube along the table."""
BEHIND = 0.06
"""How far (m) behind the cube, opposite the push, the gripper starts."""


class Push(BaxterEnv):
    """From 6 cm behind the cube at its height, push it along the table to a goal 5-15 cm
    away within 3 cm (20 steps). Goal parameters: the push's (x, y) offset in [-1, 1],
    times REACH."""

    default_episode_length = 20
    param_dim = 2
    state_dims = tuple(range(25))
    memory_dims = (
        tuple(range(25))[OBS_GRIP] + tuple(range(25))[OBS_OBJECT] + tuple(range(25))[OBS_FINGERS]
    )

    def sample_start(self, key):
        k_obj, k_angle, k_dist = jax.random.split(key, 3)
        obj = self.sample_on_table(k_obj, *OBJECT_REGION)
        angle = jax.random.uniform(k_angle, (), minval=0.0, maxval=2 * jnp.pi)
        way = jnp.stack([jnp.cos(angle), jnp.sin(angle), 0.0])
        distance = jax.random.uniform(k_dist, (), minval=0.05, maxval=REACH)
        return obj - BEHIND * way, obj, obj + distance * way

    def goal_from_param(self, param, obs):
        offset = REACH * jnp.clip(param[..., :2], -1.0, 1.0)
        return obs[..., OBS_OBJECT] + jnp.concatenate([offset, jnp.zeros_like(offset[..., :1])], -1)

    def terminated(self, obs, goal):
        return self.is_success(obs[..., OBS_OBJECT], goal)


def propose_push(env, cfg, edges):
    """The search's push goals: from the cube towards the task's goal on the table, at most
    REACH, with the edges' noise (`--search.object-goal-noise`) added in x and y."""
    obj = edges.obs[:, None, env.layout["object"]]  # (N, 1, 3)
    toward = (edges.task_goal[:, None] - obj) * jnp.array([1.0, 1.0, 0.0])
    length = jnp.linalg.norm(toward, axis=-1, keepdims=True)
    step = toward * jnp.minimum(1.0, REACH / jnp.maximum(length, 1e-6))
    noise = cfg.object_goal_noise * edges.noise * jnp.array([1.0, 1.0, 0.0])
    return obj + step + noise


register_skill(Skill(name="push", env=Push, propose=propose_push, start="empty", moves=True))
register_library("SL_push", ("transit", "grasp", "transfer", "push"))
