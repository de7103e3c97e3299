"""HER sampling: relabelled goals come from the right steps of the same episode."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.core import her, replay
from mjx_skills.core.rollout import Episode

T = 10
N_FILLED = 12  # of 30 slots: sampling must stay within the filled ones
N = 8192


def make_episodes(ids: np.ndarray) -> Episode:
    """ag[t] = (id, t); desired goals (-id, -t) never equal an achieved goal (ids >= 1)."""
    ids = np.asarray(ids, np.float32)
    i1 = np.broadcast_to(ids[:, None], (len(ids), T + 1))
    s1 = np.broadcast_to(np.arange(T + 1, dtype=np.float32), (len(ids), T + 1))
    i, s = i1[:, :T], s1[:, :T]
    return Episode(
        obs=np.stack([i1, s1, -i1], axis=-1),
        ag=np.stack([i1, s1], axis=-1),
        g=np.stack([-i, -s], axis=-1),
        actions=np.stack([i, s], axis=-1),
    )


def compute_reward(achieved: jax.Array, desired: jax.Array) -> jax.Array:
    return jnp.where(jnp.all(jnp.abs(achieved - desired) < 0.5, axis=-1), 0.0, -1.0)


def _chi2_threshold(df: int, z: float = 5.0) -> float:
    """Wilson-Hilferty approximation of the chi-square quantile at standard-normal z."""
    c = 2.0 / (9.0 * df)
    return df * (1.0 - c + z * np.sqrt(c)) ** 3


@pytest.fixture(scope="module")
def buffer() -> replay.ReplayState:
    example = jax.tree.map(lambda x: x[0], make_episodes(np.array([1])))
    state = replay.init(30 * T, example)
    return replay.add(state, make_episodes(np.arange(1, N_FILLED + 1)))


@functools.cache
def sampler(strategy: str):
    # relabel_prob stays traced, so each strategy compiles once.
    return jax.jit(
        functools.partial(her.sample_batch, compute_reward=compute_reward, strategy=strategy),
        static_argnums=2,
    )


def sample(buffer, strategy: str, relabel_prob: float, seed: int = 0, n: int = N):
    batch = sampler(strategy)(buffer, jax.random.key(seed), n, relabel_prob=relabel_prob)
    return {k: np.asarray(v) for k, v in batch.items()}


def check_common(batch: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checks every strategy shares; returns episode ids, steps t and the relabel mask."""
    ep, t = batch["obs"][:, 0], batch["obs"][:, 1]
    assert batch["obs"].shape == (N, 3) and batch["goal"].shape == (N, 2)
    assert batch["reward"].shape == (N,)
    assert ep.min() >= 1 and ep.max() <= N_FILLED  # filled slots only
    assert t.min() >= 0 and t.max() <= T - 1
    np.testing.assert_array_equal(batch["next_obs"], np.stack([ep, t + 1, -ep], -1))
    np.testing.assert_array_equal(batch["ag"], np.stack([ep, t], -1))
    np.testing.assert_array_equal(batch["next_ag"], np.stack([ep, t + 1], -1))
    np.testing.assert_array_equal(batch["action"], np.stack([ep, t], -1))
    expected_reward = np.asarray(compute_reward(batch["next_ag"], batch["goal"]))
    np.testing.assert_array_equal(batch["reward"], expected_reward)
    relabelled = batch["goal"][:, 0] > 0
    # Goals left alone are the episode's desired goal at t.
    np.testing.assert_array_equal(batch["goal"][~relabelled], np.stack([-ep, -t], -1)[~relabelled])
    # Any relabelled goal is an achieved goal of the same episode.
    np.testing.assert_array_equal(batch["goal"][relabelled, 0], ep[relabelled])
    return ep, t, relabelled


def test_future(buffer):
    batch = sample(buffer, "future", 0.8)
    _, t, rel = check_common(batch)
    assert abs(rel.mean() - 0.8) < 0.03
    f = batch["goal"][rel, 1]
    tr = t[rel]
    assert np.all(f > tr) and np.all(f <= T)
    # f is uniform over t + 1..T for every t: pooled chi-square over the per-t histograms.
    stat, df = 0.0, 0
    for step in range(T):
        fs = f[tr == step].astype(int)
        m = T - step
        counts = np.bincount(fs - step - 1, minlength=m)
        assert counts.size == m and np.all(counts > 0), (step, counts)
        if m > 1:
            expected = fs.size / m
            stat += np.sum((counts - expected) ** 2 / expected)
            df += m - 1
    assert stat < _chi2_threshold(df), (stat, df)
    # f = t + 1 makes the relabelled goal the next achieved goal: a success.
    assert np.all(batch["reward"][rel & (batch["goal"][:, 1] == t + 1)] == 0.0)
    assert np.any(batch["reward"] == 0.0) and np.any(batch["reward"] == -1.0)


