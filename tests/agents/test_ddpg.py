"""DDPG learner and running normaliser."""

from __future__ import annotations

import dataclasses
import functools

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig
from mjx_skills.core import normalizer

OBS, GOAL, ACT, B = 6, 3, 2, 64
# A larger tau than the default makes a wrong soft update visible at float32 tolerances.
CONFIG = DDPGConfig(hidden=(32, 32), tau=0.05, batch_size=B)


def make_batch(key: jax.Array) -> dict[str, jax.Array]:
    ks = jax.random.split(key, 5)
    return {
        "obs": 1.0 + 0.5 * jax.random.normal(ks[0], (B, OBS)),
        "next_obs": 1.0 + 0.5 * jax.random.normal(ks[1], (B, OBS)),
        "goal": jax.random.normal(ks[2], (B, GOAL)),
        "action": jax.random.uniform(ks[3], (B, ACT), minval=-1.0, maxval=1.0),
        "reward": -jax.random.bernoulli(ks[4], 0.7, (B,)).astype(jnp.float32),
    }


@pytest.fixture(scope="module")
def setup():
    state = ddpg.init(jax.random.key(0), OBS, GOAL, ACT, CONFIG)
    batch = make_batch(jax.random.key(1))
    state = ddpg.observe(state, batch["obs"], batch["goal"])
    return state, batch, update_one


@jax.jit
def update_one(state, batch):
    """One gradient step: `ddpg.update` on a stack of one batch."""
    state, metrics = ddpg.update(state, jax.tree.map(lambda x: x[None], batch), CONFIG)
    return state, jax.tree.map(lambda m: m[0], metrics)


def test_n_steps_in_one_call_equal_n_single_steps(setup):
    state, batch, update = setup
    batches = jax.tree.map(lambda *xs: jnp.stack(xs), batch, make_batch(jax.random.key(9)))
    together, metrics = jax.jit(functools.partial(ddpg.update, config=CONFIG))(state, batches)
    assert metrics["critic_loss"].shape == (2,)
    one_by_one = state
    for i in range(2):
        one_by_one, m = update(one_by_one, jax.tree.map(lambda x, i=i: x[i], batches))
        np.testing.assert_allclose(m["critic_loss"], metrics["critic_loss"][i], rtol=1e-4)
    chex.assert_trees_all_close(together, one_by_one, rtol=1e-4, atol=1e-5)
    assert int(together.steps) == 2


def test_init_targets_equal_online(setup):
    state, _, _ = setup
    chex.assert_trees_all_equal(state.target_actor_params, state.actor_params)
    chex.assert_trees_all_equal(state.target_critic_params, state.critic_params)
    assert int(state.steps) == 0


def test_update_lowers_critic_loss(setup):
    state, batch, update = setup
    losses = []
    for _ in range(50):
        state, metrics = update(state, batch)
        losses.append(float(metrics["critic_loss"]))
        assert all(np.isfinite(float(v)) for v in metrics.values())
    assert int(state.steps) == 50
    assert losses[-1] < 0.5 * losses[0], losses


def test_soft_target_update(setup):
    state, batch, update = setup
    state, _ = update(state, batch)  # targets now lag the online nets
    new, _ = update(state, batch)
    tau = CONFIG.tau
    for target, online in (
        ("target_actor_params", "actor_params"),
        ("target_critic_params", "critic_params"),
    ):
        expected = jax.tree.map(
            lambda t, p: (1 - tau) * t + tau * p, getattr(state, target), getattr(new, online)
        )
        chex.assert_trees_all_close(getattr(new, target), expected, rtol=1e-6, atol=1e-7)
        # The online nets did move, so the check above is not vacuous.
        moved = jax.tree.map(
            lambda a, b: jnp.max(jnp.abs(a - b)), getattr(state, online), getattr(new, online)
        )
        assert max(jax.tree.leaves(moved)) > 1e-5


