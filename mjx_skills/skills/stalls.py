"""Obstacles the coarse models never saw, remembered where the arm stalled
(`--search.stall-memory`).

The skills' coarse dynamics models are learned in empty skill envs, so they predict that a
transfer carries the cube straight through the container_wall task's tall wall (thesis
Fig. 6.5). A search on those models plans the same blocked transfer again and again. The
explorer corrects them online, within each episode: when a moving skill (transit,
transfer) stops moving short of its goal, the point `stall_ahead` m beyond the gripper
towards that goal is remembered as an obstacle, and the search prunes every moving edge
whose straight segment from its node's gripper to its goal passes within `stall_radius` of
a remembered obstacle. Together with waypoint transfer goals (`--search.waypoint-share`)
the search then finds paths round the obstacle. Off by default (the thesis has neither).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_skills.skills import registry

EMPTY = 1e3
"""Coordinate of an empty memory slot: far from every segment."""


def empty(n: int, size: int) -> jax.Array:
    """(n, size, 3): no obstacle remembered."""
    return jnp.full((n, size, 3), EMPTY)


def moving(names: tuple[str, ...], skill: jax.Array) -> jax.Array:
    """skill (...) int32 -> (...) bool: the skill travels in a straight line to its goal
    (`registry.Skill.moves`: transit and transfer; grasp only closes and lifts)."""
    return jnp.array([registry.get(name).moves for name in names])[skill]


def segment_distance(points: jax.Array, start: jax.Array, end: jax.Array) -> jax.Array:
    """Distance of points (..., M, 3) from the segments start -> end (..., 3): (..., M)."""
    d = (end - start)[..., None, :]
    rel = points - start[..., None, :]
    t = jnp.clip(jnp.sum(rel * d, -1) / jnp.maximum(jnp.sum(d * d, -1), 1e-12), 0.0, 1.0)
    return jnp.linalg.norm(rel - t[..., None] * d, axis=-1)


def blocked(
    obstacles: jax.Array,
    names: tuple[str, ...],
    skill: jax.Array,
    grip: jax.Array,
    goal: jax.Array,
    radius: float,
) -> jax.Array:
    """Edges (skill (R,), gripper position (R, 3), goal (R, 3)) of a moving skill whose path
    passes within `radius` of one of their env's obstacles (R, M, 3): (R,) bool."""
    near = segment_distance(obstacles, grip, goal) < radius
    return moving(names, skill) & jnp.any(near, axis=-1)


def stalled(
    names: tuple[str, ...],
    skill: jax.Array,
    grip: jax.Array,
    last_grip: jax.Array,
    goal: jax.Array,
    active: jax.Array,
    steps: jax.Array,
    step_m: float,
    margin: float,
) -> jax.Array:
    """(B,) bool: a running moving skill moved its gripper (B, 3) less than `step_m` in its
    last step while still farther than `margin` from its goal (a skill settling onto its
    goal is not an obstacle)."""
    still = jnp.linalg.norm(grip - last_grip, axis=-1) < step_m
    far = jnp.linalg.norm(goal - grip, axis=-1) > margin
    return active & (steps >= 2) & moving(names, skill) & still & far


def remember(
    obstacles: jax.Array,
    count: jax.Array,
    grip: jax.Array,
    goal: jax.Array,
    stall: jax.Array,
    ahead: float,
) -> tuple[jax.Array, jax.Array]:
    """Write the point `ahead` m from grip (B, 3) towards goal (B, 3) into the ring buffer
    obstacles (B, M, 3) of the envs that stalled (B,); returns (obstacles, count)."""
    direction = goal - grip
    length = jnp.maximum(jnp.linalg.norm(direction, axis=-1, keepdims=True), 1e-9)
    point = grip + ahead * direction / length
    slot = jax.nn.one_hot(count % obstacles.shape[1], obstacles.shape[1], dtype=bool)
    write = stall[:, None] & slot
    return jnp.where(write[..., None], point[:, None], obstacles), count + stall
