"""PAS / MPAS: bounded meta actions, meta steps that are the skills' own runs, coarse-level
hindsight, and the trainer's guarantees (compiles once, deterministic, resumable) for every
method that uses the skill library."""

from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig, EnvConfig, PASConfig, SearchConfig, TrainConfig
from mjx_skills.core import replay, rollout
from mjx_skills.methods import pas
from mjx_skills.methods.ddpg_her_sl_fast import FastConfig
from mjx_skills.skills.library import DEFAULT_DIR, LIBRARIES, load
from mjx_skills.training import epoch
from mjx_skills.training.metrics_log import read_metrics
from mjx_skills.training.runner import RunArgs, train_run
from tests.fakes import tiny_train

needs_library = pytest.mark.skipif(
    not (DEFAULT_DIR / "manifest.json").exists(), reason="no built skill library"
)


def test_inverted_gradients_point_back_inside_the_bounds():
    grad = jnp.array([1.0, 1.0, -1.0, 1.0, -1.0])
    action = jnp.array([0.5, 1.0, -1.0, 1.2, -1.3])
    np.testing.assert_allclose(
        ddpg.invert_gradients(grad, action), [0.25, 0.0, 0.0, -0.1, 0.15], atol=1e-6
    )


def test_an_inverting_actor_learns_and_stays_inside_its_bounds():
    """Reward grows with the first action component without limit; the critic learns that,
    and the linear actor pushed by it must stop at the bound, not run past it."""
    cfg = DDPGConfig(hidden=(32, 32), gamma=0.5, clip_target=False)
    state = ddpg.init(jax.random.PRNGKey(0), 2, 1, 2, cfg, bounds="invert")
    key = jax.random.PRNGKey(1)
    n, b = 400, 64
    obs = jax.random.normal(key, (n, b, 2))
    action = jax.random.uniform(jax.random.fold_in(key, 1), (n, b, 2), minval=-1, maxval=1)
    batches = {
        "obs": obs,
        "next_obs": obs,
        "goal": jnp.zeros((n, b, 1)),
        "action": action,
        "reward": 3.0 * action[..., 0],
    }
    state = ddpg.observe(state, obs.reshape(-1, 2), jnp.zeros((n * b, 1)))
    state, _ = ddpg.update(state, batches, cfg)
    o, g = ddpg.normalize_inputs(state, obs[0], jnp.zeros((b, 1)), cfg)
    raw = ddpg.actor_module(state, cfg).apply(state.actor_params, o, g)
    assert float(raw[:, 0].mean()) > 0.8, "the actor follows the critic towards the bound"
    assert float(jnp.abs(raw).max()) < 1.1, "and stays (about) inside it"


def test_store_lists_the_meta_steps_of_each_episode():
    T = 10
    decision = jnp.zeros((2, T), bool).at[0, jnp.array([0, 3, 7])].set(True).at[1, 0].set(True)
    meta = jnp.arange(2 * T, dtype=jnp.float32).reshape(2, T, 1)
    episodes = rollout.Episode(
        obs=jnp.zeros((2, T + 1, 1)),
        ag=jnp.zeros((2, T + 1, 1)),
        g=jnp.zeros((2, T, 1)),
        actions=jnp.zeros((2, T, 1)),
    )
    stored = pas.store(episodes, {"decision": decision, "meta_action": meta})
    np.testing.assert_array_equal(stored.start[0, :4], [0, 3, 7, T])
    np.testing.assert_array_equal(stored.end[0, :3], [3, 7, T])
    np.testing.assert_array_equal(stored.valid[0], np.arange(T) < 3)
    np.testing.assert_array_equal(stored.action[0, :3, 0], [0, 3, 7])
    np.testing.assert_array_equal(stored.valid[1], np.arange(T) < 1)
    assert int(stored.end[1, 0]) == T


