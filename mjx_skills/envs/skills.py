"""The three skills of the library (thesis ch. 3): transit, grasp, transfer.

Each skill env also declares what the skill library needs: the box its goal parameters
map into from [-1, 1] (`goal_from_param`), which observation dimensions the skill changes
(`state_dims`) and memory retrieval compares (`memory_dims`), and when a running skill
stops (`terminated`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_skills.envs.baxter import OBS_FINGERS, OBS_GRIP, OBS_GRIP_VEL, OBS_OBJECT, BaxterEnv

OBJECT_REGION = ((0.55, -0.45), (0.8, 0.05))
_DIMS = tuple(range(25))
MANIPULATION_MEMORY_DIMS = _DIMS[OBS_GRIP] + _DIMS[OBS_OBJECT] + _DIMS[OBS_FINGERS]
"""Observation dimensions memory retrieval compares for grasp and transfer (with the goal):
positions only, so metres are not mixed with radians and velocities."""


def lerp(param: jax.Array, low, high) -> jax.Array:
    """A skill's goal parameters in [-1, 1] (clipped) -> the box [low, high]: every skill's
    `goal_from_param` (Baxter's here, Fetch's in envs/fetch_skills.py)."""
    low, high = jnp.asarray(low), jnp.asarray(high)
    return low + (jnp.clip(param, -1.0, 1.0) + 1.0) * 0.5 * (high - low)


class Transit(BaxterEnv):
    """Move the empty gripper to a 3-D target within 3 cm (20 steps)."""

    default_episode_length = 20
    goal_is_object = False
    param_dim = 3
    state_dims = tuple(range(25))[OBS_GRIP] + tuple(range(25))[OBS_GRIP_VEL]
    memory_dims = tuple(range(25))[OBS_GRIP]

    def sample_start(self, key):
        k_grip, k_obj, k_goal = jax.random.split(key, 3)
        return (
            self.sample_workspace(k_grip),
            self.sample_on_table(k_obj, *OBJECT_REGION),
            self.sample_workspace(k_goal),
        )

    def goal_from_param(self, param: jax.Array, obs: jax.Array) -> jax.Array:
        return lerp(param, self.workspace_low, self.workspace_high)

    def terminated(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        return self.is_success(obs[..., OBS_GRIP], goal)


class Grasp(BaxterEnv):
    """From within 5 cm of the cube, grasp it and lift it 5-8 cm (20 steps)."""

    default_episode_length = 20
    param_dim = 1
    lift_range = (0.05, 0.08)
    state_dims = tuple(range(25))
    memory_dims = MANIPULATION_MEMORY_DIMS

    def sample_start(self, key):
        k_obj, k_dz, k_r, k_a, k_h = jax.random.split(key, 5)
        obj = self.sample_on_table(k_obj, *OBJECT_REGION)
        # The grip starts above the cube (pads clear of its top face) within 5 cm of it.
        dz = jax.random.uniform(k_dz, (), minval=0.03, maxval=0.045)
        radius = jnp.sqrt(0.05**2 - dz**2) * jnp.sqrt(jax.random.uniform(k_r, ()))
        angle = jax.random.uniform(k_a, (), minval=0.0, maxval=2 * jnp.pi)
        grip = obj + jnp.stack([radius * jnp.cos(angle), radius * jnp.sin(angle), dz])
        lift = jax.random.uniform(k_h, (), minval=self.lift_range[0], maxval=self.lift_range[1])
        return grip, obj, obj + jnp.array([0.0, 0.0, 1.0]) * lift

    def goal_from_param(self, param: jax.Array, obs: jax.Array) -> jax.Array:
        lift = lerp(param[..., 0], *self.lift_range)
        zero = jnp.zeros_like(lift)
        return obs[..., OBS_OBJECT] + jnp.stack([zero, zero, lift], axis=-1)

    def terminated(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        return self.is_success(obs[..., OBS_OBJECT], goal)


class Transfer(BaxterEnv):
    """Carry the held cube to a 3-D target within 3 cm.

    20 steps, not the thesis's 10: at 5 cm per step, 10 steps cannot cross our workspace
    (60 cm in y), so a tenth of the goals would be unreachable by any policy."""

    default_episode_length = 20
    grasped_start = True
    param_dim = 3
    state_dims = tuple(range(25))
    memory_dims = MANIPULATION_MEMORY_DIMS

    def object_goal_box(self):
        low = self.workspace_low.at[2].set(self.table_z + self.object_half)
        return low, self.workspace_high

    def sample_start(self, key):
        k_grip, k_goal = jax.random.split(key)
        # The held cube's bottom starts at least 2 cm above the table.
        grip_low = self.workspace_low.at[2].set(self.table_z + self.object_half + 0.02)
        grip = self.sample_workspace(k_grip, low=grip_low)
        return grip, grip, self.sample_workspace(k_goal, *self.object_goal_box())

    def goal_from_param(self, param: jax.Array, obs: jax.Array) -> jax.Array:
        return lerp(param, *self.object_goal_box())

    def terminated(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """At the goal, or the cube dropped (nothing left to transfer)."""
        return self.is_success(obs[..., OBS_OBJECT], goal) | ~self.grasped(obs)


PARAM_DIM = max(Transit.param_dim, Grasp.param_dim, Transfer.param_dim)
"""Goal parameters padded to the widest skill's (transit and transfer: 3), as a
meta-controller over the skills outputs them."""
