"""The explorers on two cubes: the search never plans a transfer of the cube not held (with
goal clearance, beside the cube at the goal), Fast's proposals and MPAS transfer only the
cube held, and in order they work on the first cube not at its goal."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.envs import make


def _held_scene(two, n: int, held: int) -> jax.Array:
    """(n, 40) observations: cube `held` closed in the fingers, the other on the table."""
    from mjx_skills.envs.baxter import LAYOUT, OBS_OBJECT
    from mjx_skills.envs.two_objects import _CUBE_1
    from mjx_skills.skills.library import consistent
    from tests.fakes import states

    in_hand, _ = states(n, held=True)
    table, _ = states(n, held=False)
    on_table = consistent(LAYOUT, in_hand.at[:, OBS_OBJECT].set(table[:, OBS_OBJECT]))
    views = (in_hand, on_table) if held == 0 else (on_table, in_hand)
    obs = jnp.concatenate([views[0], views[1][:, _CUBE_1]], axis=1)
    np.testing.assert_allclose(two.project(obs, held), in_hand, atol=1e-6)
    return obs


def _free_scene(two, n: int) -> jax.Array:
    """(n, 40) observations: both cubes on the table 10 cm apart in y, the gripper open."""
    from mjx_skills.envs.baxter import LAYOUT, OBS_OBJECT
    from mjx_skills.envs.two_objects import _CUBE_1
    from mjx_skills.skills.library import consistent
    from tests.fakes import states

    free, _ = states(n, held=False)
    other = consistent(LAYOUT, free.at[:, OBS_OBJECT].add(jnp.array([0.0, 0.1, 0.0])))
    return jnp.concatenate([free, other[:, _CUBE_1]], axis=1)


@pytest.mark.parametrize("held", [0, 1])
@pytest.mark.parametrize("held_at_goal", [False, True])
def test_the_search_never_plans_a_transfer_of_the_cube_not_held(held, held_at_goal):
    """DDPG+HER+SL's explorer in a two-cube scene searches (skill, cube, goal). Holding a
    cube not yet at its goal it plans for that cube only (transfers: it finishes what it
    holds); once the held cube is at its goal it plans for the other cube only, and never
    a transfer of it."""
    from mjx_skills.agents import ddpg
    from mjx_skills.config import DDPGConfig, SearchConfig
    from mjx_skills.methods import ddpg_her_sl
    from tests.fakes import EnvState, KnownLibrary

    two, n = make("pick_move_two"), 512
    obs = _held_scene(two, n, held)
    rng = np.random.default_rng(10 + held)  # not states()'s seed: goals apart from the grip
    goal = jnp.asarray(rng.uniform([0.5, -0.4, 0.1] * 2, [0.85, 0.0, 0.2] * 2, (n, 6)), jnp.float32)
    achieved = two.achieved_from_obs(obs)
    if held_at_goal:  # the held cube's goal is where it is
        goal = goal.at[:, 3 * held : 3 * held + 3].set(achieved[:, 3 * held : 3 * held + 3])
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=achieved)
    agent = ddpg.init(jax.random.PRNGKey(1), 40, 6, 4, DDPGConfig(hidden=(16,)))
    cfg = SearchConfig(eps_start=1.0, eps_end=1.0, stall_memory=0, branching=3, height=2)
    beh = ddpg_her_sl.make_behaviour(
        agent, KnownLibrary(), jnp.zeros((), jnp.int32), two, cfg, DDPGConfig(hidden=(16,))
    )
    ps, _, record = jax.jit(beh.step)(
        beh.init(jax.random.PRNGKey(0), n), jax.random.PRNGKey(3), state
    )
    transfer = np.asarray(ps.run.skill) == KnownLibrary().names.index("transfer")
    cube = np.asarray(record["object"])
    assert np.asarray(record["skill_calls"]).all()
    done = np.asarray(two.cube_success(achieved, goal))[:, held]  # (a few by chance)
    assert done.all() if held_at_goal else done.mean() < 0.05
    assert np.all(cube[~done] == held) and np.all(transfer[~done])
    assert np.all(cube[done] != held) and not transfer[done].any()


@pytest.mark.parametrize("held", [0, 1])
def test_with_goal_clearance_the_search_transfers_the_held_cube_beside_the_one_at_the_goal(held):
    """Both cubes share one goal and the cube not held rests on it. The search scores a
    transfer by the distance of its end to the goal, so it aims the held cube onto the other
    one (within the 3 cm goal noise); with --search.goal-clearance 0.05 it aims it 5 cm
    from it (`clear_goals`), where both fit."""
    from mjx_skills.agents import ddpg
    from mjx_skills.config import DDPGConfig, SearchConfig
    from mjx_skills.methods import ddpg_her_sl
    from tests.fakes import EnvState, KnownLibrary

    two, n = make("two_in_container"), 256
    obs = _held_scene(two, n, held)
    achieved = two.achieved_from_obs(obs).reshape(n, 2, 3)
    resting = achieved[:, 1 - held]
    goal = jnp.concatenate([resting, resting], axis=1)  # the shared goal: where it rests
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=achieved.reshape(n, 6))
    short = ~np.asarray(two.cube_success(state.achieved_goal, goal))[:, held]
    agent = ddpg.init(jax.random.PRNGKey(1), 40, 6, 4, DDPGConfig(hidden=(16,)))
    gaps = []
    for clearance in (0.0, 0.05):
        cfg = SearchConfig(
            eps_start=1.0,
            eps_end=1.0,
            stall_memory=0,
            branching=5,
            height=1,
            waypoint_share=0.0,
            goal_clearance=clearance,
        )
        beh = ddpg_her_sl.make_behaviour(
            agent, KnownLibrary(), jnp.zeros((), jnp.int32), two, cfg, DDPGConfig(hidden=(16,))
        )
        ps, _, _ = jax.jit(beh.step)(
            beh.init(jax.random.PRNGKey(0), n), jax.random.PRNGKey(3), state
        )
        gaps.append(np.linalg.norm(np.asarray(ps.run.goal - resting)[short, :2], axis=-1))
    assert short.mean() > 0.9
    assert np.median(gaps[0]) < 0.03 and np.median(gaps[1]) > 0.04, [np.median(g) for g in gaps]


@pytest.mark.parametrize("held", [0, 1])
def test_the_fast_methods_proposals_transfer_only_the_cube_held(held):
    """DDPG+HER+SL+Fast's critic picks among proposals made on each cube's view towards that
    cube's goal: with a cube held short of its goal, only its transfer may be taken (none on
    the other cube's view), aiming at its own part of the 6-D goal; once it is at its goal
    the other cube's skills may start (they let it go); with none held, no transfer."""
    from mjx_skills.config import SearchConfig
    from mjx_skills.methods import ddpg_her_sl_fast as fast
    from tests.fakes import NAMES, EncodingLibrary

    two, n, per_cube = make("pick_move_two"), 64, 6
    obs = _held_scene(two, n, held)
    goal = jnp.asarray(
        np.random.default_rng(held).uniform([0.5, -0.4, 0.1] * 2, [0.85, 0.0, 0.2] * 2, (n, 6)),
        jnp.float32,
    )
    actions, ok = fast.propose_any(
        two, EncodingLibrary(), SearchConfig(), obs, goal, jax.random.key(4), per_cube
    )
    assert actions.shape == (n, 2 * per_cube, 4)
    short = ~np.asarray(two.cube_success(two.achieved_from_obs(obs), goal))[:, held]
    assert short.sum() > n // 2
    ok = np.asarray(ok).reshape(n, 2, per_cube)  # the held cube short of its goal: only it
    assert ok[:, held].all() and not ok[short, 1 - held].any()
    skill = np.rint(np.asarray(actions[..., 0]) * 10).astype(int).reshape(n, 2, per_cube)
    assert np.all(skill[:, held] == NAMES.index("transfer"))
    there = (
        goal.reshape(n, 2, 3).at[:, held].set(two.achieved_from_obs(obs).reshape(n, 2, 3)[:, held])
    )
    _, ok_there = fast.propose_any(
        two,
        EncodingLibrary(),
        SearchConfig(),
        obs,
        there.reshape(n, 6),
        jax.random.key(4),
        per_cube,
    )
    assert bool(jnp.all(ok_there))  # held at its goal: the other cube's skills may let it go
    free = _free_scene(two, n)  # both cubes on the table: transit and grasp on either
    free_actions, free_ok = fast.propose_any(
        two, EncodingLibrary(), SearchConfig(), free, goal, jax.random.key(4), per_cube
    )
    free_skill = np.rint(np.asarray(free_actions[..., 0]) * 10).astype(int)
    assert bool(jnp.all(free_ok)) and not np.any(free_skill == NAMES.index("transfer"))
    aim = np.asarray(actions[..., 1:]).reshape(n, 2, per_cube, 3)[:, held]
    near = np.linalg.norm(aim - np.asarray(goal).reshape(n, 2, 3)[:, held, None], axis=-1)
    assert np.mean(near < 0.03 * np.sqrt(3) + 1e-6) > 0.5