@pytest.mark.parametrize("hindsight", [False, True])
def test_coarse_hindsight_relabels_with_a_later_meta_steps_achieved_goal(hindsight):
    T, n_eps = 12, 3
    # Achieved goal at env step t of episode e is 100 e + t: a value names its step.
    ag = (100.0 * jnp.arange(n_eps)[:, None] + jnp.arange(T + 1)[None]).reshape(n_eps, T + 1, 1)
    g = jnp.full((n_eps, T, 1), -5.0)
    decision = jnp.zeros((n_eps, T), bool).at[:, jnp.array([0, 2, 5, 9])].set(True)
    episodes = rollout.Episode(obs=ag, ag=ag, g=g, actions=jnp.zeros((n_eps, T, 1)))
    stored = pas.store(episodes, {"decision": decision, "meta_action": jnp.zeros((n_eps, T, 1))})
    buffer = replay.add(replay.init(10 * T, jax.tree.map(lambda x: x[0], stored), T=T), stored)
    env = SimpleNamespace(
        compute_reward=lambda a, d: jnp.where(jnp.abs(a - d)[..., 0] < 0.5, 0.0, -1.0),
        grasped=lambda obs: jnp.zeros(obs.shape[:-1], bool),
        n_objects=1,
    )
    cfg = PASConfig(hindsight=hindsight, relabel_prob=1.0)
    sampled = pas.sample_batch(buffer, jax.random.PRNGKey(0), 500, env, cfg, LIBRARIES["SL1"])
    batch = jax.tree.map(np.asarray, sampled)
    ends = {0: 2, 2: 5, 5: 9, 9: 12}
    for obs, next_obs, goal, reward in zip(
        batch["obs"][:, 0],
        batch["next_obs"][:, 0],
        batch["goal"][:, 0],
        batch["reward"],
        strict=True,
    ):
        episode, start = divmod(int(obs), 100)
        assert int(next_obs) == 100 * episode + ends[start]  # the meta step's own end
        if hindsight:
            g_ep, g_step = divmod(int(goal), 100)
            assert g_ep == episode and g_step in ends.values() and g_step >= ends[start]
        else:
            assert goal == -5.0
        assert reward == (0.0 if abs(next_obs - goal) < 0.5 else -1.0)
    if hindsight:  # later meta steps' goals are drawn too, not only the own end
        assert np.mean(batch["goal"][:, 0] % 100 != batch["next_obs"][:, 0] % 100) > 0.2


def _constant_meta_agent(meta_action: jax.Array) -> ddpg.DDPGState:
    """A meta-controller whose every output is `meta_action` (last layer: zeros + bias)."""
    state = ddpg.init(
        jax.random.PRNGKey(0), 25, 3, meta_action.shape[0], DDPGConfig(), bounds="invert"
    )
    mlp = state.actor_params["params"]["MLP_0"]
    last = max(mlp, key=lambda name: int(name.split("_")[1]))
    mlp = {**mlp, last: {"kernel": jnp.zeros_like(mlp[last]["kernel"]), "bias": meta_action}}
    return state.replace(actor_params={"params": {"MLP_0": mlp}})


@needs_library
def test_a_meta_step_is_the_skills_own_run(env_factory):
    lib, _ = load(DEFAULT_DIR)
    env = env_factory("pick_move")
    K = len(lib.names)
    transit = lib.index("transit")
    x = jnp.array([0.3, -0.2, 0.1])
    meta = jnp.full((pas.meta_dim(K),), -1.0).at[transit].set(1.0)
    meta = meta.at[K + 3 * transit : K + 3 * transit + 3].set(x)
    cfg = PASConfig(skill_steps=6, critic="joint")
    behaviour = pas.make_behaviour(
        _constant_meta_agent(meta), lib, env, cfg, DDPGConfig(), noisy=False
    )
    key = jax.random.PRNGKey(3)
    episodes, _, records = jax.jit(lambda k: rollout.run_episodes(env, behaviour, k, 2))(key)
    # By hand: the same resets, then transit's policy towards goal_from_param(x).
    k_reset, _ = jax.random.split(key)
    state = jax.vmap(env.reset)(jax.random.split(k_reset, 2))
    skill = jnp.full((2,), transit, jnp.int32)
    goal = lib.goal_from_param(skill, jnp.broadcast_to(x, (2, 3)), state.obs)
    step = jax.jit(lambda s: jax.vmap(env.step)(s, lib.policy_action(skill, s.obs, goal)))
    decision = np.asarray(records["decision"])
    for e in range(2):
        assert decision[e, 0]
        c = int(np.flatnonzero(decision[e, 1:])[0]) + 1  # the second choice's step
        s = state
        for t in range(c):
            reached = bool(lib.reached(skill, s.obs, goal)[e])
            assert not reached or t == 0, "the skill ran on after terminating"
            s = step(s)
        done = bool(lib.reached(skill, s.obs, goal)[e])
        assert c == cfg.skill_steps or done, "the meta step ended before its skill did"
        np.testing.assert_allclose(episodes.obs[e, c], s.obs[e], atol=1e-4)
        assert int(records["skill"][e, 0]) == transit


