"""The push library's skills on the Fetch robot (issue #45): approach and push, for a skill
library that serves `fetch_push`, whose fingers are blocked closed so that grasp and
transfer cannot serve it (`make skills ROBOT=fetch SKILL_LIBRARY=SL_fetch_push`).

- **approach**: transit (move the gripper to a 3-D target within 3 cm) in FetchPush's scene,
  a skill of its own so that the search can propose its goals behind the block, opposite
  the task's goal (`skills.registry`), where transit's goals lie above the block.
- **push**: in FetchPush's scene, from `BEHIND` behind the block's centre (opposite the
  push), the grip at most `PUSH_HEIGHT[1]` above the centre, push the block along the table
  to a goal `PUSH_RANGE` away within 3 cm (20 steps). Its two goal parameters are the
  push's (x, y) offset from the block, times `REACH`.

The grip at the block's centre height pushes it as FetchPush's scripted controller does
(`envs.fetch_scripted.push`, which solves FetchPush here).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_skills.envs.fetch_scripted import BLOCK_HALF
from mjx_skills.envs.fetch_skills import FetchGrasp, FetchSkill, FetchTransit
from mjx_skills.envs.fetch_tasks import FetchPush

REACH = 0.15
"""How far (m) in x and in y one push may carry the block (its goal parameters' scale)."""
PUSH_RANGE = (0.05, 0.15)
"""How far (m) a push's training goal lies from the block, along the push."""
BEHIND = BLOCK_HALF + 0.045
"""How far (m, in x and y) behind the block's centre the grip starts, opposite the push: 4.5 cm
from its near face. The closed fingers reach 3 cm to either side of the grip, so at 3 cm (where
the scripted push lines up) a push across them starts in contact and moves the block while
the start is placed (measured: up to 3.5 cm)."""
PUSH_HEIGHT = (0.0, 0.02)
"""How far (m) above the block's centre the grip starts, uniform: from the centre's height
(where the scripted push pushes) to the lowest goal of approach (transit's box floor,
`fetch_skills.GRIP_CLEARANCE`)."""

RAISE = 0.08
"""How far (m) above a push's start approach goes first where the grip is not yet over it
(`LINE_UP`): the closed fingertips reach 5 cm below the grip, so from PUSH_HEIGHT's top + RAISE
they pass over the block's top (BLOCK_HALF above its centre) instead of knocking it."""
LINE_UP = 0.05
"""How close (m, in x and y) to a push's start the grip must be for approach to go down to it
(`skills.registry`'s proposer of approach); farther, approach goes RAISE above it first."""

APPROACH_NOISE = 1 / 3
"""Approach's goals scatter this share of `SearchConfig.object_goal_noise` in x and y (1 cm at
the default): at 3 cm, each new approach chased a goal 3 cm off and push never started."""
LATERAL = 0.02
"""How far (m) across the push a training start's grip may lie off the line through the
block's centre, uniform: approach ends within 3 cm of its goal, so push meets such starts."""
COLLECT_ALIGNED = 0.5
"""Share of push's data-collection runs whose goal lies along the grip's line through the
block (within COLLECT_TURN), as the search asks pushes after approach; the others draw the
goal parameters uniformly (pushes sideways and backwards, which fail: the classifier's
negatives). All uniform, 86 % of the collected pushes failed (`collection_param`)."""
COLLECT_TURN = jnp.pi / 4
"""Largest angle (rad) between an aligned collection push and the grip's line to the block."""


class _PushScene:
    """FetchPush's scene, whose fingers are blocked closed, for a Fetch skill: both skills of
    the push library share it (a library's data collection starts each skill from the
    others' starts, `skills.fit.make_collect`, so its skills share one scene)."""

    scene = FetchPush.scene
    initial_qpos = FetchPush.initial_qpos
    block_gripper = True
    gripper_extra_height = FetchPush.gripper_extra_height
    target_in_the_air = False
    open_fingers_prob = 0.0


class FetchApproach(_PushScene, FetchTransit):
    """Move the gripper to a 3-D target in the box within 3 cm (20 steps): transit in
    FetchPush's scene, trained as its own skill so that its goals are proposed behind the
    block. Its box reaches BEHIND further than the block's range in x and y, so that a
    push's start behind a block at the range's edge is one of its goals; the block is drawn
    in the block's range (`table_low`, `table_high`)."""

    def __init__(self, config=None):
        super().__init__(config)
        margin = jnp.array([BEHIND, BEHIND, 0.0])
        self.table_low, self.table_high = self.box_low, self.box_high
        self.box_low, self.box_high = self.box_low - margin, self.box_high + margin

    def sample_on_table(self, key: jax.Array) -> jax.Array:
        return super().sample_on_table(key, self.table_low, self.table_high)


class FetchPushBlock(_PushScene, FetchSkill):
    """From BEHIND behind the block's centre at PUSH_HEIGHT (LATERAL off its line), push the
    block along the table to a goal 5-15 cm away within 3 cm (20 steps), in FetchPush's
    scene: fingers blocked."""

    near_clearance = 0.0
    param_dim = 2
    state_dims = tuple(range(25))
    memory_dims = FetchGrasp.memory_dims

    def sample_start(self, key):
        k_block, k_angle, k_distance, k_height, k_side = jax.random.split(key, 5)
        block = self.sample_on_table(k_block)
        angle = jax.random.uniform(k_angle, (), minval=0.0, maxval=2 * jnp.pi)
        way = jnp.stack([jnp.cos(angle), jnp.sin(angle), jnp.zeros(())])
        distance = jax.random.uniform(k_distance, (), minval=PUSH_RANGE[0], maxval=PUSH_RANGE[1])
        height = jax.random.uniform(k_height, (), minval=PUSH_HEIGHT[0], maxval=PUSH_HEIGHT[1])
        side = jax.random.uniform(k_side, (), minval=-LATERAL, maxval=LATERAL)
        across = jnp.stack([-way[1] * side, way[0] * side, height])
        return block - BEHIND * way + across, block, block + distance * way

    def collection_param(self, key: jax.Array, obs: jax.Array) -> jax.Array:
        """key, obs (n, obs_dim) -> (n, 2) goal parameters for the library's data collection:
        COLLECT_ALIGNED of them a push PUSH_RANGE long along the grip's line through the block
        (turned by at most COLLECT_TURN), the others uniform in [-1, 1]."""
        k_which, k_turn, k_distance, k_any = jax.random.split(key, 4)
        n = obs.shape[0]
        away = obs[:, self.layout["object"]] - obs[:, self.layout["grip"]]
        turn = jax.random.uniform(k_turn, (n,), minval=-COLLECT_TURN, maxval=COLLECT_TURN)
        angle = jnp.arctan2(away[:, 1], away[:, 0]) + turn
        distance = jax.random.uniform(k_distance, (n,), minval=PUSH_RANGE[0], maxval=PUSH_RANGE[1])
        aligned = (distance / REACH)[:, None] * jnp.stack([jnp.cos(angle), jnp.sin(angle)], -1)
        anywhere = jax.random.uniform(k_any, (n, 2), minval=-1.0, maxval=1.0)
        return jnp.where(jax.random.uniform(k_which, (n, 1)) < COLLECT_ALIGNED, aligned, anywhere)

    def goal_from_param(self, param: jax.Array, obs: jax.Array) -> jax.Array:
        offset = REACH * jnp.clip(param[..., :2], -1.0, 1.0)
        flat = jnp.concatenate([offset, jnp.zeros_like(offset[..., :1])], axis=-1)
        return obs[..., self.layout["object"]] + flat

    def terminated(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        return self.is_success(obs[..., self.layout["object"]], goal)


FETCH_PUSH_SKILLS = {"fetch_approach": FetchApproach, "fetch_push_block": FetchPushBlock}
"""Registry names -> the push library's skill envs (registered as skills by `skills.registry`)."""
