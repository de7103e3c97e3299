"""Scripted controllers of the Fetch tasks: simple state machines on the observation (the
state is read from it at every step, nothing is remembered), in JAX. They show the tasks
solvable in this physics (`tests/envs/test_fetch.py` requires 90 % success over 64 episodes)
and drive the contact-rich episodes the parity tests replay in gymnasium-robotics.

Each is policy(obs (..., obs_dim), goal (..., 3)) -> action (..., 4) in [-1, 1]: the
first three move the mocap target by up to 5 cm from the gripper body, so an action of
(target - grip) / 5 cm carries the grip point to the target.
"""

from __future__ import annotations

import jax.numpy as jnp

from mjx_skills.envs.fetch import ACTION_SCALE

OPEN, CLOSE = 1.0, -1.0
BLOCK_HALF = 0.025
"""Half the block's side (pick_and_place.xml, push.xml)."""
CLEARANCE = 0.06
"""Height above the block's centre at which the gripper travels to it."""


def toward(grip: jnp.ndarray, target: jnp.ndarray, gripper, speed: float = 1.0) -> jnp.ndarray:
    """The action that moves the grip point to `target`, at most `speed` x 5 cm per axis."""
    move = jnp.clip((target - grip) / ACTION_SCALE, -speed, speed)
    return jnp.concatenate([move, jnp.broadcast_to(gripper, move.shape[:-1])[..., None]], -1)


def reach(obs: jnp.ndarray, goal: jnp.ndarray) -> jnp.ndarray:
    return toward(obs[..., 0:3], goal, 0.0)


def first(cases: list[tuple[jnp.ndarray, jnp.ndarray]], default: jnp.ndarray) -> jnp.ndarray:
    """Per row, the action of the first (condition, action) case whose condition holds."""
    out = default
    for condition, action in reversed(cases):
        out = jnp.where(condition[..., None], action, out)
    return out


def push(obs: jnp.ndarray, goal: jnp.ndarray) -> jnp.ndarray:
    """Lift, travel above the point behind the block (seen from the goal), descend, then push
    at half speed along the line through the block's centre, stopping 2 cm from the goal."""
    grip, block = obs[..., 0:3], obs[..., 3:6]
    to_goal = goal[..., :2] - block[..., :2]
    distance = jnp.linalg.norm(to_goal, axis=-1)
    u = to_goal / jnp.maximum(distance, 1e-6)[..., None]
    behind_xy = block[..., :2] - u * (BLOCK_HALF + 0.03)
    rel = grip[..., :2] - block[..., :2]
    along = jnp.sum(rel * u, axis=-1)
    lateral = jnp.abs(rel[..., 0] * u[..., 1] - rel[..., 1] * u[..., 0])
    z = block[..., 2:3]
    in_line = (grip[..., 2] < z[..., 0] + 0.02) & (along < -BLOCK_HALF) & (lateral < 0.015)
    # Pushing: aim just inside the block's near face, at most 2 cm past where it is now.
    push_xy = block[..., :2] - u * (BLOCK_HALF + 0.005) + u * jnp.minimum(distance, 0.02)[..., None]
    cases = [
        (in_line & (distance < 0.02), toward(grip, grip, 0.0)),
        (in_line, toward(grip, jnp.concatenate([push_xy, z], -1), 0.0, speed=0.5)),
        (
            jnp.linalg.norm(grip[..., :2] - behind_xy, axis=-1) < 0.01,
            toward(grip, jnp.concatenate([behind_xy, z], -1), 0.0),
        ),
        (
            grip[..., 2] > z[..., 0] + CLEARANCE - 0.015,
            toward(grip, jnp.concatenate([behind_xy, z + CLEARANCE], -1), 0.0),
        ),
    ]
    lift = toward(grip, jnp.concatenate([grip[..., :2], z + CLEARANCE], -1), 0.0)
    return first(cases, lift)


def pick_and_place(obs: jnp.ndarray, goal: jnp.ndarray) -> jnp.ndarray:
    """Open above the block, descend, close, carry it to the goal closed."""
    grip, block, rel = obs[..., 0:3], obs[..., 3:6], obs[..., 6:9]
    gap = jnp.sum(obs[..., 9:11], axis=-1)
    xy_near = jnp.linalg.norm(rel[..., :2], axis=-1) < 0.01
    at_block = xy_near & (jnp.abs(rel[..., 2]) < 0.01)
    cases = [
        (at_block & (gap < 2 * BLOCK_HALF + 0.004), toward(grip, goal, CLOSE)),
        (at_block, toward(grip, block, CLOSE)),
        (xy_near, toward(grip, block, OPEN)),
    ]
    return first(cases, toward(grip, block + jnp.array([0.0, 0.0, CLEARANCE]), OPEN))


def transit(obs: jnp.ndarray, goal: jnp.ndarray) -> jnp.ndarray:
    """The empty gripper, open, straight to the goal."""
    return toward(obs[..., 0:3], goal, OPEN)


def transfer(obs: jnp.ndarray, goal: jnp.ndarray) -> jnp.ndarray:
    """The held block straight to the goal, closed: the grip aims where the block, at its
    offset in the fingers, is at the goal."""
    return toward(obs[..., 0:3], goal - obs[..., 6:9], CLOSE)


SCRIPTED = {
    "fetch_reach": reach,
    "fetch_push": push,
    "fetch_pick_and_place": pick_and_place,
    "fetch_transit": transit,
    "fetch_grasp": pick_and_place,  # its goal: the block lifted where it lies
    "fetch_transfer": transfer,
    "fetch_approach": transit,
    "fetch_push_block": push,
}
"""Registry name -> scripted controller (FetchSlide has none: a shot that stops a puck
on a low-friction table within 5 cm is no simple state machine). The Fetch skills
(`envs/fetch_skills.py`) are pick and place's parts; the push library's
(`envs/fetch_push_skills.py`) are transit and FetchPush's push."""
