"""The look-ahead search and the exploring behaviour, with a hand-built library whose
classifier, critic and coarse model are known functions."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig, SearchConfig
from mjx_skills.envs.baxter import LAYOUT, OBS_GRIP, OBS_OBJECT
from mjx_skills.methods import ddpg_her_sl
from mjx_skills.skills import lookahead
from mjx_skills.skills.library import consistent
from tests.fakes import NAMES, EnvState, KnownLibrary, states


def test_one_level_search_returns_the_known_best_edge(env):
    cfg = SearchConfig(height=1, branching=6)
    lib = KnownLibrary()
    obs, goal = states(8, held=False)
    key = jax.random.PRNGKey(3)
    found = jax.jit(lambda o, g: lookahead.search(lib, cfg, env, o, g, key))(obs, goal)
    skill, goals, ok = lookahead.sample_edges(
        lib,
        cfg,
        obs,
        goal,
        lookahead.level_draws(lookahead.draw_edges(lookahead.env_keys(key, 8), cfg, 3), 0, 6),
    )
    nxt = jax.vmap(lambda s, g: lib.next_state(s, obs, g), in_axes=(1, 1), out_axes=1)(skill, goals)
    utility = -goals[..., 0] + cfg.gamma * lookahead.leaf_value(cfg, env, nxt, goal[:, None])
    best = np.argmax(np.where(ok, utility, -np.inf), axis=1)
    np.testing.assert_array_equal(
        found.skill, np.take_along_axis(np.asarray(skill), best[:, None], 1)[:, 0]
    )
    np.testing.assert_allclose(
        found.goal, np.take_along_axis(np.asarray(goals), best[:, None, None], 1)[:, 0], atol=1e-6
    )
    assert not np.any(found.all_pruned)


@dataclasses.dataclass(frozen=True)
class GoalLeafLibrary(KnownLibrary):
    """The coarse model must not be asked: with leaf_state = "goal" a one-level tree's
    leaves are the skills' goals."""

    def next_state(self, skill, obs, goal):
        raise AssertionError("the coarse model was called for a leaf")

    at_goal = KnownLibrary.next_state


def test_goal_leaves_skip_the_model_and_score_the_goals(env):
    cfg = SearchConfig(height=1, branching=6, leaf_state="goal")
    obs, goal = states(8, held=False)
    key = jax.random.PRNGKey(3)
    found = lookahead.search(GoalLeafLibrary(), cfg, env, obs, goal, key)
    want = lookahead.search(
        KnownLibrary(), dataclasses.replace(cfg, leaf_state="predicted"), env, obs, goal, key
    )
    np.testing.assert_array_equal(found.skill, want.skill)
    np.testing.assert_allclose(found.utility, want.utility, rtol=1e-6)


def test_skills_follow_the_grasp_state_and_pruned_edges_are_never_chosen(env):
    cfg = SearchConfig()
    run = jax.jit(lambda lib, o, g, k: lookahead.search(lib, cfg, env, o, g, k), static_argnums=0)
    free, goal = states(32, held=False)
    held, _ = states(32, held=True)
    for seed in range(3):
        key = jax.random.PRNGKey(seed)
        # The cube on the table: transit or grasp first; with grasp pruned, always transit.
        first = np.asarray(run(KnownLibrary(), free, goal, key).skill)
        assert set(first) <= {0, 1}
        found = run(KnownLibrary(pruned=(1,)), free, goal, key)
        kept = ~np.asarray(found.all_pruned)  # (all five samples grasp: nothing to choose)
        assert kept.sum() > 20 and set(np.asarray(found.skill)[kept]) == {0}
        # The cube held: only transfer.
        assert set(np.asarray(run(KnownLibrary(), held, goal, key).skill)) == {2}


def test_an_all_pruned_tree_says_so_and_the_policy_acts(env):
    cfg = SearchConfig(eps_start=1.0, eps_end=1.0)
    lib = KnownLibrary(pruned=(0, 1, 2))
    obs, goal = states(6, held=False)
    found = lookahead.search(lib, cfg, env, obs, goal, jax.random.PRNGKey(0))
    assert np.all(found.all_pruned) and np.all(np.isneginf(found.utility))
    from mjx_skills.agents import ddpg

    agent = ddpg.init(jax.random.PRNGKey(1), 25, 3, 4, DDPGConfig())
    beh = ddpg_her_sl.make_behaviour(agent, lib, jnp.zeros((), jnp.int32), env, cfg, DDPGConfig())
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=obs[:, OBS_OBJECT])
    ps, action, record = beh.step(beh.init(jax.random.PRNGKey(2), 6), jax.random.PRNGKey(3), state)
    assert (
        not np.any(ps.run.active)
        and np.all(record["all_pruned"])
        and not np.any(record["skill_calls"])
    )
    assert not np.allclose(action, 0.5)  # the learned policy's noisy action, not a skill's