def test_targets_move_once_per_cycle_as_the_her_baselines(setup):
    """target_update='cycle': the three gradient steps of a call learn against the targets
    the call started with (the first step's TD targets are the same as with 'step', later
    ones differ), and only then do the targets move once by tau towards the online nets."""
    state, batch, _ = setup
    state, _ = ddpg.update(state, jax.tree.map(lambda x: x[None], batch), CONFIG)  # lagging
    batches = jax.tree.map(
        lambda *xs: jnp.stack(xs), *(make_batch(jax.random.key(k)) for k in range(3))
    )
    cycle = dataclasses.replace(CONFIG, target_update="cycle")
    per_step, m_step = ddpg.update(state, batches, CONFIG)
    per_cycle, m_cycle = ddpg.update(state, batches, cycle)
    np.testing.assert_allclose(m_cycle["critic_loss"][0], m_step["critic_loss"][0], rtol=1e-6)
    assert abs(float(m_cycle["critic_loss"][2]) - float(m_step["critic_loss"][2])) > 1e-7
    tau = CONFIG.tau
    for target, online in (
        ("target_actor_params", "actor_params"),
        ("target_critic_params", "critic_params"),
    ):
        once = jax.tree.map(
            lambda t, p: (1 - tau) * np.asarray(t) + tau * np.asarray(p),
            getattr(state, target),
            getattr(per_cycle, online),
        )
        chex.assert_trees_all_close(getattr(per_cycle, target), once, rtol=1e-6, atol=1e-7)
        gap = jax.tree.map(lambda a, b: jnp.max(jnp.abs(a - b)), getattr(per_step, target), once)
        assert max(jax.tree.leaves(gap)) > 1e-6  # per step, the targets moved otherwise


def test_td_target_clipped(setup):
    state, batch, _ = setup
    # Push the target critic's output bias far up and down: targets must stay in range.
    lo = -1.0 / (1.0 - CONFIG.gamma)
    for shift in (100.0, -1000.0):
        params = jax.tree.map(lambda x: x, state.target_critic_params)
        params["params"]["MLP_0"]["Dense_2"]["bias"] = (
            params["params"]["MLP_0"]["Dense_2"]["bias"] + shift
        )
        y = ddpg.td_target(state.replace(target_critic_params=params), batch, CONFIG)
        assert y.shape == (B,)
        np.testing.assert_allclose(y, 0.0 if shift > 0 else lo, rtol=1e-6)
    unclipped = DDPGConfig(hidden=CONFIG.hidden, clip_target=False)
    y = ddpg.td_target(state.replace(target_critic_params=params), batch, unclipped)
    assert float(jnp.max(y)) < lo - 100


def test_act_in_range_and_shapes(setup):
    state, batch, _ = setup
    # Scaled-up weights saturate tanh; outputs must still lie in [-1, 1].
    big = state.replace(actor_params=jax.tree.map(lambda x: 50.0 * x, state.actor_params))
    for s in (state, big):
        a = ddpg.act(s, batch["obs"], batch["goal"], CONFIG)
        assert a.shape == (B, ACT)
        assert float(jnp.max(jnp.abs(a))) <= 1.0
    assert float(jnp.max(jnp.abs(ddpg.act(big, batch["obs"], batch["goal"], CONFIG)))) > 0.99
    single = ddpg.act(state, batch["obs"][0], batch["goal"][0], CONFIG)
    assert single.shape == (ACT,)
    np.testing.assert_allclose(
        single, ddpg.act(state, batch["obs"], batch["goal"], CONFIG)[0], atol=1e-6
    )
    lead = ddpg.act(
        state, batch["obs"].reshape(4, 16, OBS), batch["goal"].reshape(4, 16, GOAL), CONFIG
    )
    assert lead.shape == (4, 16, ACT)
    q = ddpg.q_value(state, batch["obs"], batch["goal"], batch["action"], CONFIG)
    assert q.shape == (B,)


