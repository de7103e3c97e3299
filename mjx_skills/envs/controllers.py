"""Scripted controllers: move above, descend, close, lift, carry, (detour,) release.

They prove that the physics and predicates allow every task (tests/envs/test_solvable.py) and
serve as baselines and demos. Stateless: each action is a pure function of (obs, goal),
so they vmap and run inside the same jitted rollouts as the learned policies.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from mjx_skills.core import rollout
from mjx_skills.envs.baxter import OBS_GRIP, OBS_OBJECT, OBS_REL, BaxterEnv
from mjx_skills.envs.tasks import ContainerWall, PutInContainer, TakeOut
from mjx_skills.envs.two_objects import TwoObjects

OPEN, CLOSE = 1.0, -1.0
APPROACH_HEIGHT = 0.035  # grip above the cube's centre before descending: pads clear its top


def _toward(env: BaxterEnv, grip: jax.Array, target: jax.Array, gripper: jax.Array) -> jax.Array:
    delta = jnp.clip((target - grip) / env.config.action_scale, -1.0, 1.0)
    return jnp.concatenate([delta, jnp.reshape(gripper, (1,))])


def _detour(env: BaxterEnv, grip: jax.Array, target: jax.Array) -> jax.Array:
    """ContainerWall: to cross the tall wall's line (y = -0.28) go round its end (x < 0.55),
    out to 8 cm past the line before heading for the target (a held cube is 4 cm wide)."""
    wall_y, pass_x, margin, safe_z = -0.28, 0.505, 0.06, env.table_z + 0.14
    going_down = target[1] < wall_y  # toward -y, where the container is
    crossing = jnp.where(going_down, grip[1] > wall_y - margin, grip[1] < wall_y + margin)
    past_y = jnp.where(going_down, wall_y - margin - 0.02, wall_y + margin + 0.02)
    beside = jnp.where(
        grip[0] > pass_x + 0.01,
        jnp.array([pass_x, grip[1], safe_z]),
        jnp.array([pass_x, past_y, safe_z]),
    )
    return jnp.where(crossing, beside, target)


def _carry_target(env: BaxterEnv, obs: jax.Array, goal: jax.Array, place: bool) -> jax.Array:
    """Grip target that brings the held cube to the goal (the cube may sit off-centre in
    the grip); place tasks carry above the walls first and then descend."""
    offset = obs[OBS_REL]
    if place:
        safe = jnp.array([goal[0], goal[1], jnp.maximum(goal[2], env.table_z + 0.14)])
        far = jnp.linalg.norm(obs[OBS_OBJECT][:2] - goal[:2]) > 0.015
        goal = jnp.where(far, safe, goal)
    return goal - offset


def make_scripted_policy(
    env: BaxterEnv, slots: jax.Array | None = None
) -> Callable[[jax.Array, jax.Array], jax.Array]:
    """-> policy(obs (25,), goal (3,)) -> action (4,) for `env`'s task; `slots` (2, 3): a
    two-cube task's offsets of each cube's place from its goal (default `CONTAINER_SLOTS` in
    the container, none elsewhere)."""
    if not env.goal_is_object:  # transit: go straight to the goal, fingers open

        def transit(obs, goal):
            return _toward(env, obs[OBS_GRIP], goal, jnp.asarray(OPEN))

        return transit
    if isinstance(env, TwoObjects):
        return _two_cubes(env, slots)
    place = isinstance(env, PutInContainer) and not isinstance(env, TakeOut)
    return _pick_place(env, place, detour=isinstance(env, ContainerWall))


def _pick_place(env: BaxterEnv, place: bool, detour: bool):
    """-> policy(one-cube obs (25,), goal (3,)): grasp the cube, carry it to the goal and,
    if `place`, lower it there and let go."""

    def policy(obs: jax.Array, goal: jax.Array) -> jax.Array:
        grip, obj = obs[OBS_GRIP], obs[OBS_OBJECT]
        held = env.grasped(obs)
        # --- reach and grasp
        # Approach at the current height (or higher), then descend straight down: no
        # sweeping through walls or over the cube with the fingers low.
        above = jnp.array([obj[0], obj[1], jnp.maximum(obj[2] + APPROACH_HEIGHT, grip[2])])
        aligned = jnp.linalg.norm(obj[:2] - grip[:2]) < 0.008
        at_object = aligned & (grip[2] - obj[2] < 0.006)
        reach = jnp.where(aligned, obj, above)
        reach_gripper = jnp.where(at_object, CLOSE, OPEN)
        # --- carry (and release when placed)
        carry = _carry_target(env, obs, goal, place)
        placed = (jnp.linalg.norm(obj[:2] - goal[:2]) < 0.012) & (jnp.abs(obj[2] - goal[2]) < 0.012)
        release = place & placed
        carry_gripper = jnp.where(release, OPEN, CLOSE)
        target = jnp.where(held, carry, reach)
        gripper = jnp.where(held, carry_gripper, reach_gripper)
        # once released on the goal: back off upwards with the fingers open
        done = release & ~held
        target = jnp.where(done, grip + jnp.array([0.0, 0.0, 0.05]), target)
        gripper = jnp.where(done, OPEN, gripper)
        if detour:
            target = _detour(env, grip, target)
        return _toward(env, grip, target, gripper)

    return policy


CONTAINER_SLOTS = jnp.array([[0.0, -0.025, 0.0], [0.0, 0.025, 0.0]])
"""Where the script puts each cube in the container, from its centre: side by side."""


def _two_cubes(env: TwoObjects, slots: jax.Array | None):
    """The blue cube first (placed: on its table goal, or in the container), then, once the
    open fingers are clear above it, the red one (pick_move_two: held at its goal in the
    air; two_in_container: placed beside it)."""
    container = isinstance(env, PutInContainer)
    first = _pick_place(env, place=True, detour=False)
    second = _pick_place(env, place=container, detour=False)
    if slots is None:
        slots = CONTAINER_SLOTS if container else jnp.zeros((2, 3))

    def policy(obs: jax.Array, goal: jax.Array) -> jax.Array:
        one, two = env.project(obs, 0), env.project(obs, 1)
        first_done = env.cube_success(env.achieved_from_obs(obs), goal)[0] & ~env.grasped(one)
        grip, cube = obs[OBS_GRIP], obs[OBS_OBJECT]
        clear = (grip[2] - cube[2] > 0.06) | (jnp.linalg.norm(grip[:2] - cube[:2]) > 0.06)
        up = _toward(env, grip, grip + jnp.array([0.0, 0.0, 0.05]), jnp.asarray(OPEN))
        later = jnp.where(clear, second(two, goal[3:] + slots[1]), up)
        return jnp.where(first_done, later, first(one, goal[:3] + slots[0]))

    return policy


def scripted_behaviour(env: BaxterEnv) -> rollout.Behaviour:
    """The scripted controller as a (stateless) behaviour of the shared rollout scan."""
    policy = jax.vmap(make_scripted_policy(env))
    return rollout.stateless(lambda key, obs, goal: policy(obs, goal))


def rollout_scripted(env: BaxterEnv, key: jax.Array, n_episodes: int):
    """Run the scripted policy for n_episodes in a batch -> final State (batched) and the
    per-step success (T, n_episodes) after each step."""
    episodes, final, _ = rollout.run_episodes(env, scripted_behaviour(env), key, n_episodes)
    success = env.is_success(episodes.ag[:, 1:], episodes.g).astype(jnp.float32)
    return final, success.T