def test_final(buffer):
    batch = sample(buffer, "final", 0.8)
    _, t, rel = check_common(batch)
    assert abs(rel.mean() - 0.8) < 0.03
    assert np.all(batch["goal"][rel, 1] == T)
    np.testing.assert_array_equal(batch["reward"][rel], np.where(t[rel] == T - 1, 0.0, -1.0))


def test_episode(buffer):
    batch = sample(buffer, "episode", 0.8)
    _, _, rel = check_common(batch)
    assert abs(rel.mean() - 0.8) < 0.03
    steps = batch["goal"][rel, 1].astype(int)
    counts = np.bincount(steps, minlength=T + 1)
    assert counts.size == T + 1 and np.all(counts > 0)  # 0..T, earlier steps included


@pytest.mark.parametrize("strategy", ["future", "final", "episode", "none"])
def test_relabel_prob_extremes_and_none(buffer, strategy):
    for p in (0.0, 1.0):
        batch = sample(buffer, strategy, p, seed=3)
        _, _, rel = check_common(batch)
        assert rel.mean() == (p if strategy != "none" else 0.0)
    if strategy == "none":
        # Unrelabelled desired goals never match here, so every reward is -1.
        assert np.all(sample(buffer, "none", 0.8)["reward"] == -1.0)


def test_vmap_over_seeds(buffer):
    stacked = jax.tree.map(lambda x: jnp.stack([x, x]), buffer)
    keys = jax.random.split(jax.random.key(1), 2)
    fn = jax.vmap(lambda s, k: her.sample_batch(s, k, 16, compute_reward, "future", 0.8))
    batch = fn(stacked, keys)
    assert batch["goal"].shape == (2, 16, 2) and batch["reward"].shape == (2, 16)
    assert not np.array_equal(batch["obs"][0], batch["obs"][1])  # independent keys


def test_unknown_strategy(buffer):
    with pytest.raises(ValueError):
        her.sample_batch(buffer, jax.random.key(0), 4, compute_reward, "later", 0.8)


def test_the_last_step_of_an_episode_bootstraps_through_the_time_limit(buffer):
    """Episodes end by time limit only: a transition at the last step (t = T - 1) carries no
    terminal flag, its next observation is the episode's final one, and its critic target
    depends on that observation through gamma * Q' (it is not the reward alone)."""
    from mjx_skills.agents import ddpg
    from mjx_skills.config import DDPGConfig

    batch = sampler("none")(buffer, jax.random.key(3), 512, relabel_prob=0.0)
    assert "terminal" not in batch
    last = np.asarray(batch["obs"][:, 1]) == T - 1
    assert last.sum() > 10
    np.testing.assert_array_equal(np.asarray(batch["next_obs"])[last, 1], T)  # the final obs
    config = DDPGConfig(hidden=(16,), clip_target=False)
    state = ddpg.init(jax.random.key(0), 3, 2, 2, config)
    state = ddpg.observe(state, batch["obs"], batch["goal"])
    learner_batch = {k: batch[k] for k in ("obs", "next_obs", "goal", "action", "reward")}
    y = np.asarray(ddpg.td_target(state, learner_batch, config))
    moved = {**learner_batch, "next_obs": batch["next_obs"] + 3.0}
    y_moved = np.asarray(ddpg.td_target(state, moved, config))
    reward = np.asarray(batch["reward"])
    assert np.all(np.abs(y[last] - reward[last]) > 1e-6)  # gamma * Q' is there
    assert np.all(np.abs(y[last] - y_moved[last]) > 1e-6)  # and reads the final observation


