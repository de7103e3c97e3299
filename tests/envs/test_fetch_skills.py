"""The skills on Fetch (envs/fetch_skills.py): their starts as drawn (`FetchRobot.place`: the
grip where asked, the block at rest where asked or closed in the fingers), the training-only
held starts, their goal parameters and stopping rules, what they refuse; the scripted
controllers solve them (tests/envs/test_fetch.py), and the library is built from them
(tests/skills/test_fetch_library.py)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.config import EnvConfig
from mjx_skills.envs import make
from mjx_skills.envs.fetch_skills import FETCH_SKILLS

N = 32


def _starts(name: str, **config):
    """(env, the drawn (grip, block, goal), the reset states) of N keys."""
    env = make(name, **config)
    keys = jax.random.split(jax.random.PRNGKey(0), N)
    drawn = jax.vmap(env.sample_start)(keys)
    return env, drawn, jax.jit(jax.vmap(env.reset))(keys)


@pytest.mark.parametrize("name", ["fetch_transit", "fetch_transfer"])
def test_a_start_puts_the_grip_where_it_was_drawn(name):
    env, (grip, block, goal), state = _starts(name)
    obs = np.asarray(state.obs)
    near = np.linalg.norm(np.asarray(grip)[:, :2] - np.asarray(block)[:, :2], axis=-1) < 0.07
    lifted = np.asarray(grip).copy()  # near the block a free grip keeps the fingertips clear
    if name == "fetch_transit":
        low = np.asarray(block)[:, 2] + 0.05
        lifted[near, 2] = np.maximum(lifted[near, 2], low[near])
    error = np.linalg.norm(obs[:, 0:3] - lifted, axis=-1)
    assert error.max() < 0.01, error.max()  # measured: 0.5 cm at most
    if name == "fetch_transit":  # the block rests where it was drawn, undisturbed
        np.testing.assert_allclose(obs[:, 3:6], np.asarray(block), atol=0.003)
    assert bool(jnp.all(state.done == 0)) and float(state.metrics["physics_resets"].sum()) == 0
    low, high = np.asarray(env.box_low), np.asarray(env.box_high)
    assert np.all((np.asarray(goal) >= low) & (np.asarray(goal) <= high))


def test_a_transfer_starts_with_the_block_held_and_keeps_it_when_still():
    env, _, state = _starts("fetch_transfer")
    assert bool(jnp.all(state.info["grasped"]))
    rel = np.linalg.norm(np.asarray(state.obs)[:, 6:9], axis=-1)
    assert rel.max() < 0.027 and rel.min() < 0.005  # 0 to 2.5 cm below the grip
    step = jax.jit(jax.vmap(env.step))
    for _ in range(5):  # the fingers kept closed, the arm kept still
        state = step(state, jnp.tile(jnp.array([0.0, 0.0, 0.0, -1.0]), (N, 1)))
    assert bool(jnp.all(state.info["grasped"]))
    assert not bool(jnp.any(env.terminated(state.obs, state.desired_goal)))


def test_a_free_block_rests_where_it_was_drawn_with_the_fingers_open_or_closed():
    env, (grip, block, goal), state = _starts("fetch_grasp")
    obs = np.asarray(state.obs)
    np.testing.assert_allclose(obs[:, 3:6], np.asarray(block), atol=0.005)
    assert not bool(jnp.any(state.info["grasped"]))
    gap = obs[:, 9:11].sum(-1)
    assert np.all((gap > 0.09) | (gap < 0.005)) and 0 < np.mean(gap > 0.09) < 1
    # The grip starts 5 to 7 cm above the block, within 4 cm of it in x and y; the goal
    # lifts the block by 5 to 8 cm.
    rel = obs[:, 6:9]
    assert np.all(np.linalg.norm(rel[:, :2], axis=-1) < 0.045)
    assert np.all((-rel[:, 2] > 0.045) & (-rel[:, 2] < 0.075))
    lift = np.asarray(goal)[:, 2] - np.asarray(block)[:, 2]
    assert np.all((lift >= 0.05) & (lift <= 0.08))


def test_held_training_starts_close_the_fingers_on_the_block_where_it_lies():
    _, (_, block, _), state = _starts("fetch_grasp", held_start_prob=1.0)
    assert bool(jnp.all(state.info["grasped"]))
    np.testing.assert_allclose(np.asarray(state.obs)[:, 3:6], np.asarray(block), atol=0.01)
    _, _, never = _starts("fetch_grasp", held_start_prob=0.0)
    assert not bool(jnp.any(never.info["grasped"]))


def test_goal_parameters_map_into_the_skills_goal_spaces():
    params = jnp.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], [5.0, -5.0, 0.0]])
    transit = make("fetch_transit")
    obs = jnp.zeros((3, 25))
    goals = np.asarray(transit.goal_from_param(params, obs))
    assert np.all(goals >= np.asarray(transit.box_low)) and np.all(
        goals <= np.asarray(transit.box_high)
    )
    grasp = make("fetch_grasp")
    obs = obs.at[:, 3:6].set(jnp.array([1.3, 0.75, 0.425]))
    lifted = np.asarray(grasp.goal_from_param(params[:, :1], obs))
    np.testing.assert_allclose(lifted[:, 2] - 0.425, [0.05, 0.08, 0.08], atol=1e-6)


def test_a_transfer_stops_when_the_block_drops():
    env = make("fetch_transfer")
    held = jnp.zeros(25).at[9:11].set(0.024)  # block at the grip, fingers on it
    dropped = held.at[6:9].set(jnp.array([0.0, 0.0, -0.1]))  # 10 cm below the grip
    goal = jnp.array([2.0, 2.0, 2.0])
    assert not bool(env.terminated(held, goal)) and bool(env.terminated(dropped, goal))


def test_held_starts_are_the_only_baxter_option_a_fetch_skill_takes():
    for name in FETCH_SKILLS:
        make(name, held_start_prob=0.5)
        with pytest.raises(ValueError, match=r"n_substeps \(--env.n-substeps\) is for the Baxter"):
            make(name, n_substeps=5)
    assert EnvConfig().held_start_prob == 0.0