def test_the_behaviour_commits_for_at_most_w_steps_and_follows_eps(env):
    from mjx_skills.agents import ddpg

    agent = ddpg.init(jax.random.PRNGKey(1), 25, 3, 4, DDPGConfig())
    obs, goal = states(256, held=False)
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=obs[:, OBS_OBJECT])
    for eps, w in ((1.0, 3), (0.3, 4)):
        # stall_memory 0: the state here never moves, which the stall memory takes for a stall.
        cfg = SearchConfig(eps_start=eps, eps_end=eps, skill_steps=w, stall_memory=0)
        beh = ddpg_her_sl.make_behaviour(
            agent, KnownLibrary(), jnp.zeros((), jnp.int32), env, cfg, DDPGConfig()
        )
        step = jax.jit(beh.step)
        ps = beh.init(jax.random.PRNGKey(0), 256)
        calls, driven = [], []
        for t in range(12):
            ps, _, record = step(ps, jax.random.PRNGKey(100 + t), state)
            calls.append(np.asarray(record["skill_calls"]))
            driven.append(np.asarray(record["skill_driven"]))
            assert np.all(np.asarray(ps.run.steps)[np.asarray(ps.run.active)] <= w)
        calls = np.array(calls)
        if eps == 1.0:  # a skill at once, replaced exactly every w steps
            np.testing.assert_array_equal(calls[::w], 1)
            assert calls.sum() == 256 * len(range(0, 12, w))
        else:  # a decision starts a skill with probability eps (5 sigma)
            decisions = calls.sum() + (~np.array(driven)).sum()
            share = calls.sum() / decisions
            assert abs(share - eps) < 5 * np.sqrt(eps * (1 - eps) / decisions), share


@dataclasses.dataclass(frozen=True)
class TerminatingLibrary(KnownLibrary):
    """Every running skill reports `terminated` at once."""

    def terminated(self, skill, obs, goal):
        return jnp.ones(skill.shape, bool)


def test_a_terminated_skill_hands_back_the_decision_at_once(env):
    """With eps = 1 and w = 5, a skill that terminates is replaced by a new search at the
    very next step (KnownLibrary's never terminate: a new skill only every 5 steps)."""
    from mjx_skills.agents import ddpg

    agent = ddpg.init(jax.random.PRNGKey(1), 25, 3, 4, DDPGConfig())
    obs, goal = states(16, held=False)
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=obs[:, OBS_OBJECT])
    cfg = SearchConfig(eps_start=1.0, eps_end=1.0, skill_steps=5, stall_memory=0)
    for lib, every in ((TerminatingLibrary(), 1), (KnownLibrary(), 5)):
        beh = ddpg_her_sl.make_behaviour(
            agent, lib, jnp.zeros((), jnp.int32), env, cfg, DDPGConfig()
        )
        step = jax.jit(beh.step)
        ps, calls = beh.init(jax.random.PRNGKey(0), 16), []
        for t in range(10):
            ps, _, record = step(ps, jax.random.PRNGKey(t), state)
            calls.append(np.asarray(record["skill_calls"]))
        calls = np.array(calls)
        np.testing.assert_array_equal(calls[::every], 1)
        assert calls.sum() == 16 * len(range(0, 10, every))


def test_the_oracle_explorer_acts_with_the_scripted_controller_at_rate_eps(env_factory):
    """explorer = "scripted": at eps = 1 every action is the task's scripted controller's,
    at eps = 0 none is (the learned policy's noisy action instead)."""
    from mjx_skills.agents import ddpg
    from mjx_skills.envs.controllers import make_scripted_policy

    task = env_factory("pick_move")
    agent = ddpg.init(jax.random.PRNGKey(1), 25, 3, 4, DDPGConfig())
    obs, goal = states(64, held=False)
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=obs[:, OBS_OBJECT])
    scripted = np.asarray(jax.vmap(make_scripted_policy(task))(obs, goal))
    for eps in (1.0, 0.0):
        cfg = SearchConfig(explorer="scripted", eps_start=eps, eps_end=eps)
        beh = ddpg_her_sl.make_scripted_behaviour(
            agent, jnp.zeros((), jnp.int32), task, cfg, DDPGConfig()
        )
        _, action, _ = beh.step(beh.init(jax.random.PRNGKey(0), 64), jax.random.PRNGKey(5), state)
        same = np.all(np.isclose(np.asarray(action), scripted, atol=1e-6), axis=1)
        assert same.all() if eps == 1.0 else not same.any()


