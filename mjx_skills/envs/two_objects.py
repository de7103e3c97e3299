"""Two-cube tasks (beyond the thesis): the same arm and table with a second, red cube.

The observation is the one-cube observation (25 numbers, cube 1 in the cube's places)
followed by cube 2's position, its offset from the grip, rotation and velocities (15): 40
numbers. `project(obs, k)` is the one-cube observation of the scene seen as (gripper, cube
k), exactly what a skill trained with one cube sees, so a library skill can act on either
cube. The achieved and desired goals are both cubes' positions (6 numbers).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.envs.baxter import OBS_OBJECT, PARKED_OBJECT, SENSORS, BaxterEnv
from mjx_skills.envs.tasks import TASK_OBJECT_REGION, PickMove, PutInContainer

SENSORS_2 = ("object2_pos", "object2_quat", "object2_linvel", "object2_angvel")
ONE = 25
"""Width of the one-cube observation."""
_CUBE_1 = np.array([3, 4, 5, 6, 7, 8, 11, 12, 13, 14, 15, 16, 17, 18, 19])
"""Cube 1's entries of the one-cube observation (position, offset, rotation, velocities);
cube 2's follow the one-cube observation in the same order."""
_VIEW_2 = np.arange(ONE)
_VIEW_2[_CUBE_1] = ONE + np.arange(len(_CUBE_1))
"""The two-cube observation's indices of cube 2's view, (gripper, cube 2): `project`."""
MIN_APART = 0.07
"""Starts and goals of the two cubes keep their centres this far apart (m, xy)."""


def object_views(env, obs: jax.Array) -> jax.Array:
    """obs (..., obs_dim) of any task -> (..., n, 25): the scene seen as (gripper, cube k)
    for each of its n cubes (`TwoObjects.project`), the one-cube observation a library skill
    was trained on; a one-cube task's observation as it is (n = 1)."""
    if env.n_objects == 1:
        return obs[..., None, :]
    return jnp.stack([env.project(obs, k) for k in range(env.n_objects)], axis=-2)


def view_indices(env) -> tuple[tuple[int, ...], ...]:
    """Per cube k of `env`'s scene, the observation's indices of its view, static (a
    `nets.Views`): obs[..., view_indices(env)[k]] is `object_views(env, obs)[..., k, :]`.
    A scene without an object (FetchReach) has one view too: the whole observation."""
    if env.n_objects <= 1:
        return (tuple(range(env.obs_dim)),)
    return tuple(range(ONE)), tuple(int(i) for i in _VIEW_2)


def finish_first(held: jax.Array, at_goal: jax.Array) -> jax.Array:
    """held, at_goal (..., c) bool per cube -> (..., c) bool: another cube is in the fingers
    and not yet at its goal, so nothing starts on this cube's view (whose gripper looks
    empty but is not): the library's explorers finish what they hold first. Once the held
    cube is at its goal, a transit or grasp on another cube is what releases it."""
    busy = held & ~at_goal
    return busy.any(-1, keepdims=True) & ~busy


def clear_goals(env, obs: jax.Array, goal: jax.Array, clearance: float) -> jax.Array:
    """obs (..., obs_dim), goal (..., 3 n) of any task -> (..., n, 3): each cube's goal as
    the library's explorers aim it, `clearance` (m, xy between centres) clear of the other
    cubes (entity-informed goals, the thesis's outlook). Against each other cube j in turn:
    where j lies within `clearance` of the goal (at its height), the goal moves to
    `clearance` from j, on the goal's side of j; else, where j's goal lies within
    `clearance` of it (a shared goal, as both cubes' container), it moves clearance / 2
    towards this cube's side of j, so that the two end side by side. A goal clear of the
    other cubes stays as it is; so does every goal where clearance is 0 or n = 1.

    Why: the search scores a transfer by the distance of its end to the goal, so towards a
    goal shared with a cube already there it picks the transfer that drops the second cube
    onto the first (no success: docs/results.md)."""
    n = env.n_objects
    goals = goal.reshape(*goal.shape[:-1], n, 3)
    if n == 1 or not clearance:
        return goals
    cubes = env.achieved_from_obs(obs).reshape(goals.shape)
    aimed = []
    for k in range(n):
        g = goals[..., k, :]
        for j in [i for i in range(n) if i != k]:
            cube = cubes[..., j, :]
            side = _unit_xy(cubes[..., k, :] - cube, jnp.array([1.0, 0.0, 0.0]))
            off = _unit_xy(g - cube, side)
            level = jnp.abs(g[..., 2] - cube[..., 2]) < 2 * env.object_half
            taken = (_xy(g - cube) < clearance) & level
            shared = _xy(goals[..., j, :] - g) < clearance
            beside = (cube + clearance * off).at[..., 2].set(g[..., 2])
            g = jnp.where(
                taken[..., None],
                beside,
                jnp.where(shared[..., None], g + 0.5 * clearance * side, g),
            )
        aimed.append(g)
    return jnp.stack(aimed, axis=-2)


