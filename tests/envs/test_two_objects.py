"""Two-cube scenes: the projection onto (gripper, cube k) is the one-cube observation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.envs import make
from mjx_skills.skills.library import DEFAULT_DIR


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


def test_the_step_wise_reward_counts_each_cube_and_success_still_needs_both():
    """`object_reward`: -1, -0.5, 0 with none, one, both cubes in; without it -1 until both
    are. HER recomputes it for relabelled goals, so it must hold on a batch."""
    plain, each = make("two_in_container"), make("two_in_container", object_reward=True)
    goal = jnp.concatenate([plain.goal, plain.goal])
    inside = plain.goal + jnp.array([0.0, 0.025, 0.0])
    outside = plain.goal + jnp.array([0.0, 0.2, 0.0])
    pairs = ((outside, outside), (outside, inside), (inside, outside), (inside, inside))
    achieved = jnp.stack([jnp.concatenate(pair) for pair in pairs])
    goals = jnp.broadcast_to(goal, achieved.shape)
    np.testing.assert_array_equal(each.compute_reward(achieved, goals), [-1.0, -0.5, -0.5, 0.0])
    np.testing.assert_array_equal(plain.compute_reward(achieved, goals), [-1.0, -1.0, -1.0, 0.0])
    np.testing.assert_array_equal(each.is_success(achieved, goals), [False, False, False, True])


@pytest.mark.parametrize(
    "task, cubes, off", [("two_in_container", (0, 1), 0.025), ("pick_move_two", (0,), 0.0)]
)
def test_a_goal_start_puts_one_cube_whose_goal_rests_on_a_surface_at_its_goal(task, cubes, off):
    """--env.goal-start-prob 1: every reset has exactly one cube at its goal, drawn among the
    cubes whose goal rests on a surface (pick_move_two's red goal may be in the air), `off`
    m from it (two_in_container: room for the other cube beside it), and the task not yet
    solved; one-cube tasks refuse it."""
    env = make(task, goal_start_prob=1.0)
    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), 24))
    at_goal = np.asarray(env.cube_success(states.achieved_goal, states.desired_goal))
    np.testing.assert_array_equal(at_goal.sum(axis=1), 1)
    assert set(np.flatnonzero(at_goal.any(axis=0))) == set(cubes)
    gap = np.asarray(states.achieved_goal - states.desired_goal).reshape(-1, 2, 3)[at_goal]
    np.testing.assert_allclose(np.linalg.norm(gap[:, :2], axis=-1), off, atol=5e-3)
    assert not np.asarray(states.metrics["success"]).any()
    assert np.asarray(states.metrics["physics_resets"]).sum() == 0
    with pytest.raises(ValueError, match="goal_start_prob"):
        make("put_in_container", goal_start_prob=0.5)


def test_clear_goals_put_cubes_sharing_a_goal_side_by_side_and_clear_of_a_cube_there():
    """`clear_goals`: both cubes away from their shared goal -> each aims clearance / 2 off
    it on its own side; one cube resting at the goal -> the other aims clearance from it, on
    the goal's side; goals clear of the other cube, and clearance 0, leave the goals as they
    are."""
    from mjx_skills.envs.two_objects import clear_goals

    env, c = make("two_in_container"), 0.05
    g = np.asarray(env.goal)
    goal = jnp.asarray(np.concatenate([g, g]))

    def scene(*cubes):
        return jnp.zeros(40).at[3:6].set(cubes[0]).at[25:28].set(cubes[1])

    away = (g + [0.0, -0.2, 0.0], g + [0.15, 0.1, 0.0])  # on the table, both outside
    aimed = np.asarray(clear_goals(env, scene(*away), goal, c))
    np.testing.assert_allclose(np.linalg.norm(aimed[:, :2] - g[:2], axis=-1), c / 2, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(aimed[0, :2] - aimed[1, :2]), c, atol=1e-6)
    for k in (0, 1):  # each on its own side: nearer its own cube than the other's aim is
        assert np.linalg.norm(aimed[k] - away[k]) < np.linalg.norm(aimed[1 - k] - away[k])
    there = g + [0.01, 0.0, 0.0]  # cube 0 rests 1 cm off the goal: cube 1 aims 5 cm from it
    aimed = np.asarray(clear_goals(env, scene(there, away[1]), goal, c))
    np.testing.assert_allclose(aimed[1], there + [-c, 0.0, 0.0], atol=1e-6)
    assert env.one_cube_success(jnp.asarray(aimed[1]), jnp.asarray(g))  # still inside
    far = (g + [0.0, -0.2, 0.0], g + [0.0, 0.2, 0.0])
    distinct = jnp.asarray(np.concatenate([g, g + [0.0, 0.1, 0.0]]))  # goals 10 cm apart
    np.testing.assert_allclose(clear_goals(env, scene(*far), distinct, c), distinct.reshape(2, 3))
    np.testing.assert_allclose(clear_goals(env, scene(there, g), goal, 0.0), goal.reshape(2, 3))
    one = make("put_in_container")
    np.testing.assert_allclose(clear_goals(one, jnp.zeros(25), one.goal, c), one.goal[None])


def test_the_scripted_controller_solves_none_aiming_both_cubes_at_the_shared_goal():
    """two_in_container's goal is the container's centre for both cubes. The script aimed
    at it drops the second cube onto the first (no episode solved); aimed by `clear_goals`
    instead of its fixed slots it passes the solvability bar (tests/envs/test_solvable.py): the
    room the second cube needs is the stage that aiming at the goal misses."""
    from mjx_skills.core import rollout
    from mjx_skills.envs.controllers import make_scripted_policy
    from mjx_skills.envs.two_objects import clear_goals

    env = make("two_in_container")
    centre = make_scripted_policy(env, slots=jnp.zeros((2, 3)))

    def aimed(obs, goal):
        return centre(obs, clear_goals(env, obs, goal, 0.05).reshape(-1))

    def rate(policy) -> float:
        behaviour = rollout.stateless(lambda key, obs, goal: jax.vmap(policy)(obs, goal))
        run = jax.jit(lambda key: rollout.run_episodes(env, behaviour, key, 64)[1])
        return float(run(jax.random.PRNGKey(1)).metrics["success"].mean())

    assert rate(centre) < 0.05
    assert rate(aimed) >= 0.9


def test_the_joint_pas_critic_refuses_two_cube_tasks_before_writing_anything(tmp_path):
    from mjx_skills import train

    with pytest.raises(SystemExit, match="one-cube tasks; two_in_container has 2 cubes"):
        train.main(
            ["mpas", "--task", "two_in_container", "--pas.critic", "joint", "--out", str(tmp_path)]
        )
    assert not any(tmp_path.iterdir())


def test_behaviour_cloning_refuses_an_explorer_that_drives_no_skill(tmp_path):
    """DDPG+HER+SL+BC clones the steps the search's skills drove; the scripted explorer
    drives none, and the method trained as plain DDPG+HER+SL without a word."""
    from mjx_skills import train

    with pytest.raises(SystemExit, match="--search.explorer scripted drives none"):
        train.main(
            [
                "ddpg_her_sl_bc",
                "--task",
                "pick_move",
                "--search.explorer",
                "scripted",
                "--out",
                str(tmp_path),
            ]
        )
    assert not any(tmp_path.iterdir())


@pytest.mark.skipif(not (DEFAULT_DIR / "manifest.json").exists(), reason="no built skill library")
@pytest.mark.parametrize("k", [0, 1])
def test_a_library_skill_acts_on_cube_k_as_on_the_cube_of_a_one_cube_scene(k):
    """The committed library (trained with one cube), applied to cube k of a two-cube scene
    through the projection, gives the actions it gives in the one-cube scene holding only
    that cube (grip and cube where they are), for every skill and goal."""
    from mjx_skills.envs.two_objects import object_views
    from mjx_skills.skills.library import load

    lib, _ = load(DEFAULT_DIR)
    two, one = make("pick_move_two"), make("pick_move")
    grip = np.array([0.62, -0.15, 0.02])
    cubes = np.array([[0.7, -0.3, -0.08], [0.6, -0.05, -0.08]])
    view = object_views(two, _obs(two, grip, cubes)[None])[:, k]
    alone = _obs(one, grip, cubes[k])[None]
    goals = jnp.asarray(
        np.random.default_rng(k).uniform([0.5, -0.4, -0.05], [0.8, 0.0, 0.1], (8, 3))
    )
    for skill in range(len(lib.names)):
        s = jnp.full((8,), skill, jnp.int32)
        on_view = lib.policy_action(s, jnp.repeat(view, 8, 0), goals)
        on_alone = lib.policy_action(s, jnp.repeat(alone, 8, 0), goals)
        np.testing.assert_allclose(np.asarray(on_view), np.asarray(on_alone), atol=2e-2)


@pytest.mark.skipif(not (DEFAULT_DIR / "manifest.json").exists(), reason="no built skill library")
@pytest.mark.parametrize("method", ["ddpg_her_sl", "mpas"])
def test_library_methods_train_on_two_cubes_with_the_one_cube_library(tmp_path, method):
    """A whole (tiny) run on pick_move_two: the library's skills drive steps on both cubes
    (the logged mean cube index lies strictly between 0 and 1)."""
    from mjx_skills.config import EnvConfig, PASConfig, SearchConfig, TrainConfig
    from mjx_skills.training.metrics_log import read_metrics
    from mjx_skills.training.runner import RunArgs, train_run

    sl = method == "ddpg_her_sl"
    train = TrainConfig(
        task="pick_move_two",
        epochs=1,
        envs=4,
        cycles=1,
        updates_per_cycle=2 if sl else TrainConfig().updates_per_cycle,
        eval_episodes=2,
        replay_capacity=2000,
        progress=False,
        out=str(tmp_path),
    )
    options = (
        {"search": SearchConfig(branching=3, height=2)}
        if sl
        else {"pas": PASConfig(hindsight=True, updates_per_cycle=2, skill_steps=5)}
    )
    args = RunArgs(train=train, method=method, env=EnvConfig(episode_length=40), options=options)
    (row,) = read_metrics(train_run(args))
    assert row["skill_calls"] > 0
    assert 0.0 < row["explore_object"] < 1.0, row["explore_object"]
    # The share of cubes at their goals bounds the success (both cubes) from above.
    assert row["eval_success"] <= row["eval_cubes"] <= 1.0


def test_the_stage_diagnostic_tells_a_second_cube_stacked_on_the_first_from_one_beside_it():
    """experiments/diagnostics/two_cube_stages.py on made-up episodes of 4 steps: cube 0 in
    from step 2 in both; cube 1 ends on top of it in the first, beside it in the second."""
    import runpy
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "experiments/diagnostics/two_cube_stages.py"
    stages = runpy.run_path(str(path))["stages"]
    at_goal = np.zeros((2, 4, 2), bool)
    at_goal[:, 2:, 0] = True
    held = np.zeros((2, 4, 2), bool)
    held[:, 3, 1] = True  # cube 1 held after cube 0 got there
    end = np.array(
        [[[0.7, -0.35, -0.08], [0.71, -0.35, -0.04]], [[0.7, -0.35, -0.08], [0.7, -0.25, -0.08]]]
    )
    out = stages(at_goal, held, end)
    assert out["cubes_at_goal_at_end"] == [0.0, 1.0, 0.0]
    assert out["one_there"]["other_on_top_of_the_first"] == 0.5
    assert out["one_there"]["other_cube_held_after"] == 1.0
    assert out["first_cube_there_at_step"] == 2.0


def test_deep_sets_networks_see_the_cubes_as_a_set_of_their_views():
    """--ddpg.architecture deep_sets: each cube's view is `object_views`'s; actor and critic
    give the same output with the two cubes (and their goals) swapped, but not with only the
    goals swapped; an MLP does not; a deep-sets agent without views is refused."""
    from mjx_skills.agents import ddpg
    from mjx_skills.config import DDPGConfig
    from mjx_skills.envs.two_objects import _CUBE_1, ONE, object_views, view_indices

    env = make("two_in_container")
    obs = jax.random.normal(jax.random.PRNGKey(0), (8, 40))
    goal = jax.random.normal(jax.random.PRNGKey(1), (8, 6))
    views = view_indices(env)
    gathered = np.stack([np.asarray(obs)[:, list(v)] for v in views], axis=1)
    np.testing.assert_array_equal(gathered, object_views(env, obs))
    swapped = obs.at[:, _CUBE_1].set(obs[:, ONE:]).at[:, ONE:].set(obs[:, _CUBE_1])
    other_goal = jnp.concatenate([goal[:, 3:], goal[:, :3]], axis=1)
    for arch in ("deep_sets", "mlp"):
        cfg = DDPGConfig(hidden=(32, 32, 32), architecture=arch)
        agent = ddpg.init(jax.random.PRNGKey(2), 40, 6, 4, cfg, views=views)
        a = ddpg.act(agent, obs, goal, cfg)
        same = np.abs(ddpg.act(agent, swapped, other_goal, cfg) - a).max()
        q_same = np.abs(
            ddpg.q_value(agent, swapped, other_goal, a, cfg)
            - ddpg.q_value(agent, obs, goal, a, cfg)
        ).max()
        assert (same < 1e-5 and q_same < 1e-4) if arch == "deep_sets" else same > 1e-3
        assert np.abs(ddpg.act(agent, obs, other_goal, cfg) - a).max() > 1e-3
    with pytest.raises(ValueError, match="views"):
        ddpg.init(jax.random.PRNGKey(2), 40, 6, 4, DDPGConfig(architecture="deep_sets"))