def test_explore(setup):
    state, batch, _ = setup
    obs = jnp.repeat(batch["obs"][:1], 4000, axis=0)
    goal = jnp.repeat(batch["goal"][:1], 4000, axis=0)
    greedy = ddpg.act(state, obs[:1], goal[:1], CONFIG)[0]
    a = ddpg.explore(state, jax.random.key(2), obs, goal, CONFIG)
    assert a.shape == (4000, ACT) and float(jnp.max(jnp.abs(a))) <= 1.0
    assert float(jnp.max(jnp.abs(a))) == 1.0  # random / clipped actions reach the bounds
    # Small noise stays clear of the bounds: actions centre on the policy's with std sigma.
    small = DDPGConfig(hidden=CONFIG.hidden, noise_sigma=0.02, random_eps=0.0)
    assert float(jnp.max(jnp.abs(greedy))) < 1.0 - 6 * small.noise_sigma
    a = ddpg.explore(state, jax.random.key(5), obs, goal, small)
    np.testing.assert_allclose(jnp.mean(a, axis=0), greedy, atol=0.002)
    np.testing.assert_allclose(jnp.std(a, axis=0), small.noise_sigma, rtol=0.1)
    none = DDPGConfig(hidden=CONFIG.hidden, noise_sigma=0.0, random_eps=0.0)
    np.testing.assert_allclose(
        ddpg.explore(state, jax.random.key(3), obs[:5], goal[:5], none),
        ddpg.act(state, obs[:5], goal[:5], none),
        atol=1e-6,
    )
    rand = DDPGConfig(hidden=CONFIG.hidden, noise_sigma=0.0, random_eps=1.0)
    r = ddpg.explore(state, jax.random.key(4), obs, goal, rand)
    np.testing.assert_allclose(jnp.mean(r, axis=0), 0.0, atol=0.05)  # uniform on [-1, 1]
    np.testing.assert_allclose(jnp.var(r, axis=0), 1.0 / 3.0, atol=0.03)


def test_vmap_over_seeds_inside_scan(setup):
    _, batch, _ = setup
    keys = jax.random.split(jax.random.key(7), 2)

    @jax.jit
    @jax.vmap
    def run(key):
        state = ddpg.init(key, OBS, GOAL, ACT, CONFIG)
        state = ddpg.observe(state, batch["obs"], batch["goal"])

        def step(s, k):
            s, m = ddpg.update(s, jax.tree.map(lambda x: x[None], batch), CONFIG)
            return s, (
                m["critic_loss"][0],
                ddpg.explore(s, k, batch["obs"][0], batch["goal"][0], CONFIG),
            )

        return jax.lax.scan(step, state, jax.random.split(key, 3))

    state, (losses, actions) = run(keys)
    assert losses.shape == (2, 3) and actions.shape == (2, 3, ACT)
    assert np.all(np.asarray(state.steps) == 3)
    assert np.all(np.isfinite(np.asarray(losses)))
    # Different seeds, different networks.
    assert not np.allclose(losses[0], losses[1])


def test_normalizer_matches_numpy():
    rng = np.random.default_rng(0)
    # A large offset with a small spread breaks the naive float32 sumsq / n - mean^2.
    x = rng.normal([1000.0, 0.7, -3.0, 0.0], [0.1, 0.002, 2.0, 1.0], size=(3000, 4))
    state = normalizer.init(4)
    update = jax.jit(normalizer.update)
    for chunk in np.array_split(x, 7):
        state = update(state, jnp.asarray(chunk, jnp.float32))
    mean, std = normalizer.mean_std(state, eps=1e-6)
    assert float(state.count) == 3000
    # Within a small share of each column's spread (float32 resolves 1000 to 6e-5).
    assert np.all(np.abs(np.asarray(mean) - x.mean(0)) < 2e-3 * x.std(0))
    np.testing.assert_allclose(std, x.std(0), rtol=1e-2)
    z = normalizer.normalize(state, jnp.asarray(x[:100], jnp.float32), clip=5.0, eps=1e-6)
    np.testing.assert_allclose(z, (x[:100] - x.mean(0)) / x.std(0), atol=0.05)