def _xy(v: jax.Array) -> jax.Array:
    return jnp.linalg.norm(v[..., :2], axis=-1)


def _unit_xy(v: jax.Array, fallback: jax.Array) -> jax.Array:
    """v's unit direction in xy (z = 0); `fallback` (a unit xy vector) where v has none."""
    flat = v.at[..., 2].set(0.0)
    length = _xy(flat)[..., None]
    return jnp.where(length > 1e-4, flat / jnp.maximum(length, 1e-4), fallback)


def workable(held: jax.Array, at_goal: jax.Array, in_order: bool) -> jax.Array:
    """held, at_goal (..., c) bool per cube -> (..., c) bool: the cubes the library's
    explorers may start a skill on. A cube in the fingers and short of its goal is the only
    one (`finish_first`); with `in_order`, otherwise only the first cube (by index) not at
    its goal, so that the explorers fetch the cubes in one order."""
    ok = ~finish_first(held, at_goal)
    if not in_order:
        return ok
    first = jnp.argmax(~at_goal, axis=-1)[..., None]
    nxt = (jnp.arange(at_goal.shape[-1]) == first) & ~at_goal
    return ok & (nxt | (held & ~at_goal))


class TwoObjects(BaxterEnv):
    """Mixin over a one-cube task: both cubes placed at reset, observed and scored."""

    n_objects = 2
    goal_dim = 6
    parked = np.stack([PARKED_OBJECT, PARKED_OBJECT + np.array([0.0, 0.5, 0.0])])

    goal_rests = (True, True)
    """Per cube: whether its goal rests on a surface, so that a goal start can put it there."""
    goal_start_offset = 0.0
    """How far (m, xy, in a random direction) from its goal a goal start puts the cube: room
    for the other cube where both share a goal."""

    def __init__(self, config=None):
        super().__init__(config)
        if self.config.held_start_prob:
            raise ValueError("held_start_prob: held starts are for one-cube tasks")
        for name in SENSORS_2:
            s = self.model.sensor(name)
            self.sensor_slices[name] = slice(int(s.adr[0]), int(s.adr[0] + s.dim[0]))
        joint = self.model.joint("object2").id
        self.object2_qpos_adr = self.model.jnt_qposadr[joint]
        self.object2_qvel_adr = self.model.jnt_dofadr[joint]
        self.obs_dim = ONE + len(_CUBE_1)

    # ------------------------------------------------------------------ observation
    def observation(self, sens):
        second = {name.replace("object2", "object"): sens[name] for name in SENSORS_2}
        one = super().observation(sens)
        other = super().observation({**{n: sens[n] for n in SENSORS}, **second})
        return jnp.concatenate([one, other[..., _CUBE_1]], axis=-1)

    def project(self, obs: jax.Array, k: int | jax.Array) -> jax.Array:
        """(..., 40) -> (..., 25): the scene as (gripper, cube k), the one-cube observation."""
        return jnp.where(jnp.asarray(k) == 1, obs[..., _VIEW_2], obs[..., :ONE])

    def grasped(self, obs):
        """Either cube held (a one-cube observation: that cube)."""
        if obs.shape[-1] == ONE:
            return super().grasped(obs)
        return super().grasped(self.project(obs, 0)) | super().grasped(self.project(obs, 1))

    def achieved_goal(self, sens):
        return jnp.concatenate([sens["object_pos"], sens["object2_pos"]], axis=-1)

    def achieved_from_obs(self, obs):
        return jnp.concatenate([obs[..., 3:6], obs[..., ONE : ONE + 3]], axis=-1)

    def cube_success(self, achieved, desired):
        """(..., 2) bool: each cube at its goal by the one-cube task's rule."""
        a, d = (
            achieved.reshape(*achieved.shape[:-1], 2, 3),
            desired.reshape(*desired.shape[:-1], 2, 3),
        )
        return self.one_cube_success(a, d)

    def one_cube_success(self, achieved, desired):
        """(...) bool: one cube's position (..., 3) at its goal (..., 3), the one-cube rule."""
        return super().is_success(achieved, desired)

    @property
    def cube_view(self) -> CubeView:
        """The task seen one cube at a time: what the look-ahead search scores the projected
        states of one cube with (`project`)."""
        return CubeView(self)

    def is_success(self, achieved, desired):
        return jnp.all(self.cube_success(achieved, desired), axis=-1)

    def compute_reward(self, achieved, desired):
        """Sparse: 0 once every cube is at its goal, else -1; with `object_reward` minus the
        share of cubes not yet at their goals (-1, -0.5, 0)."""
        if not self.config.object_reward:
            return super().compute_reward(achieved, desired)
        return jnp.mean(self.cube_success(achieved, desired), axis=-1, dtype=jnp.float32) - 1.0

    # ------------------------------------------------------------------ reset
    def training_start(self, key, grip, object_pos, goal):
        """With `goal_start_prob`, one cube drawn among those whose goal rests on a surface
        (`goal_rests`) starts at its goal, `goal_start_offset` from it in a random direction:
        object_pos (2, 3), goal (6,)."""
        grip, object_pos, held = super().training_start(key, grip, object_pos, goal)
        if self.config.goal_start_prob > 0:
            k_coin, k_cube, k_dir = jax.random.split(jax.random.fold_in(key, 11), 3)
            rests = jnp.asarray(self.goal_rests, jnp.float32)
            k = jax.random.choice(k_cube, len(self.goal_rests), p=rests / rests.sum())
            start = jax.random.uniform(k_coin) < self.config.goal_start_prob
            at_goal = start & (jnp.arange(self.n_objects) == k)
            angle = jax.random.uniform(k_dir, (), maxval=2 * jnp.pi)
            offset = self.goal_start_offset * jnp.array([jnp.cos(angle), jnp.sin(angle), 0.0])
            there = goal.reshape(self.n_objects, 3) + offset
            object_pos = jnp.where(at_goal[:, None], there, object_pos)
        return grip, object_pos, held

    def _put_object(self, qpos, qvel, object_pos):
        qpos, qvel = super()._put_object(qpos, qvel, object_pos[0])
        pose = jnp.concatenate([object_pos[1], jnp.array([1.0, 0.0, 0.0, 0.0])])
        qpos = qpos.at[self.object2_qpos_adr : self.object2_qpos_adr + 7].set(pose)
        qvel = qvel.at[self.object2_qvel_adr : self.object2_qvel_adr + 6].set(0.0)
        return qpos, qvel

    def apart(self, key, sample, others, tries: int = 16):
        """A draw of `sample(key)` (3,) at least MIN_APART (xy) from each of `others` (n, 3):
        the first of `tries` draws that is (the last if none is)."""
        draws = jax.vmap(sample)(jax.random.split(key, tries))
        gap = jnp.linalg.norm(draws[:, None, :2] - others[None, :, :2], axis=-1).min(axis=1)
        ok = (gap >= MIN_APART).at[-1].set(True)
        return draws[jnp.argmax(ok)]


