"""The skill-execution state machine shared by DDPG+HER+SL and PAS / MPAS."""

import jax.numpy as jnp
import numpy as np

from mjx_skills.skills import execution


def test_deciding_envs_start_or_go_idle_and_the_others_keep_their_skill():
    run = execution.idle(4)
    assert not np.any(run.active)
    np.testing.assert_array_equal(execution.decide(run, jnp.zeros(4, bool)), [True] * 4)
    goal = jnp.arange(12.0).reshape(4, 3)
    # Envs 0-2 start skill 2 (env 3 decides but starts nothing: it stays idle).
    run = execution.advance(
        run, jnp.ones(4, bool), jnp.array([1, 1, 1, 0], bool), jnp.full(4, 2, jnp.int32), goal
    )
    np.testing.assert_array_equal(run.active, [True, True, True, False])
    np.testing.assert_array_equal(run.steps, [1, 1, 1, 1])
    # Env 0's stop rule fires: it decides and starts skill 0; env 1 keeps running (step 2);
    # env 2 decides and goes idle; env 3 is idle, so it decides, and starts nothing.
    stop = jnp.array([True, False, True, False])
    deciding = execution.decide(run, stop)
    np.testing.assert_array_equal(deciding, [True, False, True, True])
    run = execution.advance(
        run, deciding, jnp.array([True, False, False, False]), jnp.zeros(4, jnp.int32), -goal
    )
    np.testing.assert_array_equal(run.active, [True, True, False, False])
    np.testing.assert_array_equal(run.skill, [0, 2, 2, 0])
    np.testing.assert_array_equal(run.steps, [1, 2, 2, 2])
    np.testing.assert_array_equal(run.goal[0], -goal[0])
    np.testing.assert_array_equal(run.goal[1], goal[1])
