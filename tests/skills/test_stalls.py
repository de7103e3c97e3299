"""The stall memory and obstacles in the search: segments near an obstacle are blocked
(grasp never), the ring buffer keeps the last stalled points, a stalled transfer ends and
the search stops planning through it."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig, SearchConfig
from mjx_skills.envs.baxter import OBS_GRIP, OBS_OBJECT
from mjx_skills.methods import ddpg_her_sl
from mjx_skills.skills import stalls
from tests.fakes import NAMES, EnvState, KnownLibrary, states

TRANSFER = NAMES.index("transfer")


def test_segments_near_an_obstacle_are_blocked_and_grasp_never_is():
    obs = jnp.zeros((4, 25)).at[:, OBS_GRIP].set(jnp.array([0.6, 0.0, 0.1]))
    goal = jnp.array([[0.6, -0.3, 0.1]] * 4)
    # On the path; 2 cm beside it; 5 cm beside it; behind the start (outside the segment).
    points = jnp.array(
        [[0.6, -0.15, 0.1], [0.62, -0.15, 0.1], [0.65, -0.15, 0.1], [0.6, 0.05, 0.1]]
    )[:, None]
    np.testing.assert_allclose(
        stalls.segment_distance(points, obs[:, OBS_GRIP], goal)[:, 0],
        [0.0, 0.02, 0.05, 0.05],
        atol=1e-6,
    )
    skill = jnp.full((4,), TRANSFER)
    np.testing.assert_array_equal(
        stalls.blocked(points, NAMES, skill, obs[:, OBS_GRIP], goal, 0.03),
        [True, True, False, False],
    )
    grasp = jnp.full((4,), NAMES.index("grasp"))
    assert not np.any(stalls.blocked(points, NAMES, grasp, obs[:, OBS_GRIP], goal, 0.03))


def test_the_ring_buffer_keeps_the_last_points_of_envs_that_stalled():
    obstacles, count = stalls.empty(2, 2), jnp.zeros((2,), jnp.int32)
    heading = jnp.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    for i in range(3):
        grip = jnp.zeros((2, 3)).at[0, 2].set(i)
        obstacles, count = stalls.remember(
            obstacles, count, grip, grip + 2 * heading, jnp.array([True, False]), 0.1
        )
    np.testing.assert_array_equal(count, [3, 0])
    # Slots 0 and 1 of env 0 hold stalls 2 and 1, each 0.1 from its grip towards its goal.
    np.testing.assert_allclose(obstacles[0], [[0.1, 0.0, 2.0], [0.1, 0.0, 1.0]], atol=1e-6)
    assert np.all(np.asarray(obstacles[1]) == stalls.EMPTY)


def test_a_stalled_transfer_ends_and_the_search_stops_planning_through_it(env):
    """The held cube does not move while a transfer runs (a wall): the explorer ends the
    skill at its second step, remembers the point ahead, and no later transfer towards the
    task goal passes there; with waypoints the search finds transfers that avoid it."""
    agent = ddpg.init(jax.random.PRNGKey(1), 25, 3, 4, DDPGConfig())
    obs, _ = states(64, held=True)
    goal = obs[:, OBS_OBJECT] + jnp.array([0.0, -0.15, 0.0])  # 15 cm away: never solved
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=obs[:, OBS_OBJECT])
    for share in (0.0, 0.5):
        cfg = SearchConfig(eps_start=1.0, eps_end=1.0, stall_memory=4, waypoint_share=share)
        beh = ddpg_her_sl.make_behaviour(
            agent, KnownLibrary(), jnp.zeros((), jnp.int32), env, cfg, DDPGConfig()
        )
        step = jax.jit(beh.step)
        ps = beh.init(jax.random.PRNGKey(0), 64)
        ps, _, rec = step(ps, jax.random.PRNGKey(1), state)
        assert np.all(rec["skill_calls"]) and np.all(np.asarray(ps.run.skill) == TRANSFER)
        first = np.asarray(ps.run.goal)
        ps, _, rec = step(ps, jax.random.PRNGKey(2), state)
        assert not np.any(rec["stalls"])  # one step says nothing yet
        ps, _, rec = step(ps, jax.random.PRNGKey(3), state)
        # Every goal was farther than stall_ahead + stall_radius: all stalled at step 2.
        assert np.all(rec["stalls"]) and np.all(np.asarray(ps.stalls) == 1)
        grip = np.asarray(obs[:, OBS_GRIP])
        ahead = grip + 0.03 * (first - grip) / np.linalg.norm(first - grip, axis=1, keepdims=True)
        np.testing.assert_allclose(ps.obstacles[:, 0], ahead, atol=1e-5)
        # The replanned skills (if any) pass no remembered obstacle.
        started = np.asarray(rec["skill_calls"]).astype(bool)
        if share == 0.0:  # every transfer heads for the task goal, past the obstacle
            assert not started.any() and np.all(rec["all_pruned"])
        else:
            assert started.sum() >= 8  # waypoints heading away from it (24 of 64 here)
            assert np.all(np.asarray(rec["all_pruned"])[~started])
            near = stalls.segment_distance(ps.obstacles, obs[:, OBS_GRIP], ps.run.goal).min(-1)
            assert np.all(np.asarray(near)[started] >= 0.03)