@dataclasses.dataclass(frozen=True)
class CubeView:
    """One cube of a two-cube task, as a one-cube task: its achieved goal read from a
    projected observation (..., 25), its goal (..., 3), success by the one-cube rule."""

    env: TwoObjects

    @property
    def threshold(self) -> float:
        return self.env.threshold

    def achieved_from_obs(self, obs):
        return obs[..., OBS_OBJECT]

    def is_success(self, achieved, desired):
        return self.env.one_cube_success(achieved, desired)

    def compute_reward(self, achieved, desired):
        return self.is_success(achieved, desired).astype(jnp.float32) - 1.0


class PickMoveTwo(TwoObjects, PickMove):
    """Each cube to its own 3-D goal within 3 cm (120 steps): the blue cube's goal lies on
    the table, the red one's 0-18 cm above it (one gripper can hold only one cube in the
    air). Cubes and goals start at least 7 cm apart."""

    scene = "scene_pick_move_two.xml"
    goal_rests = (True, False)
    """The red cube's goal may lie in the air: only the blue cube can start at its goal."""
    default_episode_length = 120
    """At 150 steps the script's held red cube sometimes slips out of the fingers before the
    end (scripted success 0.78 against 0.95 at 100 or 120 steps)."""

    def sample_start(self, key):
        k_grip, k1, k2, k_g1, k_g2 = jax.random.split(key, 5)
        on_table = self.sample_object  # the blue cube's goal rests on the table too
        cube1 = on_table(k1)
        goal1 = self.apart(k_g1, on_table, cube1[None])
        cube2 = self.apart(k2, on_table, jnp.stack([cube1, goal1]))
        goal2 = self.apart(k_g2, self.sample_goal, jnp.stack([cube1, goal1, cube2]))
        grip = self.sample_workspace(k_grip)
        return grip, jnp.stack([cube1, cube2]), jnp.concatenate([goal1, goal2])


class TwoInContainer(TwoObjects, PutInContainer):
    """Both cubes into the container, each by the container's rule (within 5 cm (xy) of its
    centre, resting on its floor), 200 steps. Cubes start at least 7 cm apart."""

    scene = "scene_two_in_container.xml"
    default_episode_length = 200
    goal_start_offset = 0.025
    """A goal start's cube sits 2.5 cm off the container's centre, as the scripted controller
    places each (its cubes are 4 cm wide; both must lie within 5 cm of the centre), leaving
    room for the other. At the centre itself the other cube would have only a 1 cm ring."""

    def sample_start(self, key):
        k_grip, k1, k2 = jax.random.split(key, 3)
        on_table = lambda k: self.sample_on_table(k, *TASK_OBJECT_REGION)  # noqa: E731
        cube1 = on_table(k1)
        cube2 = self.apart(k2, on_table, cube1[None])
        grip = self.sample_grip_start(k_grip)
        return grip, jnp.stack([cube1, cube2]), jnp.concatenate([self.goal, self.goal])
