"""The library's three skills on the Fetch robot (issue #45): transit, grasp and transfer in
gymnasium-robotics' pick-and-place scene, for a skill library of Fetch (`make skills
ROBOT=fetch`) that serves `fetch_pick_and_place` (and any Fetch task with its block).

They are the Baxter skills' definitions (envs/skills.py) on Fetch: the same start conditions,
goals, goal parameters and stopping rules, in the box where Fetch's tasks put their objects
and goals (`skill_box`: within 15 cm in x and y of the grip's start, from the resting
block's centre up to 45 cm above it). A start with the grip at a chosen point, or with the
block in the fingers, is `FetchRobot.place`. Success is within 3 cm, as Baxter's skills (the
Fetch tasks' own threshold is 5 cm).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from mjx_skills.config import EnvConfig
from mjx_skills.core.types import State
from mjx_skills.envs.fetch_tasks import AIR_MAX, FetchPickAndPlace, refuse_unsupported
from mjx_skills.envs.skills import lerp

TRAINING_FIELDS = ("held_start_prob",)
"""EnvConfig fields of the Baxter scenes a Fetch skill honours: grasp trains with held starts
(`LibraryConfig.grasp_held_start_prob`)."""
GRIP_CLEARANCE = 0.02
"""A free grip starts at least this far (m) above the resting block's centre."""
FINGERTIPS = 0.05
"""How far (m) Fetch's closed fingertips reach below the grip: a free grip within
`NEAR_BLOCK` of the block in x and y starts at least this far above the block's centre,
so that no start presses the fingers into it (measured: closer, the block sinks into the
table; open fingers straddle a centred block from 2 cm, but not an offset one)."""
NEAR_BLOCK = 0.07


