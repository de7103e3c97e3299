"""Every registered env: jitted reset and random steps under vmap, determinism, bad input."""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from mjx_skills.config import EnvConfig
from mjx_skills.envs import BAXTER, ENVS, make
from mjx_skills.envs.baxter import XML_DIR, load_model

N_ENVS, N_STEPS = 4, 200


def _random_rollout(env, key):
    keys = jax.random.split(key, N_ENVS)
    state = jax.vmap(env.reset)(keys)

    def body(state, k):
        action = jax.random.uniform(k, (N_ENVS, 4), minval=-1.0, maxval=1.0)
        state = jax.vmap(env.step)(state, action)
        return state, (state.obs, state.achieved_goal, state.reward)

    return jax.lax.scan(body, state, jax.random.split(key, N_STEPS))


@pytest.mark.parametrize("name", list(ENVS))
def test_reset_and_random_steps(name, env_factory):
    env = env_factory(name)
    run = jax.jit(lambda k: _random_rollout(env, k))
    final, (obs, ag, reward) = run(jax.random.PRNGKey(0))
    assert obs.shape == (N_STEPS, N_ENVS, env.obs_dim) and obs.dtype == jnp.float32
    assert ag.shape == (N_STEPS, N_ENVS, env.goal_dim)
    assert final.desired_goal.shape == (N_ENVS, env.goal_dim)
    assert bool(jnp.all(jnp.isfinite(obs))) and bool(jnp.all(jnp.isfinite(ag)))
    assert set(np.unique(np.asarray(reward))) <= {-1.0, 0.0}
    assert float(final.metrics["physics_resets"].sum()) == 0.0
    if name in BAXTER:  # the Fetch tasks, as gymnasium-robotics', clip no target
        # The grip stays inside the workspace box (clip + weld tracking error of a few mm).
        grip = obs[..., :3]
        assert bool(jnp.all(grip >= env.workspace_low - 0.02)) and bool(
            jnp.all(grip <= env.workspace_high + 0.02)
        )
    # Same key, same trajectory.
    _, (obs2, _, _) = run(jax.random.PRNGKey(0))
    np.testing.assert_array_equal(np.asarray(obs), np.asarray(obs2))


def test_nan_and_out_of_range_actions_are_sanitised_and_counted(env_factory):
    env = env_factory("pick_move")
    state = jax.jit(env.reset)(jax.random.PRNGKey(1))
    step = jax.jit(env.step)
    state = step(state, jnp.array([jnp.nan, 0.0, 0.0, 0.0]))
    state = step(state, jnp.array([3.0, 0.0, 0.0, 0.0]))
    assert bool(jnp.all(jnp.isfinite(state.obs)))
    assert float(state.metrics["invalid_actions"]) == 2.0


def test_unknown_env_lists_valid_names():
    with pytest.raises(ValueError, match="valid: transit, grasp"):
        make("pick_and_place")


@pytest.mark.parametrize(
    "field,value",
    [("n_substeps", 0), ("timestep", -0.1), ("distance_threshold", -1.0), ("physics", "gpu")],
)
def test_invalid_config_names_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        EnvConfig(**{field: value})


def test_unknown_override_is_rejected():
    with pytest.raises(ValueError, match="unknown EnvConfig field"):
        make("transit", substeps=3)


@pytest.mark.parametrize("scene", sorted(p.name for p in XML_DIR.glob("scene_*.xml")))
def test_a_cube_off_the_table_lands_on_the_floor(scene):
    """A cube pushed off the table must stop on the floor: one that fell forever put
    positions of hundreds of metres into the observation normaliser and collapsed
    learned policies (docs/simulation.md)."""
    model = load_model(scene, EnvConfig())
    data = mujoco.MjData(model)
    joint = model.joint("object")
    adr = joint.qposadr[0]
    data.qpos[adr : adr + 3] = [1.3, -0.2, 0.0]  # beyond the table's far edge
    for _ in range(int(3.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    floor_z = float(model.geom("floor").pos[2])
    np.testing.assert_allclose(data.qpos[adr + 2], floor_z + 0.02, atol=0.005)
    assert np.abs(data.qvel[joint.dofadr[0] : joint.dofadr[0] + 3]).max() < 1e-2


@pytest.mark.parametrize("name", ["pick_move", "take_out"])
def test_single_goal_gives_every_episode_the_mean_of_the_goal_distribution(name):
    """PAS's single-goal formulation: one desired goal for every reset, the mean of the goals
    the task draws (so inside the task's goal region, not one arbitrary draw)."""
    keys = jax.random.split(jax.random.PRNGKey(5), 1024)
    drawn = jax.vmap(make(name).sample_start)(keys)[2]
    fixed = jax.vmap(make(name, EnvConfig(single_goal=True)).reset)(keys[:3]).desired_goal
    assert float(jnp.std(drawn[:, 2])) > 0.02  # the task draws goals...
    np.testing.assert_allclose(np.asarray(fixed), np.asarray(fixed[:1]).repeat(3, 0))
    np.testing.assert_allclose(np.asarray(fixed[0]), np.asarray(drawn.mean(0)), atol=0.015)
