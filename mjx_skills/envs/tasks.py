"""The manipulation tasks of the thesis (ch. 6.1), with its start distributions, goals,
episode lengths and success predicates (reference/original-setup.md)."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_skills.envs.baxter import BaxterEnv

CONTAINER_XY = (0.7, -0.35)  # centre of the container and of object B (xml/scene_*.xml)
TASK_OBJECT_REGION = ((0.55, -0.2), (0.8, 0.05))  # cubes start away from container / B


class PickMove(BaxterEnv):
    """Pick the cube anywhere on the table and move it to a 3-D goal within 3 cm (50 steps).
    The goal lies 0-18 cm above the table (FetchPickAndPlace-like)."""

    default_episode_length = 50

    def sample_object(self, key):
        """A cube resting anywhere on the table's reachable part (3,)."""
        return self.sample_on_table(key, (0.55, -0.45), (0.8, 0.05))

    def sample_goal(self, key):
        """A goal over the same area, 0-18 cm above resting on the table (3,)."""
        return self.sample_workspace(
            key,
            low=jnp.array([0.55, -0.45, self.table_z + self.object_half]),
            high=jnp.array([0.8, 0.05, self.table_z + self.object_half + 0.18]),
        )

    def sample_start(self, key):
        k_grip, k_obj, k_goal = jax.random.split(key, 3)
        return self.sample_workspace(k_grip), self.sample_object(k_obj), self.sample_goal(k_goal)


class PutInContainer(BaxterEnv):
    """Put the cube into the fixed container: success when the cube is within 5 cm (xy) of
    the container's centre and within 2 cm (z) of resting on its floor (100 steps)."""

    scene = "scene_put_in_container.xml"
    default_episode_length = 100
    default_threshold = 0.05
    z_tolerance = 0.02
    support_height = 0.01
    """Height above the table of what the cube rests on at the goal (the 1 cm floor)."""

    def __init__(self, config=None):
        super().__init__(config)
        rest_z = self.table_z + self.support_height + self.object_half
        self.goal = jnp.array([*CONTAINER_XY, rest_z])

    def sample_grip_start(self, key):
        """Above the walls (and on the cubes' side of them), so that the reset's move from
        home never drags the gripper through a wall."""
        low = self.workspace_low.at[1].set(-0.25).at[2].set(self.table_z + 0.12)
        return self.sample_workspace(key, low=low)

    def sample_start(self, key):
        k_grip, k_obj = jax.random.split(key)
        obj = self.sample_on_table(k_obj, *TASK_OBJECT_REGION)
        return self.sample_grip_start(k_grip), obj, self.goal

    def is_success(self, achieved_goal, desired_goal):
        delta = achieved_goal - desired_goal
        xy = jnp.linalg.norm(delta[..., :2], axis=-1)
        return (xy < self.threshold) & (jnp.abs(delta[..., 2]) < self.z_tolerance)


class ContainerWall(PutInContainer):
    """PutInContainer with the wall facing the cubes too high to pass over (100 steps)."""

    scene = "scene_container_wall.xml"


class PutOn(PutInContainer):
    """Put the cube on object B: within 3 cm (xy) of B's top centre and within 1 cm (z) of
    resting on it, i.e. in contact (the original code's 3 cm in z would count a cube held
    in the air; 1 cm cannot), 50 steps."""

    scene = "scene_put_on.xml"
    default_episode_length = 50
    default_threshold = 0.03
    z_tolerance = 0.01
    support_height = 0.05  # object B is a 5 cm cube


class TakeOut(PutInContainer):
    """Take the cube out of the container to a random 3-D goal 10-22 cm above the container's
    floor, within 3 cm (50 steps)."""

    default_episode_length = 50
    default_threshold = 0.03

    def sample_start(self, key):
        k_grip, k_obj, k_goal = jax.random.split(key, 3)
        centre = jnp.asarray(CONTAINER_XY)
        # +-2.5 cm keeps the open fingers (7 cm wide) clear of the walls above the cube.
        obj_xy = centre + jax.random.uniform(k_obj, (2,), minval=-0.025, maxval=0.025)
        obj = jnp.concatenate([obj_xy, self.goal[2:]])
        goal_xy = centre + jax.random.uniform(k_goal, (2,), minval=-0.05, maxval=0.05)
        goal_z = self.table_z + jax.random.uniform(
            jax.random.fold_in(k_goal, 1), (1,), minval=0.1, maxval=0.22
        )
        return self.sample_grip_start(k_grip), obj, jnp.concatenate([goal_xy, goal_z])

    def is_success(self, achieved_goal, desired_goal):
        return BaxterEnv.is_success(self, achieved_goal, desired_goal)