def test_normalizer_eps_floor_and_clip():
    state = normalizer.init(2)
    # Before any data: identity.
    np.testing.assert_allclose(
        normalizer.normalize(state, jnp.array([0.3, -2.0]), 5.0, 0.01), [0.3, -2.0]
    )
    x = jnp.stack([jnp.full((50,), 2.0), jnp.linspace(-1.0, 1.0, 50)], axis=-1)
    state = normalizer.update(state, x)
    mean, std = normalizer.mean_std(state, eps=0.01)
    np.testing.assert_allclose(std[0], 0.01)  # a constant column is floored at eps
    z = normalizer.normalize(state, jnp.array([[2.001, 0.0], [3.0, 100.0]]), clip=5.0, eps=0.01)
    np.testing.assert_allclose(z, [[0.1, 0.0], [5.0, 5.0]], atol=1e-3)
    # Leading axes are flattened.
    state3 = normalizer.update(normalizer.init(2), x.reshape(5, 10, 2))
    chex.assert_trees_all_close(state3, state)


def test_the_losses_on_known_values():
    """The critic's TD loss, the actor's -Q + L2 loss, and the inverting-gradients loss
    (value -mean Q, gradient -invert_gradients(dQ/da, a) / B) on hand-computed values."""
    q, y = jnp.array([1.0, -2.0, 0.5]), jnp.array([0.0, 0.0, 1.5])
    np.testing.assert_allclose(ddpg.td_loss(q, y), (1.0 + 4.0 + 1.0) / 3, rtol=1e-6)

    pi = jnp.array([[0.5, -1.0], [0.0, 0.2]])
    q_pi = jnp.array([-3.0, -1.0])
    expected = 2.0 + 0.5 * (0.25 + 1.0 + 0.0 + 0.04) / 4
    np.testing.assert_allclose(ddpg.actor_loss(q_pi, pi, 0.5), expected, rtol=1e-6)

    # Q(a) = sum over the batch of w . a: dQ/da = w for every row.
    w = jnp.array([2.0, -1.0])
    q_of = lambda a: jnp.sum(a @ w)
    a = jnp.array([[0.5, 0.5], [-0.5, 0.9]])
    value, grad = jax.value_and_grad(ddpg.inverting_actor_loss, argnums=1)(q_of, a)
    np.testing.assert_allclose(value, -q_of(a) / 2, rtol=1e-6)
    # Up (w > 0): scaled by (1 - a) / 2; down (w < 0): by (a + 1) / 2; then -1/B.
    room = jnp.array([[(1 - 0.5) / 2, (0.5 + 1) / 2], [(1 + 0.5) / 2, (0.9 + 1) / 2]])
    np.testing.assert_allclose(grad, -(w * room) / 2, rtol=1e-6)
    # A bound passed (a > 1 pushed up) turns the step back inside.
    _, past = jax.value_and_grad(ddpg.inverting_actor_loss, argnums=1)(
        q_of, jnp.array([[1.5, 0.0]])
    )
    assert float(past[0, 0]) > 0  # descending the loss lowers a[0, 0] back towards 1