@pytest.mark.parametrize("n_step", [3, 5])
def test_n_step_returns_sum_the_relabelled_rewards_of_the_same_episode(buffer, n_step):
    """n-step HER: the reward is the discounted sum of rewards recomputed under the
    relabelled goal over the next min(n, T - t) steps of the same episode, next_obs lies
    that many steps later, and the discount is gamma to that power."""
    gamma = 0.9
    fn = jax.jit(
        functools.partial(
            her.sample_batch,
            compute_reward=compute_reward,
            strategy="future",
            n_step=n_step,
            gamma=gamma,
        ),
        static_argnums=2,
    )
    batch = {
        k: np.asarray(v) for k, v in fn(buffer, jax.random.key(5), N, relabel_prob=0.8).items()
    }
    ep, t = batch["obs"][:, 0], batch["obs"][:, 1]
    goal_step = np.where(batch["goal"][:, 0] > 0, batch["goal"][:, 1], -1)  # -1: never reached
    m = np.minimum(n_step, T - t)
    expected = np.zeros(N)
    for i in range(n_step):
        reached = (t + i + 1) == goal_step
        expected += np.where(i < m, gamma**i * np.where(reached, 0.0, -1.0), 0.0)
    np.testing.assert_allclose(batch["reward"], expected, rtol=1e-6)
    np.testing.assert_array_equal(batch["next_obs"], np.stack([ep, t + m, -ep], -1))
    np.testing.assert_allclose(batch["discount"], gamma**m, rtol=1e-6)
    # Some sums hold a success inside the window after a failure, and some windows are cut
    # by the episode's end: both cases are exercised.
    assert np.any((expected > -m) & (expected < 0)) and np.any(m < n_step)


def test_the_critic_target_discounts_by_the_batch_discount():
    """A batch `discount` replaces gamma in r + gamma * Q' (n-step returns)."""
    from mjx_skills.agents import ddpg
    from mjx_skills.config import DDPGConfig

    config = DDPGConfig(hidden=(16,), clip_target=False, gamma=0.9)
    state = ddpg.init(jax.random.key(0), 3, 2, 2, config)
    rng = np.random.default_rng(0)
    batch = {
        "obs": rng.normal(size=(64, 3)),
        "next_obs": rng.normal(size=(64, 3)),
        "goal": rng.normal(size=(64, 2)),
        "action": rng.uniform(-1, 1, (64, 2)),
        "reward": -np.ones(64),
    }
    batch = {k: jnp.asarray(v, jnp.float32) for k, v in batch.items()}
    discount = jnp.asarray(rng.choice([0.9**2, 0.9**5], 64), jnp.float32)
    one_step = np.asarray(ddpg.td_target(state, batch, config)) + 1.0  # gamma * Q'
    n_step = np.asarray(ddpg.td_target(state, {**batch, "discount": discount}, config)) + 1.0
    np.testing.assert_allclose(n_step, one_step / 0.9 * np.asarray(discount), rtol=1e-4, atol=1e-6)


def test_actual_goals_are_desired_goals_drawn_from_the_whole_replay(buffer):
    # mrl's 'futureactual_2_2': 0.4 future, 0.4 another transition's desired goal, 0.2 own.
    batch = her.sample_batch(
        buffer, jax.random.key(5), N, compute_reward, "future", 0.4, actual_prob=0.4
    )
    batch = {k: np.asarray(v) for k, v in batch.items()}
    ep, t = batch["obs"][:, 0], batch["obs"][:, 1]
    goal = batch["goal"]
    future = goal[:, 0] > 0
    np.testing.assert_array_equal(goal[future, 0], ep[future])
    assert np.all(goal[future, 1] > t[future])
    own = ~future & (goal[:, 0] == -ep) & (goal[:, 1] == -t)
    actual = ~future & ~own
    # Actual goals are desired goals (-id, -step) of filled slots, at any step.
    assert np.all(-goal[actual, 0] >= 1) and np.all(-goal[actual, 0] <= N_FILLED)
    assert set(np.unique(-goal[actual, 1])) == set(range(T))
    assert abs(future.mean() - 0.4) < 0.03
    # An actual draw repeats the transition's own (episode, step) 1 time in N_FILLED * T.
    assert abs(actual.mean() - 0.4 * (1 - 1 / (N_FILLED * T))) < 0.03
    # Its episode and step are both drawn afresh: another episode 11 times in 12, another
    # step 9 times in 10, over all non-future goals (the own 0.2 share included).
    rest = ~future
    assert abs(np.mean(-goal[rest, 0] != ep[rest]) - 0.4 / 0.6 * (1 - 1 / N_FILLED)) < 0.03
    assert abs(np.mean(-goal[rest, 1] != t[rest]) - 0.4 / 0.6 * (1 - 1 / T)) < 0.03
    np.testing.assert_array_equal(
        batch["reward"], np.asarray(compute_reward(batch["next_ag"], goal))
    )


def test_a_zero_actual_share_leaves_every_draw_as_without_it(buffer):
    key = jax.random.key(6)
    without = her.sample_batch(buffer, key, 256, compute_reward, "future", 0.8)
    traced = jax.jit(
        lambda p: her.sample_batch(buffer, key, 256, compute_reward, "future", 0.8, actual_prob=p)
    )(jnp.float32(0.0))
    for name in without:
        np.testing.assert_array_equal(np.asarray(without[name]), np.asarray(traced[name]))