class FetchSkill(FetchPickAndPlace):
    """Base of the Fetch skills: pick-and-place's scene and robot, 20-step episodes, 3 cm
    success, starts drawn by `sample_start` -> (grip (3,), block (3,), goal (3,)) and placed
    by `FetchRobot.place` (with the block in the fingers for `grasped_start`, or, in
    training, with `EnvConfig.held_start_prob`; otherwise the fingers open or closed,
    `open_fingers_prob`)."""

    default_episode_length = 20
    default_threshold = 0.03
    grasped_start = False
    goal_is_object_skill = True
    """Whether the achieved goal is the block's position (else the grip's)."""
    open_fingers_prob = 0.5
    """Share of starts without the block in hand whose fingers are open; the others start
    closed, as Fetch's tasks do (a skill the search starts from a task's first state meets
    closed fingers)."""
    held_below = (0.0, 0.0)
    """How far (m) below the grip a block held at the start sits, uniform in this range."""
    near_clearance = FINGERTIPS
    """A free grip within NEAR_BLOCK of the block (x and y) starts at least this far (m) above
    the block's centre (0 for a skill whose start is at the block's side)."""
    param_dim: int
    state_dims: tuple[int, ...]
    memory_dims: tuple[int, ...]

    def __init__(self, config: EnvConfig | None = None):
        super().__init__(config)
        # The robot has the block; a transit skill's achieved goal is the grip.
        self.goal_is_object = self.goal_is_object_skill
        g = self.initial_gripper_xpos
        reach = self.obj_range
        self.box_low = jnp.array([g[0] - reach, g[1] - reach, self.height_offset])
        self.box_high = jnp.array([g[0] + reach, g[1] + reach, self.height_offset + AIR_MAX])

    @classmethod
    def check_config(cls, config: EnvConfig) -> None:
        """As every Fetch task's, except that held starts are allowed (TRAINING_FIELDS)."""
        default = EnvConfig()
        kept = dataclasses.replace(config, **{f: getattr(default, f) for f in TRAINING_FIELDS})
        refuse_unsupported(cls.__name__, kept, cls.scene)

    # ------------------------------------------------------------------ sampling
    def sample_box(self, key: jax.Array, low=None, high=None) -> jax.Array:
        """(3,) uniform in the skills' box (or [low, high])."""
        low = self.box_low if low is None else low
        high = self.box_high if high is None else high
        return jax.random.uniform(key, (3,), minval=low, maxval=high)

    def sample_on_table(self, key: jax.Array, low=None, high=None) -> jax.Array:
        """(3,) the block resting on the table, xy uniform in the box (or [low, high])."""
        low = self.box_low if low is None else low
        high = self.box_high if high is None else high
        xy = jax.random.uniform(key, (2,), minval=low[:2], maxval=high[:2])
        return jnp.concatenate([xy, jnp.array([self.height_offset])])

    def free_grip(self, key: jax.Array) -> jax.Array:
        """(3,) a grip start in the box, GRIP_CLEARANCE above the resting block's centre."""
        return self.sample_box(key, self.box_low.at[2].add(GRIP_CLEARANCE))

    def sample_start(self, key: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
        raise NotImplementedError

    def training_start(self, key, grip, block):
        """-> (grip, held): with `held_start_prob` (training only) the block starts closed in
        the fingers where it lies (fold_in: the other draws keep their keys)."""
        held = jnp.asarray(self.grasped_start)
        if self.config.held_start_prob > 0 and not self.grasped_start:
            held = jax.random.uniform(jax.random.fold_in(key, 7)) < self.config.held_start_prob
            grip = jnp.where(held, block, grip)
        return grip, held

    # ------------------------------------------------------------------ reset
    def reset(self, key: jax.Array) -> State:
        grip, block, goal = self.sample_start(key)
        grip, held = self.training_start(key, grip, block)
        near = jnp.linalg.norm(grip[:2] - block[:2]) < NEAR_BLOCK
        clear = jnp.maximum(grip[2], block[2] + self.near_clearance)
        grip = grip.at[2].set(jnp.where(near & ~held, clear, grip[2]))
        fingers_open = jax.random.uniform(jax.random.fold_in(key, 11)) < self.open_fingers_prob
        below = jax.random.uniform(jax.random.fold_in(key, 13), (), minval=0.0, maxval=1.0)
        below = self.held_below[0] + below * (self.held_below[1] - self.held_below[0])
        physics = self.robot.place(grip, block, held, fingers_open, below)
        return self.state_from(physics, goal)


class FetchTransit(FetchSkill):
    """Move the empty gripper to a 3-D target in the box within 3 cm (20 steps)."""

    goal_is_object_skill = False
    param_dim = 3
    state_dims = (0, 1, 2, 20, 21, 22)  # grip, grip velocity
    memory_dims = (0, 1, 2)

    def sample_start(self, key):
        k_grip, k_block, k_goal = jax.random.split(key, 3)
        return self.free_grip(k_grip), self.sample_on_table(k_block), self.free_grip(k_goal)

    def goal_from_param(self, param: jax.Array, obs: jax.Array) -> jax.Array:
        return lerp(param, self.box_low.at[2].add(GRIP_CLEARANCE), self.box_high)

    def terminated(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        return self.is_success(obs[..., self.layout["grip"]], goal)


class FetchGrasp(FetchSkill):
    """From 5-7 cm above the block (within 4 cm of it in x and y), grasp it and lift it
    5-8 cm (20 steps). Higher than Baxter's grasp starts (within 5 cm): Fetch's closed
    fingertips reach 5 cm below the grip (`FINGERTIPS`), so a transit that brings them
    closer presses them into the block (the search's `--search.transit-height` for
    Fetch: 0.05 to 0.07)."""

    param_dim = 1
    lift_range = (0.05, 0.08)
    start_height = (FINGERTIPS, 0.07)
    start_radius = 0.04
    state_dims = tuple(range(25))
    memory_dims = (0, 1, 2, 3, 4, 5, 9, 10)  # grip, block, fingers: positions only

    def sample_start(self, key):
        k_block, k_dz, k_r, k_a, k_h = jax.random.split(key, 5)
        block = self.sample_on_table(k_block)
        dz = jax.random.uniform(k_dz, (), minval=self.start_height[0], maxval=self.start_height[1])
        radius = self.start_radius * jnp.sqrt(jax.random.uniform(k_r, ()))
        angle = jax.random.uniform(k_a, (), minval=0.0, maxval=2 * jnp.pi)
        grip = block + jnp.stack([radius * jnp.cos(angle), radius * jnp.sin(angle), dz])
        lift = jax.random.uniform(k_h, (), minval=self.lift_range[0], maxval=self.lift_range[1])
        return grip, block, block + jnp.array([0.0, 0.0, 1.0]) * lift

    def goal_from_param(self, param: jax.Array, obs: jax.Array) -> jax.Array:
        lift = lerp(param[..., 0], *self.lift_range)
        zero = jnp.zeros_like(lift)
        return obs[..., self.layout["object"]] + jnp.stack([zero, zero, lift], axis=-1)

    def terminated(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        return self.is_success(obs[..., self.layout["object"]], goal)


class FetchTransfer(FetchSkill):
    """Carry the held block to a 3-D target in the box within 3 cm (20 steps)."""

    grasped_start = True
    param_dim = 3
    state_dims = tuple(range(25))
    memory_dims = FetchGrasp.memory_dims
    held_below = (0.0, 0.025)
    """As grasp leaves it: a grasp from above holds the block up to about 2.5 cm below the
    grip (measured on the search's grasps: 2 cm at the median)."""

    def object_goal_box(self) -> tuple[jax.Array, jax.Array]:
        """Where a held block's goal may lie: the box, from the resting block's height."""
        return self.box_low, self.box_high

    def sample_start(self, key):
        k_grip, k_goal = jax.random.split(key)
        grip = self.free_grip(k_grip)
        return grip, grip, self.sample_box(k_goal, *self.object_goal_box())

    def goal_from_param(self, param: jax.Array, obs: jax.Array) -> jax.Array:
        return lerp(param, *self.object_goal_box())

    def terminated(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """At the goal, or the block dropped (nothing left to transfer)."""
        return self.is_success(obs[..., self.layout["object"]], goal) | ~self.grasped(obs)


FETCH_SKILLS = {
    "fetch_transit": FetchTransit,
    "fetch_grasp": FetchGrasp,
    "fetch_transfer": FetchTransfer,
}
"""Registry names -> the Fetch skill envs (registered as skills by `skills.registry`)."""
