"""The per-skill critic of PAS / MPAS (`pdqn`): a skill's value reads its own goal only,
choices respect the allowed skills, and a goal-reaching meta transition is terminal."""

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.agents import ddpg, mpdqn
from mjx_skills.config import DDPGConfig
from mjx_skills.envs.skills import PARAM_DIM
from mjx_skills.skills.library import LIBRARIES, skill_envs

CFG = DDPGConfig()
NAMES = LIBRARIES["SL1"]
B = 64


def _state_and_inputs():
    state = mpdqn.init(jax.random.PRNGKey(0), 25, 3, len(NAMES), CFG)
    k_obs, k_goal, k_par = jax.random.split(jax.random.PRNGKey(1), 3)
    obs = 0.3 * jax.random.normal(k_obs, (B, 25))
    goal = 0.3 * jax.random.normal(k_goal, (B, 3))
    params = jax.random.uniform(k_par, (B, len(NAMES), PARAM_DIM), minval=-1, maxval=1)
    return state, obs, goal, params


def test_each_skills_value_reads_its_own_goal_only():
    state, obs, goal, params = _state_and_inputs()
    goals = mpdqn.skill_goals(skill_envs(NAMES))
    o, g = ddpg.normalize_inputs(state, obs, goal, CFG)

    def values(p):
        return mpdqn._values(
            state.critic_params, o, g, mpdqn._norm_goal(state, goals(p, obs), CFG), CFG
        )

    base = values(params)
    transfer = NAMES.index("transfer")
    moved = values(params.at[:, transfer].set(-params[:, transfer]))
    others = [k for k in range(len(NAMES)) if k != transfer]
    np.testing.assert_allclose(moved[:, others], base[:, others], atol=1e-6)
    assert np.max(np.abs(moved[:, transfer] - base[:, transfer])) > 1e-4
    # Grasp reads its first parameter only: the padding changes nothing.
    grasp = NAMES.index("grasp")
    padded = values(params.at[:, grasp, 1:].set(0.9))
    np.testing.assert_allclose(padded, base, atol=1e-6)


def test_choices_keep_to_the_allowed_skills_even_exploring():
    state, obs, goal, _ = _state_and_inputs()
    goals = mpdqn.skill_goals(skill_envs(NAMES))
    allowed = jax.random.uniform(jax.random.PRNGKey(2), (B, len(NAMES))) < 0.5
    allowed = allowed.at[:, 0].set(~jnp.any(allowed[:, 1:], axis=-1) | allowed[:, 0])
    cfg = DDPGConfig(random_eps=0.5)
    for key in (None, jax.random.PRNGKey(3)):
        skill, target, stored = mpdqn.choose(state, obs, goal, allowed, goals, cfg, key)
        assert bool(jnp.all(allowed[jnp.arange(B), skill]))
        np.testing.assert_array_equal(np.argmax(stored[:, : len(NAMES)], -1), skill)
        np.testing.assert_allclose(stored[:, len(NAMES) :], target)


def test_a_terminal_transition_is_not_bootstrapped():
    state = ddpg.init(jax.random.PRNGKey(0), 25, 3, 4, CFG)
    batch = {
        "obs": jnp.ones((8, 25)),
        "next_obs": jnp.ones((8, 25)),
        "goal": jnp.zeros((8, 3)),
        "action": jnp.zeros((8, 4)),
        "reward": -jnp.ones((8,)),
    }
    going_on = ddpg.td_target(state, batch, CFG)
    terminal = jnp.arange(8) % 2 == 0
    y = ddpg.td_target(state, {**batch, "terminal": terminal.astype(jnp.float32)}, CFG)
    np.testing.assert_allclose(y[terminal], -1.0)
    np.testing.assert_allclose(y[~terminal], going_on[~terminal])
    assert np.max(np.abs(going_on + 1.0)) > 1e-4  # the critic's Q' does enter otherwise