# --------------------------------------------------- the trainer's guarantees, per method
TINY = tiny_train(task="pick_move", updates_per_cycle=3, replay_capacity=3000)
LIBRARY_METHODS = {
    "ddpg_her_sl": ("ddpg_her_sl", {"search": SearchConfig(branching=3, height=2)}),
    # DDPG+HER+SL's explorer with the default tree (K = 5, height 3), stall memory and
    # waypoints, under DDPG+HER+SL+BC's learner: one compile covers both.
    "ddpg_her_sl_bc_default_tree": ("ddpg_her_sl_bc", {"search": SearchConfig()}),
    "ddpg_her_sl_fast": (
        "ddpg_her_sl_fast",
        {"search": SearchConfig(branching=3, height=2), "fast": FastConfig(updates_per_cycle=3)},
    ),
    "mpas": ("mpas", {"pas": PASConfig(hindsight=True, updates_per_cycle=3)}),
    "pas": ("pas", {"pas": PASConfig(critic="joint", terminal_at_goal=False, updates_per_cycle=3)}),
}


def _args(tmp_path, case, **overrides):
    method, options = LIBRARY_METHODS[case]
    train = {**TINY, "out": str(tmp_path), **overrides}
    if method in ("pas", "mpas", "ddpg_her_sl_fast"):  # they take their own update count
        train.pop("updates_per_cycle")
    return RunArgs(
        train=TrainConfig(**train), method=method, env=EnvConfig(episode_length=12), options=options
    )


def _rows(run_dir):
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in read_metrics(run_dir)]


@needs_library
@pytest.mark.parametrize("case", sorted(LIBRARY_METHODS))
def test_library_methods_compile_once_repeat_and_resume(case, tmp_path):
    from mjx_skills import methods

    args = _args(tmp_path, case, seeds=2)
    method = args.method
    lib = methods.get(method).load_aux(args.full_options())
    _, _, epoch_fn, carry0 = epoch.build(method, args.train, args.env, args.options, lib)
    copy = lambda c: jax.tree.map(jnp.copy, c)
    runs = []
    for _ in range(2):
        carry, history = copy(carry0), []
        for _ in range(2):
            carry, metrics = epoch_fn(carry, lib)
            history.append(epoch.host_metrics(metrics))
        runs.append(history)
    assert epoch_fn._cache_size() == 1, "the epoch was traced again"
    for a, b in zip(*runs, strict=True):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert runs[0][1]["skill_calls"].min() > 0, "the library drove some steps"
    if method == "ddpg_her_sl_bc":  # the explorer's steps were cloned where the critic agreed
        share = runs[0][1]["bc_share"]
        assert np.all((share > 0) & (share < 1)), share

    straight = train_run(_args(tmp_path / "a", case, epochs=3, checkpoint_every=1))
    pieces = train_run(_args(tmp_path / "b", case, epochs=3, checkpoint_every=2), stop_after=2)
    assert train_run(RunArgs(resume=str(pieces))) == pieces
    assert _rows(straight) == _rows(pieces)


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        (["mpas", "--updates-per-cycle", "50"], "--pas.updates-per-cycle"),
        (["pas", "--ddpg.relabel-prob", "0.5"], "--pas.relabel-prob"),
        (["mpas", "--ddpg.her-strategy", "final"], "--pas.hindsight"),
        (["pas", "--pas.relabel-prob", "0.5"], "--pas.hindsight, which is off"),
    ],
)
def test_an_option_the_method_does_not_read_is_refused(argv, flag, tmp_path):
    """PAS / MPAS wrote these to config.json and did nothing with them."""
    from mjx_skills import train as train_command

    with pytest.raises(SystemExit, match=f"does not read .*{flag}"):
        train_command.main([*argv, "--task", "take_out", "--out", str(tmp_path)])
    assert not any(tmp_path.iterdir())
    train_command.parse(["mpas", "--pas.updates-per-cycle", "50"])  # what it does read is fine