def test_epsilon_decays_linearly():
    cfg = SearchConfig(eps_start=1.0, eps_end=0.001, eps_decay_epochs=30)
    np.testing.assert_allclose(
        ddpg_her_sl.epsilon(cfg, jnp.array([0, 15, 30, 60])), [1.0, 0.5005, 0.001, 0.001], atol=1e-6
    )


def test_the_floor_by_success_falls_as_the_evaluated_success_rises():
    fixed = SearchConfig(eps_end=0.1, eps_decay_epochs=10)
    by_success = dataclasses.replace(fixed, eps_floor_by_success=True)
    success = jnp.array([0.0, 0.5, 0.9, 1.0])
    # Past the decay: the floor, times 1 - success; a fixed floor ignores the success.
    np.testing.assert_allclose(
        ddpg_her_sl.epsilon(by_success, 12, success), [0.1, 0.05, 0.01, 0.0], atol=1e-6
    )
    np.testing.assert_allclose(ddpg_her_sl.epsilon(fixed, 12, success), 0.1, atol=1e-6)
    # During the decay it heads for that floor: halfway at epoch 5.
    np.testing.assert_allclose(ddpg_her_sl.epsilon(by_success, 5, 1.0), 0.5, atol=1e-6)
    np.testing.assert_allclose(ddpg_her_sl.epsilon(by_success, 0, 1.0), 1.0, atol=1e-6)


def test_a_solved_task_holds_still(env):
    from mjx_skills.agents import ddpg

    agent = ddpg.init(jax.random.PRNGKey(1), 25, 3, 4, DDPGConfig())
    obs, _ = states(4, held=True)
    goal = obs[:, OBS_OBJECT]  # the cube is at the task goal already
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=goal)
    cfg = SearchConfig(eps_start=1.0, eps_end=1.0)
    beh = ddpg_her_sl.make_behaviour(
        agent, KnownLibrary(), jnp.zeros((), jnp.int32), env, cfg, DDPGConfig()
    )
    ps, action, record = beh.step(beh.init(jax.random.PRNGKey(0), 4), jax.random.PRNGKey(1), state)
    assert np.all(record["holds"]) and not np.any(record["searches"]) and not np.any(ps.run.active)
    np.testing.assert_allclose(action[:, :3], 0.0)
    np.testing.assert_allclose(action[:, 3], np.where(np.asarray(env.grasped(obs)), -1.0, 1.0))


# Obstacles remembered where a skill stalled, and waypoint transfer goals (`stalls.py`): the
# explorer's online correction of coarse models that never saw container_wall's wall.

TRANSFER, GRASP = NAMES.index("transfer"), NAMES.index("grasp")
Z = jnp.array([0.0, 0.0, 1.0])


def test_waypoints_spread_transfer_goals_over_the_goal_box(env):
    held, goal = states(64, held=True)
    lib = KnownLibrary()
    for share, far in ((0.0, 0), (0.5, 100)):
        cfg = SearchConfig(waypoint_share=share)
        draws = lookahead.draw_edges(lookahead.env_keys(jax.random.PRNGKey(0), 64), cfg, 3)
        skill, goals, _ = lookahead.sample_edges(
            lib, cfg, held, goal, lookahead.level_draws(draws, 0, cfg.branching)
        )
        assert np.all(np.asarray(skill) == TRANSFER)
        dist = np.abs(np.asarray(goals) - np.asarray(goal)[:, None]).max(-1)
        # Within transfer_goal_noise of the task goal, unless a waypoint (5 sigma bounds).
        assert (dist > 0.031).sum() >= far
        low, high = lib.envs[TRANSFER].object_goal_box()
        assert np.all((np.asarray(goals) >= low - 1e-6) & (np.asarray(goals) <= high + 1e-6))


