"""Two-cube scenes: the projection onto (gripper, cube k) is the one-cube observation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.envs import make


def _obs(env, grip, cubes):
    physics = jax.jit(env.place)(jnp.asarray(grip), jnp.asarray(cubes))
    return env.observation(env.sensors(physics.sensordata))


@pytest.mark.parametrize("k", [0, 1])
def test_the_scene_seen_as_gripper_and_cube_k_is_the_one_cube_observation(k):
    """Cube k of a two-cube scene, projected, reads as the single cube of a one-cube scene
    set up the same way (grip and that cube where they are): so a skill trained with one
    cube acts on either cube as it would alone."""
    two, one = make("pick_move_two"), make("pick_move")
    grip = np.array([0.62, -0.15, 0.02])
    cubes = np.array([[0.7, -0.3, -0.08], [0.6, -0.05, -0.08]])
    projected = two.project(_obs(two, grip, cubes), k)
    alone = _obs(one, grip, cubes[k])
    assert projected.shape == alone.shape == (25,)
    np.testing.assert_allclose(np.asarray(projected), np.asarray(alone), atol=2e-3)
    assert not np.allclose(np.asarray(two.project(_obs(two, grip, cubes), 1 - k))[3:6], cubes[k])


def test_two_cube_tasks_score_both_cubes_and_refuse_held_starts():
    env = make("two_in_container")
    goal = jnp.concatenate([env.goal, env.goal])
    inside = env.goal + jnp.array([0.0, 0.025, 0.0])
    outside = env.goal + jnp.array([0.0, 0.2, 0.0])
    assert bool(env.is_success(jnp.concatenate([env.goal, inside]), goal))
    assert not bool(env.is_success(jnp.concatenate([env.goal, outside]), goal))
    np.testing.assert_array_equal(
        env.cube_success(jnp.concatenate([outside, inside]), goal), [False, True]
    )
    with pytest.raises(ValueError, match="held_start_prob"):
        make("pick_move_two", held_start_prob=0.5)


def test_library_methods_refuse_two_cube_tasks_before_writing_anything(tmp_path):
    from mjx_skills import train

    with pytest.raises(SystemExit, match="one-cube tasks; two_in_container has 2 cubes"):
        train.main(["mpas", "--task", "two_in_container", "--out", str(tmp_path)])
    assert not any(tmp_path.iterdir())
