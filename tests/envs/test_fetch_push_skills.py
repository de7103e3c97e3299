"""The push library's skills on Fetch (envs/fetch_push_skills.py): push starts behind the
block at its side, in FetchPush's scene (fingers blocked), its goal along the push; its goal
parameters are an offset on the table; approach is transit in that scene. The scripted
controllers solve both (tests/envs/test_fetch.py, `SCRIPTED`); the search's proposals for
them: tests/skills/test_fetch_push_library.py."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.envs import make
from mjx_skills.envs.fetch_push_skills import BEHIND, LATERAL, PUSH_HEIGHT, PUSH_RANGE, REACH
from mjx_skills.envs.fetch_skills import FetchTransit

N = 32


def test_a_push_starts_behind_the_block_with_its_goal_along_the_push():
    env = make("fetch_push_block")
    keys = jax.random.split(jax.random.PRNGKey(0), N)
    grip, block, goal = (np.asarray(x) for x in jax.vmap(env.sample_start)(keys))
    state = jax.jit(jax.vmap(env.reset))(keys)
    obs = np.asarray(state.obs)
    assert env.block_gripper and env.scene == "push"
    np.testing.assert_allclose(obs[:, 3:6], block, atol=0.003)  # the block rests as drawn
    assert np.abs(obs[:, 9:11]).max() < 0.005  # the fingers closed
    # The grip where drawn, not lifted clear of the block as the other skills' free grips.
    error = np.linalg.norm(obs[:, 0:3] - grip, axis=-1)
    assert error.max() < 0.01, error.max()
    height = obs[:, 2] - obs[:, 5]
    assert np.all((height > PUSH_HEIGHT[0] - 0.01) & (height < PUSH_HEIGHT[1] + 0.01))
    behind = block[:, :2] - grip[:, :2]
    push = goal[:, :2] - block[:, :2]
    length = np.linalg.norm(push, axis=-1)
    assert np.all((length >= PUSH_RANGE[0] - 1e-6) & (length <= PUSH_RANGE[1] + 1e-6))
    way = push / length[:, None]
    along = np.sum(behind * way, axis=-1)  # BEHIND behind the block, opposite the push ...
    across = behind[:, 0] * way[:, 1] - behind[:, 1] * way[:, 0]  # ... and off its line
    np.testing.assert_allclose(along, BEHIND, atol=1e-5)
    assert np.abs(across).max() <= LATERAL + 1e-6 and np.abs(across).max() > LATERAL / 2
    np.testing.assert_allclose(goal[:, 2], block[:, 2])  # on the table
    assert bool(jnp.all(state.done == 0)) and float(state.metrics["physics_resets"].sum()) == 0
    assert not bool(jnp.any(env.terminated(state.obs, state.desired_goal)))


def test_push_goal_parameters_are_an_offset_on_the_table_from_the_block():
    env = make("fetch_push_block")
    obs = jnp.zeros((3, 25)).at[:, 3:6].set(jnp.array([1.3, 0.75, 0.425]))
    params = jnp.array([[-1.0, 1.0], [0.5, 0.0], [5.0, -5.0]])
    goals = np.asarray(env.goal_from_param(params, obs))
    expected = [[-REACH, REACH], [0.5 * REACH, 0.0], [REACH, -REACH]]
    np.testing.assert_allclose(goals[:, :2] - [1.3, 0.75], expected, atol=1e-6)
    np.testing.assert_allclose(goals[:, 2], 0.425)


def test_approach_draws_transits_starts_in_the_push_scene():
    """Both skills of the push library share FetchPush's scene (the library's data
    collection starts each skill from the other's starts); approach draws as transit does,
    in a box about FetchPush's initial grip that reaches behind the block's range."""
    approach, transit = make("fetch_approach"), make("fetch_transit")
    assert isinstance(approach, FetchTransit) and approach.scene == "push"
    assert approach.block_gripper and not transit.block_gripper
    keys = jax.random.split(jax.random.PRNGKey(3), N)
    drawn = jax.vmap(approach.sample_start)(keys)
    # Transit's draws in a box about FetchPush's initial grip, reaching BEHIND beyond the
    # block's range in x and y (a push's start behind a block at its edge is a goal).
    shift = np.asarray(approach.table_low - transit.box_low)
    grown = np.array([BEHIND, BEHIND, 0.0])
    np.testing.assert_allclose(approach.box_low, approach.table_low - grown, atol=1e-6)
    np.testing.assert_allclose(approach.box_high, approach.table_high + grown, atol=1e-6)
    blocks = jax.vmap(transit.sample_start)(keys)[1]
    np.testing.assert_allclose(np.asarray(drawn[1]), np.asarray(blocks) + shift, atol=1e-5)
    for point in (drawn[0], drawn[2]):
        inside = (np.asarray(point) >= approach.box_low) & (np.asarray(point) <= approach.box_high)
        assert inside.all()
    outside = np.asarray(drawn[2])[:, :2] > np.asarray(approach.table_high)[:2]
    assert outside.any()  # goals beyond the block's range are drawn
    obs = np.asarray(jax.jit(jax.vmap(approach.reset))(keys).obs)
    assert np.abs(obs[:, 9:11]).max() < 0.005  # the fingers closed
    grip, block = np.asarray(drawn[0]), np.asarray(drawn[1])
    far = np.linalg.norm(grip[:, :2] - block[:, :2], axis=-1) >= 0.07  # not lifted clear
    assert far.any() and np.linalg.norm(obs[far, 0:3] - grip[far], axis=-1).max() < 0.01