def test_grasp_starts_only_within_its_initiation_set_and_the_search_plans_transit_first(env):
    """With grasp_reach r, no grasp edge is drawn where the gripper is farther than r from
    the cube, so the search's first skill there is transit; within r grasp is drawn; with
    r = 0 (the thesis) grasp is drawn anywhere with an empty gripper."""
    free, goal = states(64, held=False)  # the gripper 6-16 cm above the cube: out of reach
    near = consistent(LAYOUT, free.at[:32, OBS_GRIP].set(free[:32, OBS_OBJECT] + 0.03 * Z))
    far = np.linalg.norm(np.asarray(near[:, OBS_OBJECT] - near[:, OBS_GRIP]), axis=-1) > 0.06
    assert far.tolist() == [False] * 32 + [True] * 32
    for reach in (0.0, 0.06):
        cfg = SearchConfig(grasp_reach=reach)
        draws = lookahead.draw_edges(lookahead.env_keys(jax.random.PRNGKey(0), 64), cfg, 3)
        skill, _, ok = lookahead.sample_edges(
            KnownLibrary(), cfg, near, goal, lookahead.level_draws(draws, 0, cfg.branching)
        )
        grasp = np.asarray(skill == GRASP) & np.asarray(ok)
        assert np.asarray(ok).all() and grasp[~far].any()
        assert grasp[far].any() == (reach == 0.0)
    found = lookahead.search(KnownLibrary(), cfg, env, near, goal, jax.random.PRNGKey(1))
    assert set(np.asarray(found.skill)[far]) == {0}


@dataclasses.dataclass(frozen=True)
class CountingLibrary(KnownLibrary):
    """Counts the searched tree rows: the classifier is asked once per level and row."""

    calls: list = dataclasses.field(default_factory=list, compare=False, hash=False)

    def success_prob(self, skill, obs, goal):
        jax.debug.callback(lambda n: self.calls.append(int(n)), skill.shape[0])
        return super().success_prob(skill, obs, goal)


def test_search_where_searches_only_the_deciding_envs_each_with_its_own_key(env):
    lib = KnownLibrary()
    obs, goal = states(8, held=False)
    key = jax.random.PRNGKey(5)
    where = jnp.array([1, 0, 0, 1, 1, 0, 1, 0], bool)
    results = {
        chunk: jax.jit(
            lambda w, c=chunk: lookahead.search_where(
                lib, SearchConfig(search_chunk=c), env, w, obs, goal, key
            )
        )(where)
        for chunk in (0.125, 0.25, 1.0)
    }
    for found in results.values():
        np.testing.assert_array_equal(found.all_pruned, ~np.asarray(where))
        for i in np.flatnonzero(where):  # env i alone, with its own key
            keys = lookahead.env_keys(key, 8)[i : i + 1]
            alone = lookahead.search_envs(
                lib, SearchConfig(), env, obs[i : i + 1], goal[i : i + 1], keys
            )
            assert found.skill[i] == alone.skill[0]
            np.testing.assert_allclose(found.goal[i], alone.goal[0], atol=1e-6)
            np.testing.assert_allclose(found.utility[i], alone.utility[0], rtol=1e-5)


