"""Episode replay buffer: round trip, wrap-around, uniform sampling over filled slots."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.core import replay

T = 5


def make_episodes(ids: np.ndarray) -> dict[str, np.ndarray]:
    """Episodes whose every entry encodes (episode id, step), so a lookup is checkable."""
    ids = np.asarray(ids, np.float32)
    i1 = np.broadcast_to(ids[:, None], (len(ids), T + 1))  # (B, T+1) episode id
    s1 = np.broadcast_to(np.arange(T + 1, dtype=np.float32), (len(ids), T + 1))  # step
    i, s = i1[:, :T], s1[:, :T]
    return {
        "obs": np.stack([i1, s1, -i1], axis=-1),  # (B, T+1, 3)
        "ag": np.stack([i1, s1], axis=-1),  # (B, T+1, 2)
        "g": np.stack([-i, -s], axis=-1),  # (B, T, 2)
        "actions": np.stack([i, s], axis=-1),  # (B, T, 2)
        "ep_id": i.astype(np.int32),  # (B, T) an integer field keeps its dtype
    }


def example() -> dict[str, np.ndarray]:
    return jax.tree.map(lambda x: x[0], make_episodes(np.array([0])))


@pytest.fixture(scope="module")
def fns():
    return {
        "add": jax.jit(replay.add),
        "sample": jax.jit(replay.sample_indices, static_argnums=2),
    }


def test_init_shapes_and_dtypes():
    state = replay.init(10 * T + 3, example())
    assert state.T == T and state.n_slots == 10
    assert state.data["obs"].shape == (10, T + 1, 3)
    assert state.data["g"].shape == (10, T, 2)
    assert state.data["ep_id"].dtype == jnp.int32
    assert state.data["obs"].dtype == jnp.float32
    assert int(state.size) == 0 and int(state.insert) == 0
    # Capacity below one episode still gives one slot.
    assert replay.init(2, example()).n_slots == 1


def test_round_trip(fns):
    state = replay.init(10 * T, example())
    state = fns["add"](state, make_episodes(np.arange(1, 5)))  # 4 of 10 slots
    assert int(state.size) == 4 and int(state.insert) == 4
    ep, t = fns["sample"](state, jax.random.key(0), 512)
    ep, t = np.asarray(ep), np.asarray(t)
    assert ep.min() >= 0 and ep.max() < 4
    assert t.min() >= 0 and t.max() < T
    src = make_episodes(np.arange(1, 5))
    for k, buf in state.data.items():
        np.testing.assert_array_equal(np.asarray(buf)[ep, t], src[k][ep, t])
    # The next state of each sampled transition is in the same slot too.
    np.testing.assert_array_equal(np.asarray(state.data["obs"])[ep, t + 1], src["obs"][ep, t + 1])
    assert np.all(np.asarray(state.data["ep_id"])[ep, t] == ep + 1)


def test_wrap_around_overwrites_oldest(fns):
    state = replay.init(4 * T, example())
    state = fns["add"](state, make_episodes(np.array([1, 2, 3])))
    state = fns["add"](state, make_episodes(np.array([4, 5, 6])))  # crosses the end
    assert int(state.size) == 4 and int(state.insert) == 2
    ids = np.asarray(state.data["ep_id"])[:, 0]
    np.testing.assert_array_equal(ids, [5, 6, 3, 4])  # 1 and 2 were the oldest
    state = fns["add"](state, make_episodes(np.array([7, 8, 9])))
    assert int(state.size) == 4 and int(state.insert) == 1
    np.testing.assert_array_equal(np.asarray(state.data["ep_id"])[:, 0], [9, 6, 7, 8])


def test_batch_larger_than_buffer_equals_sequential_adds(fns):
    bulk = replay.add(replay.init(4 * T, example()), make_episodes(np.arange(1, 8)))
    seq = replay.init(4 * T, example())
    for i in range(1, 8):
        seq = replay.add(seq, make_episodes(np.array([i])))
    assert int(bulk.size) == int(seq.size) == 4
    assert int(bulk.insert) == int(seq.insert) == 7 % 4
    for k in seq.data:
        np.testing.assert_array_equal(np.asarray(bulk.data[k]), np.asarray(seq.data[k]))


def _chi2_threshold(df: int, z: float = 5.0) -> float:
    """Wilson-Hilferty approximation of the chi-square quantile at standard-normal z."""
    c = 2.0 / (9.0 * df)
    return df * (1.0 - c + z * np.sqrt(c)) ** 3


@pytest.mark.parametrize("n_filled", [1, 13, 20])
def test_uniform_over_filled_slots(fns, n_filled):
    state = replay.init(20 * T, example())
    state = fns["add"](state, make_episodes(np.arange(1, n_filled + 1)))
    n = 20_000
    ep, t = fns["sample"](state, jax.random.key(n_filled), n)
    ep, t = np.asarray(ep), np.asarray(t)
    # Never an unfilled slot: those hold zeros, filled ones ids >= 1.
    assert ep.min() >= 0 and ep.max() < n_filled
    assert np.all(np.asarray(state.data["ep_id"])[ep, t] >= 1)
    for values, bins in ((ep, n_filled), (t, T)):
        counts = np.bincount(values, minlength=bins)
        assert np.all(counts > 0)
        if bins > 1:
            expected = n / bins
            stat = np.sum((counts - expected) ** 2 / expected)
            assert stat < _chi2_threshold(bins - 1), (bins, stat, counts)


def test_chi2_test_rejects_non_uniform():
    # The test above must be able to fail: a mildly skewed histogram is caught.
    rng = np.random.default_rng(0)
    p = np.full(13, 1.0)
    p[0] = 1.5
    counts = np.bincount(rng.choice(13, 20_000, p=p / p.sum()), minlength=13)
    expected = 20_000 / 13
    assert np.sum((counts - expected) ** 2 / expected) > _chi2_threshold(12)


def test_add_rejects_mismatched_fields():
    state = replay.init(4 * T, example())
    eps = make_episodes(np.array([1]))
    with pytest.raises(ValueError):
        replay.add(state, {k: v for k, v in eps.items() if k != "g"})
    with pytest.raises(ValueError):
        replay.add(state, {**eps, "g": eps["g"][:, :-1]})