def test_the_q_filtered_bc_loss_clones_only_demonstrations_the_critic_prefers():
    pi = jnp.array([[0.0, 0.0], [0.5, 0.5], [1.0, -1.0], [0.2, 0.0]])
    demo_action = jnp.array([[1.0, 0.0], [0.5, -0.5], [0.0, 0.0], [0.2, 0.0]])
    demo = jnp.array([True, True, True, False])
    q_demo = jnp.array([-1.0, -5.0, -2.0, 0.0])
    q_pi = jnp.array([-3.0, -1.0, -4.0, -9.0])
    # Rows 0 and 2 are kept (demo and Q(s, a_demo) > Q(s, pi)); row 1 the critic rejects,
    # row 3 is no demonstration although its Q would pass.
    loss, share = ddpg.q_filtered_bc_loss(pi, demo_action, demo, q_demo, q_pi)
    np.testing.assert_allclose(loss, (1.0 + 2.0) / 2, rtol=1e-6)
    np.testing.assert_allclose(share, 0.5)
    grad = jax.grad(lambda p: ddpg.q_filtered_bc_loss(p, demo_action, demo, q_demo, q_pi)[0])(pi)
    np.testing.assert_allclose(grad[0], [-1.0, 0.0], rtol=1e-6)  # towards the demonstration
    assert not np.any(grad[1]) and not np.any(grad[3])
    none, zero = ddpg.q_filtered_bc_loss(pi, demo_action, jnp.zeros(4, bool), q_demo, q_pi)
    assert float(none) == 0.0 and float(zero) == 0.0


def test_twin_critics_are_independent_heads_read_through_their_minimum():
    """critics = 2 (TD3's clipped double Q): the ensemble's heads are two independently
    initialised critics, each exactly the one-critic network with that head's parameters;
    Q read (the pick's q_value) and the TD target take the smaller head, and one update
    moves both heads."""
    twin = dataclasses.replace(CONFIG, critics=2, clip_target=False)
    batch = make_batch(jax.random.key(3))
    state = ddpg.observe(
        ddpg.init(jax.random.key(0), OBS, GOAL, ACT, twin), batch["obs"], batch["goal"]
    )

    def head(params, i):  # head i of the ensemble, as one critic's parameters
        return {"params": {"MLP_0": params["params"][f"MLP_{i}"]}}

    qs, ys = [], []
    plain = dataclasses.replace(CONFIG, clip_target=False)
    for i in range(2):
        single = state.replace(
            critic_params=head(state.critic_params, i),
            target_critic_params=head(state.target_critic_params, i),
        )
        qs.append(ddpg.q_value(single, batch["obs"], batch["goal"], batch["action"], plain))
        ys.append(ddpg.td_target(single, batch, plain))
    assert float(jnp.mean(jnp.abs(qs[0] - qs[1]))) > 1e-3  # two inits, not one copied
    q = ddpg.q_value(state, batch["obs"], batch["goal"], batch["action"], twin)
    np.testing.assert_allclose(q, jnp.minimum(*qs), rtol=1e-3, atol=1e-4)
    # r + gamma min(Q1', Q2'): the smaller head's target, row by row
    np.testing.assert_allclose(
        ddpg.td_target(state, batch, twin), jnp.minimum(*ys), rtol=1e-3, atol=1e-4
    )

    new, metrics = jax.jit(functools.partial(ddpg.update, config=twin))(
        state, jax.tree.map(lambda x: x[None], batch)
    )
    # each head is fitted to the one shared target (not its own, nor the minimum to it)
    y = ddpg.td_target(state, batch, twin)
    np.testing.assert_allclose(
        metrics["critic_loss"][0], sum(jnp.mean((q_i - y) ** 2) for q_i in qs), rtol=1e-3
    )
    for i in range(2):
        moved = jax.tree.map(
            lambda a, b: float(jnp.max(jnp.abs(a - b))),
            head(new.critic_params, i),
            head(state.critic_params, i),
        )
        assert max(jax.tree.leaves(moved)) > 0, f"head {i} did not move"


def test_more_critics_are_refused_where_one_is_trained():
    from mjx_skills.agents import mpdqn

    with pytest.raises(ValueError, match="critics"):
        mpdqn.init(jax.random.key(0), OBS, GOAL, 3, dataclasses.replace(CONFIG, critics=2))
    with pytest.raises(ValueError, match="critics"):
        DDPGConfig(critics=0)