def test_the_search_runs_only_where_some_env_of_some_seed_explores(env):
    """Inside the trainer's vmap over seeds the guard stays a branch: no tree row is
    evaluated at a step where no env of either seed explores, and one exploring env costs
    one round of chunks, not a search of the whole batch at every step (the old cond on a
    batched predicate ran the whole tree for every env at every step)."""
    from mjx_skills.core import rollout

    agent = ddpg.init(jax.random.PRNGKey(1), 25, 3, 4, DDPGConfig())
    obs, goal = states(4, held=False)
    state = EnvState(obs=obs, desired_goal=goal, achieved_goal=obs[:, OBS_OBJECT])
    # 2 of the 2 x 4 envs per round; no stall memory: the static state would count as stalls.
    cfg = SearchConfig(search_chunk=0.25, stall_memory=0)
    over_seeds = lambda f: jax.vmap(f, axis_name=rollout.SEED_AXIS)
    # One env of one seed explores: one round, every level of the tree asked once, and the
    # env gets what it would searching alone with its own key.
    lib = CountingLibrary()
    where = jnp.zeros((2, 4), bool).at[1, 2].set(True)
    key = jax.random.PRNGKey(0)
    found = over_seeds(lambda w, o, g: lookahead.search_where(lib, cfg, env, w, o, g, key))(
        where, jnp.stack([obs, obs]), jnp.stack([goal, goal])
    )
    alone = lookahead.search_envs(
        KnownLibrary(), cfg, env, obs[2:3], goal[2:3], lookahead.env_keys(key, 4)[2:3]
    )
    assert np.all(found.all_pruned == ~np.asarray(where))
    assert found.skill[1, 2] == alone.skill[0]
    np.testing.assert_allclose(found.goal[1, 2], alone.goal[0], atol=1e-6)
    one_round = len(lib.calls)
    # Pooled over the seeds: a round searches a chunk of a quarter of the 2 x 4 envs, 2 rows
    # per tree node (searched seed by seed it would be 1).
    assert sorted(lib.calls) == [2 * cfg.branching**level for level in range(1, cfg.height + 1)]
    seeds = jax.random.split(jax.random.PRNGKey(0), 2)
    for eps in (0.0, 1.0):
        lib = CountingLibrary()
        cfg = dataclasses.replace(cfg, eps_start=eps, eps_end=eps)
        beh = ddpg_her_sl.make_behaviour(
            agent, lib, jnp.zeros((), jnp.int32), env, cfg, DDPGConfig()
        )

        def steps(key, beh=beh):
            ps = beh.init(key, 4)
            for t in range(3):
                ps, _, record = beh.step(ps, jax.random.fold_in(key, t), state)
            return record["searches"]

        jax.block_until_ready(over_seeds(steps)(seeds))
        # eps 0: never; eps 1: all 8 envs of the 2 seeds decide at the first step only
        # (skills run w = 10 steps), pooled: 4 rounds of 2 envs (a quarter of 8).
        assert len(lib.calls) == (0 if eps == 0.0 else 4 * one_round), eps
        assert set(lib.calls) <= {2 * cfg.branching**level for level in range(1, cfg.height + 1)}


def test_the_random_skill_explorer_draws_uniform_allowed_skills_and_scores_nothing(env):
    """explorer = "random", the trivial baseline: a skill uniform among those allowed (transit
    or grasp with the cube on the table, transfer with it held), goals drawn as the search
    draws them but never scored (a skill the classifier prunes is drawn as often), rows
    not deciding get nothing; in the behaviour every
    deciding env starts a skill at eps = 1."""
    cfg = SearchConfig()
    free, goal = states(512, held=False)
    held, _ = states(512, held=True)
    where = jnp.arange(512) % 4 != 0
    draw = jax.jit(lambda o, g, k: lookahead.random_edges(KnownLibrary(), cfg, where, o, g, k))
    found = draw(free, goal, jax.random.PRNGKey(0))
    skill, pruned = np.asarray(found.skill), np.asarray(found.all_pruned)
    assert np.array_equal(pruned, ~np.asarray(where))
    assert np.all(np.isneginf(np.asarray(found.utility)[pruned]))
    assert set(skill[~pruned]) == {0, 1} and abs(np.mean(skill[~pruned] == 1) - 0.5) < 0.08
    key1 = jax.random.PRNGKey(1)
    carried = draw(held, goal, key1)
    assert set(np.asarray(carried.skill)[np.asarray(where)]) == {2}
    # The classifier is never asked: grasp pruned by it is still drawn about half the time.
    unscored = lookahead.random_edges(KnownLibrary(pruned=(1,)), cfg, where, free, goal, key1)
    assert abs(np.mean(np.asarray(unscored.skill)[np.asarray(where)] == 1) - 0.5) < 0.08

    agent = ddpg.init(jax.random.PRNGKey(1), 25, 3, 4, DDPGConfig())
    every = SearchConfig(explorer="random", eps_start=1.0, eps_end=1.0)
    beh = ddpg_her_sl.make_behaviour(
        agent, KnownLibrary(), jnp.zeros((), jnp.int32), env, every, DDPGConfig()
    )
    obs, goal8 = states(8, held=False)
    state = EnvState(obs=obs, desired_goal=goal8, achieved_goal=obs[:, OBS_OBJECT])
    ps, action, record = beh.step(beh.init(jax.random.PRNGKey(2), 8), jax.random.PRNGKey(3), state)
    assert np.all(record["skill_calls"] == 1) and np.all(ps.run.active)
    assert np.allclose(action, 0.5)  # the skills' actions (KnownLibrary.policy_action)