def test_in_order_the_explorers_work_on_the_first_cube_not_at_its_goal():
    """`workable` with in_order: nothing held -> the first cube not at its goal only; a cube
    held short of its goal -> that cube (whatever its index); without in_order, any cube but
    for a held one. DDPG+HER+SL+Fast's proposals follow it: with both cubes on the table and
    --search.in-order, only cube 0's are allowed, without it both cubes'."""
    from mjx_skills.config import SearchConfig
    from mjx_skills.envs.two_objects import workable
    from mjx_skills.methods import ddpg_her_sl_fast as fast
    from tests.fakes import EncodingLibrary

    held = jnp.array([[0, 0], [0, 1], [1, 0], [0, 0], [1, 0]], bool)
    at_goal = jnp.array([[0, 0], [0, 0], [0, 0], [1, 0], [1, 0]], bool)
    np.testing.assert_array_equal(
        workable(held, at_goal, True), [[1, 0], [0, 1], [1, 0], [0, 1], [0, 1]]
    )
    np.testing.assert_array_equal(
        workable(held, at_goal, False), [[1, 1], [0, 1], [1, 0], [1, 1], [1, 1]]
    )
    two, n, per_cube = make("two_in_container"), 32, 4
    obs = _free_scene(two, n)
    goal = jnp.broadcast_to(jnp.concatenate([two.goal, two.goal]), (n, 6))
    for in_order in (True, False):
        _, ok = fast.propose_any(
            two,
            EncodingLibrary(),
            SearchConfig(in_order=in_order),
            obs,
            goal,
            jax.random.key(5),
            per_cube,
        )
        ok = np.asarray(ok).reshape(n, 2, per_cube)
        assert ok[:, 0].all() and (not ok[:, 1].any() if in_order else ok[:, 1].all())


