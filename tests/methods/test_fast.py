"""DDPG+HER+SL+Fast's action selection: the critic picks among the actor's action and the
library's proposals (`methods/ddpg_her_sl_fast.py`)."""

from __future__ import annotations

import types

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig, SearchConfig, TrainConfig
from mjx_skills.core.learner import Progress
from mjx_skills.envs import make
from mjx_skills.methods import ddpg_her_sl_fast as fast
from tests.fakes import NAMES, EncodingLibrary, states

CONFIG = DDPGConfig(hidden=(16,))
ONE_CUBE = make("pick_move")
STATE = types.SimpleNamespace(obs=jnp.zeros((2, 25)), desired_goal=jnp.zeros((2, 3)))


@pytest.mark.parametrize("held", [False, True])
def test_proposals_are_the_allowed_skills_actions_on_the_searchs_first_level_goals(held):
    obs, goal = states(16, held)
    actions, ok = fast.propose(EncodingLibrary(), SearchConfig(), obs, goal, jax.random.key(1), 6)
    assert actions.shape == (16, 6, 4) and bool(jnp.all(ok))
    skill = np.rint(np.asarray(actions[..., 0]) * 10).astype(int)
    transfer = NAMES.index("transfer")
    assert np.all(skill == transfer) if held else np.all(skill != transfer)
    if held:  # transfer goals lie around the task goal (3 cm noise, or a waypoint)
        near = np.linalg.norm(np.asarray(actions[..., 1:]) - np.asarray(goal)[:, None], axis=-1)
        assert np.mean(near < 0.03 * np.sqrt(3) + 1e-6) > 0.5


def test_the_critic_picks_the_best_candidate_and_ties_go_to_the_actor(monkeypatch):
    """With Q(s, g, a) = -|a - target|^2, the pick is the candidate nearest the target:
    a proposal when the target is one, the actor's action when the target is that."""
    obs, goal = states(8, held=False)
    agent = ddpg.init(jax.random.key(0), 25, 3, 4, CONFIG)
    lib, key = EncodingLibrary(), jax.random.key(2)
    proposals, _ = fast.propose(lib, SearchConfig(), obs, goal, key, 5)
    own = ddpg.act(agent, obs, goal, CONFIG)
    for target, from_library in ((proposals[:, 3], True), (own, False)):
        rigged = lambda s, o, g, a, c, t=target: -jnp.sum((a - t[:, None]) ** 2, axis=-1)  # noqa: E731
        monkeypatch.setattr(ddpg, "q_value", rigged)
        action, taken = fast.pick(agent, lib, SearchConfig(), obs, goal, key, 5, CONFIG, ONE_CUBE)
        np.testing.assert_allclose(action, target, atol=1e-6)
        assert bool(jnp.all(taken == from_library))


@pytest.mark.parametrize("in_training", [True, False])
def test_the_pick_acts_in_training_only_where_asked_and_always_in_evaluation(
    monkeypatch, in_training
):
    """`--fast.pick-in-training false` leaves training to DDPG+HER+SL's behaviour (the actor
    and its noise where the search does not drive); the evaluated policy picks either way."""
    calls = []
    base = fast.Learner(
        init=None, explore=lambda *a: "base explores", evaluate=None, store=None, update=None
    )
    monkeypatch.setattr(fast, "make_ddpg_her_sl", lambda *a: base)
    monkeypatch.setattr(fast, "make_behaviour", lambda *a, own, success: ("picking", own))
    monkeypatch.setattr(fast, "pick", lambda *a: calls.append(a) or ("picked", None))
    config = fast.FastConfig(pick_in_training=in_training, eval_average=0.0)
    learner = fast.make_ddpg_her_sl_fast(ONE_CUBE, TrainConfig(), CONFIG, SearchConfig(), config)
    explored = learner.explore(
        "agent", "library", Progress(jnp.zeros((), jnp.int32), jnp.zeros(()))
    )
    assert (explored == "base explores") != in_training
    _, action, _ = learner.evaluate("agent", "library").step((), jax.random.key(0), STATE)
    assert action == "picked" and calls[-1][:2] == ("agent", "library")


def test_evaluation_reads_polyak_averages_folded_in_after_each_cycle_and_training_does_not(
    monkeypatch,
):
    """`--fast.eval-average w`: after each cycle's update the averages move to w averages +
    (1 - w) online; exploring and updating see the online networks, evaluation the averages
    (normalisers: the online agent's)."""
    w, calls, seen = 0.75, [], []
    agent0 = ddpg.init(jax.random.key(0), 25, 3, 4, CONFIG)
    shift = lambda a: a.replace(  # noqa: E731 - one cycle's "learning": every weight + 1
        actor_params=jax.tree.map(lambda x: x + 1.0, a.actor_params),
        critic_params=jax.tree.map(lambda x: x + 1.0, a.critic_params),
        steps=a.steps + 1,
    )
    base = fast.Learner(
        init=lambda key: agent0,
        explore=lambda agent, *a: seen.append(agent) or "explores",
        evaluate=None,
        store=None,
        update=lambda agent, *a: (shift(agent), {"loss": 0.0}),
    )
    monkeypatch.setattr(fast, "make_ddpg_her_sl", lambda *a: base)
    monkeypatch.setattr(fast, "pick", lambda *a: calls.append(a) or ("picked", None))
    config = fast.FastConfig(pick_in_training=False, eval_average=w)
    learner = fast.make_ddpg_her_sl_fast(ONE_CUBE, TrainConfig(), CONFIG, SearchConfig(), config)
    state = learner.init(jax.random.key(1))
    for _ in range(3):
        state, losses = learner.update(state, None, None, None)
    assert losses == {"loss": 0.0} and int(state.agent.steps) == 3
    # after k cycles the online weights are p0 + k, the averages p0 + (1 - w) sum_j w^(k-j) j
    lag = (1 - w) * sum(w ** (3 - j) * j for j in (1, 2, 3))
    for name in ("actor_params", "critic_params"):
        start, online = getattr(agent0, name), getattr(state.agent, name)
        jax.tree.map(lambda p, o: np.testing.assert_allclose(o, p + 3.0, atol=1e-5), start, online)
        jax.tree.map(
            lambda p, a: np.testing.assert_allclose(a, p + lag, atol=1e-5),
            start,
            getattr(state, name),
        )
    prog = Progress(jnp.zeros((), jnp.int32), jnp.zeros(()))
    assert learner.explore(state, "library", prog) == "explores" and seen[-1] is state.agent
    learner.evaluate(state, "library").step((), jax.random.key(0), STATE)
    evaluated = calls[-1][0]
    assert evaluated.actor_params is state.actor_params
    assert evaluated.critic_params is state.critic_params
    assert evaluated.obs_norm is state.agent.obs_norm and calls[-1][1] == "library"
    # without averaging the agent is the base's own, unwrapped
    plain = fast.make_ddpg_her_sl_fast(
        ONE_CUBE, TrainConfig(), CONFIG, SearchConfig(), fast.FastConfig(eval_average=0.0)
    )
    assert plain.init(jax.random.key(1)) is agent0
    with pytest.raises(ValueError, match="eval_average"):
        fast.FastConfig(eval_average=1.0)
