"""Shared fakes of the tests: a hand-built skill library whose classifier, critic and coarse
model are known functions, the env state a behaviour reads, and hand-built observations."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from mjx_skills.envs.baxter import LAYOUT, OBS_GRIP, OBS_OBJECT
from mjx_skills.skills.library import SkillLibrary, consistent, skill_envs

NAMES = ("transit", "grasp", "transfer")
TINY_TRAIN = dict(
    task="transit",
    envs=2,
    cycles=2,
    updates_per_cycle=5,
    eval_episodes=2,
    replay_capacity=2000,
    progress=False,
)
"""TrainConfig fields of a tiny run: every code path of an epoch, compiled in seconds (the
budget test_train's runs share, so their compiled epoch is shared too)."""


def tiny_train(**changes) -> dict:
    """TINY_TRAIN with `changes`: the TrainConfig fields of a test's tiny run."""
    return {**TINY_TRAIN, **changes}


@struct.dataclass
class EnvState:
    """What the behaviour reads of the batched env state."""

    obs: jax.Array
    desired_goal: jax.Array
    achieved_goal: jax.Array


@dataclasses.dataclass(frozen=True)
class KnownLibrary:
    """Critic: minus the goal's x (so goals at small x are best); classifier: 1 unless the
    skill is in `pruned`; model: the grip (and, for transfer, the cube) lands on the goal."""

    pruned: tuple[int, ...] = ()
    names: tuple[str, ...] = NAMES

    @property
    def envs(self):
        return skill_envs(self.names)

    @property
    def layout(self):
        return LAYOUT

    def success_prob(self, skill, obs, goal):
        bad = jnp.isin(skill, jnp.array(self.pruned or (-1,)))
        return jnp.where(bad, 0.0, 1.0)

    def q(self, skill, obs, goal):
        return -goal[:, 0]

    def next_state(self, skill, obs, goal):
        moved = obs.at[:, OBS_GRIP].set(goal)
        carry = (skill == self.names.index("transfer"))[:, None]
        moved = moved.at[:, OBS_OBJECT].set(jnp.where(carry, goal, obs[:, OBS_OBJECT]))
        return consistent(LAYOUT, moved)

    recall = next_state
    allowed = SkillLibrary.allowed  # the real rule: transfer only with the cube in hand

    def terminated(self, skill, obs, goal):
        return jnp.zeros(skill.shape, bool)

    def policy_action(self, skill, obs, goal):
        return jnp.full((obs.shape[0], 4), 0.5)


def states(n: int, held: bool) -> tuple[jax.Array, jax.Array]:
    """Observations with the cube on the table (or in the fingers) and task goals."""
    rng = np.random.default_rng(0)
    obs = np.zeros((n, 25), np.float32)
    obs[:, OBS_GRIP] = rng.uniform([0.55, -0.4, 0.1], [0.8, 0.0, 0.2], (n, 3))
    obs[:, OBS_OBJECT] = (
        obs[:, OBS_GRIP] if held else rng.uniform([0.55, -0.4, 0.04], [0.8, 0.0, 0.04], (n, 3))
    )
    obs[:, 9:11] = 0.012 if held else 0.02  # fingers closed on the cube / open
    # Goals at least 8 cm above the cube's centre: the task is never solved at the start.
    goal = rng.uniform([0.55, -0.4, 0.12], [0.8, 0.0, 0.2], (n, 3)).astype(np.float32)
    return consistent(LAYOUT, jnp.asarray(obs)), jnp.asarray(goal)


@dataclasses.dataclass(frozen=True)
class EncodingLibrary(KnownLibrary):
    """A library whose skill policies say who they are: action = (skill / 10, goal)."""

    def policy_action(self, skill, obs, goal):
        return jnp.concatenate([skill[:, None] / 10.0, goal], axis=-1)


def flip_byte(path, offset: int | None = None) -> None:
    """Invert one byte of the file `path` (its middle by default): damage to detect."""
    data = bytearray(path.read_bytes())
    data[len(data) // 2 if offset is None else offset] ^= 0xFF
    path.write_bytes(bytes(data))