@pytest.mark.parametrize("held", [0, 1])
def test_mpas_chooses_cube_and_skill_and_transfers_only_the_cube_held(held):
    """MPAS's meta-controller in a two-cube scene chooses among (cube, skill) pairs: exploring
    at random over many envs it picks both cubes and transfer, transfer only for the held
    cube; the chosen skill's policy sees the chosen cube's view, and a grasp's goal is named
    on that view (above that cube)."""
    from mjx_skills.agents import mpdqn
    from mjx_skills.config import DDPGConfig, PASConfig
    from mjx_skills.envs.baxter import OBS_OBJECT
    from mjx_skills.methods import pas
    from tests.fakes import NAMES, EnvState, KnownLibrary

    class ViewLibrary(KnownLibrary):
        """Its policies say which skill acts and where the cube of their view is."""

        def policy_action(self, skill, obs, goal):
            return jnp.concatenate([skill[:, None] / 10.0, obs[:, OBS_OBJECT]], axis=-1)

        def reached(self, skill, obs, goal):
            return jnp.zeros(skill.shape, bool)

    two, n, K = make("pick_move_two"), 512, len(NAMES)
    obs = _held_scene(two, n, held)
    goal = jnp.asarray(
        np.random.default_rng(held).uniform([0.5, -0.4, 0.1] * 2, [0.85, 0.0, 0.2] * 2, (n, 6)),
        jnp.float32,
    )
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=two.achieved_from_obs(obs))
    config = DDPGConfig(hidden=(16,), random_eps=1.0)  # a uniformly random allowed choice
    agent = mpdqn.init(jax.random.PRNGKey(1), 40, 6, 2 * K, config)
    beh = pas.make_behaviour(agent, ViewLibrary(), two, PASConfig(), config, noisy=True)
    ms, action, record = jax.jit(beh.step)(
        beh.init(jax.random.PRNGKey(0), n), jax.random.PRNGKey(3), state
    )
    choice = np.asarray(ms.skill)
    cube, skill = choice // K, choice % K
    transfer = skill == NAMES.index("transfer")
    assert transfer.any() and (cube != held).any(), "both kinds of choice were made"
    assert np.all(cube[transfer] == held)
    np.testing.assert_array_equal(np.rint(np.asarray(action[:, 0]) * 10), skill)
    cubes = np.asarray(two.achieved_from_obs(obs)).reshape(n, 2, 3)
    np.testing.assert_allclose(np.asarray(action[:, 1:]), cubes[np.arange(n), cube], atol=1e-5)
    grasp = skill == NAMES.index("grasp")
    chosen_goal = np.asarray(record["meta_action"])[:, 2 * K :]
    assert grasp.any()
    np.testing.assert_allclose(chosen_goal[grasp, :2], cubes[grasp, cube[grasp], :2], atol=1e-5)
