"""Data for the skill library, and the fits of its coarse models and success classifiers.

Collection (thesis 3.3, 5.1.1): N (start, goal parameter) pairs per skill, run with the
learned skill policy until the skill's `terminated` predicate holds or its horizon runs out,
in one jitted program per chunk of runs -> (s0, g, s_terminal, success, steps). Starts come
from the skill's own start distribution and from the other skills' (gripper anywhere, near
the cube, cube held), so failures cover the states the search will ask about.

Fits: every skill's model (or classifier) is fitted at once by one jitted step `vmap`ped
over the skill axis; a held-out split drives early stopping per skill.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig, LibraryConfig
from mjx_skills.core import optim
from mjx_skills.core.nets import CoarseDynamics, SuccessClassifier
from mjx_skills.core.types import SkillEnv

NORM_FLOOR = 1e-3
"""Smallest std used to normalise a model input or output dimension (m, rad, m/s)."""


# ---------------------------------------------------------------------- collection
def make_collect(
    skill_env: SkillEnv,
    start_envs: tuple[SkillEnv, ...],
    counts: tuple[int, ...],
    ddpg_config: DDPGConfig,
) -> Callable[[ddpg.DDPGState, jax.Array], dict[str, jax.Array]]:
    """-> collect(policy, key) -> samples of sum(counts) skill runs, counts[i] of them from
    start_envs[i]'s start distribution (all envs share the scene). Jittable.

    samples: s0 (n, 25), goal (n, 3), param (n, 3) (padded), s_T (n, 25) at the first
    step where the skill terminated (or its horizon), success (n,) bool: the skill's goal
    reached at s_T, steps (n,) int32, source (n,) int32 (index into start_envs)."""
    horizon = skill_env.episode_length
    pd = skill_env.param_dim

    def collect(policy: ddpg.DDPGState, key: jax.Array) -> dict[str, jax.Array]:
        k_starts, k_param = jax.random.split(key)
        parts = [
            jax.vmap(env.reset)(jax.random.split(jax.random.fold_in(k_starts, i), n))
            for i, (env, n) in enumerate(zip(start_envs, counts, strict=True))
        ]
        state = jax.tree.map(lambda *xs: jnp.concatenate(xs), *parts)
        n = state.obs.shape[0]
        if hasattr(skill_env, "collection_param"):  # the skill's own draw (SkillEnv)
            drawn = skill_env.collection_param(k_param, state.obs)
            param = jnp.zeros((n, 3)).at[:, :pd].set(drawn)
        else:
            param = jax.random.uniform(k_param, (n, 3), minval=-1.0, maxval=1.0)
            param = param.at[:, pd:].set(0.0)
        goal = skill_env.goal_from_param(param[:, :pd], state.obs)
        s0 = state.obs
        done0 = skill_env.terminated(s0, goal)

        def body(carry, _):
            state, done, s_T, steps = carry
            action = ddpg.act(policy, state.obs, goal, ddpg_config)
            state = jax.vmap(skill_env.step)(state, action)
            ended = skill_env.terminated(state.obs, goal)
            s_T = jnp.where((ended & ~done)[:, None], state.obs, s_T)
            steps = steps + (~done).astype(jnp.int32)
            return (state, done | ended, s_T, steps), None

        init = (state, done0, s0, jnp.zeros((n,), jnp.int32))
        (state, done, s_T, steps), _ = jax.lax.scan(body, init, None, length=horizon)
        s_T = jnp.where(done[:, None], s_T, state.obs)
        achieved = skill_env.achieved_from_obs(s_T)
        source = jnp.concatenate([jnp.full((c,), i, jnp.int32) for i, c in enumerate(counts)])
        return {
            "s0": s0,
            "goal": goal,
            "param": param,
            "s_T": s_T,
            "steps": steps,
            "success": skill_env.is_success(achieved, goal),
            "source": source,
        }

    return collect


def start_counts(n: int, own: int, n_sources: int, own_share: float) -> tuple[int, ...]:
    """Split n runs over n_sources start distributions: `own_share` from source `own`, the
    rest evenly over the others."""
    if n_sources == 1:
        return (n,)
    n_own = round(n * own_share)
    rest = n - n_own
    others = [rest // (n_sources - 1) + (i < rest % (n_sources - 1)) for i in range(n_sources - 1)]
    counts = others[:own] + [n_own] + others[own:]
    return tuple(counts)


# ---------------------------------------------------------------------- models
def init_models(
    keys: jax.Array, config: LibraryConfig, obs_dim: int, goal_dim: int
) -> tuple[Any, Any]:
    """Fresh (dynamics, classifier) parameters, one per key, stacked on the leading axis."""
    obs, goal = jnp.zeros((1, obs_dim)), jnp.zeros((1, goal_dim))
    model = CoarseDynamics(obs_dim, tuple(config.model_hidden))
    clf = SuccessClassifier(tuple(config.classifier_hidden))

    def one(key):
        k_m, k_c = jax.random.split(key)
        return model.init(k_m, obs, goal), clf.init(k_c, obs, goal)

    return jax.vmap(one)(keys)


def dynamics_loss(obs_dim: int, hidden: tuple[int, ...]):
    """-> loss(params, batch): mean squared error of the normalised change of the skill's
    own dimensions (batch["dims"] (obs_dim,) mask), over samples weighted by batch["w"]."""
    net = CoarseDynamics(obs_dim, hidden)

    def loss(params, batch):
        pred = net.apply(params, batch["o"], batch["g"])
        sq = jnp.sum(batch["dims"] * (pred - batch["y"]) ** 2, axis=-1) / jnp.sum(batch["dims"])
        return jnp.sum(batch["w"] * sq) / jnp.maximum(jnp.sum(batch["w"]), 1.0)

    return loss


def classifier_loss(hidden: tuple[int, ...]):
    """-> loss(params, batch): binary cross-entropy of the success logit (weights w)."""
    net = SuccessClassifier(hidden)

    def loss(params, batch):
        logit = net.apply(params, batch["o"], batch["g"])
        bce = optax.sigmoid_binary_cross_entropy(logit, batch["y"])
        return jnp.sum(batch["w"] * bce) / jnp.maximum(jnp.sum(batch["w"]), 1.0)

    return loss


def make_fit_epoch(loss: Callable, optimizer: optax.GradientTransformation, batch_size: int):
    """-> fit_epoch(params, opt_state, train, key) -> (params, opt_state, mean loss): one
    shuffled pass over one skill's training split, in batches of `batch_size` (the whole
    split if it is smaller; the remainder of a pass is left out). Per skill; vmap it over the skill axis.
    `train` leaves are (N, ...) per sample, except `dims`, shared by all samples."""

    def fit_epoch(params, opt_state, train, key):
        n = train["w"].shape[0]
        size = min(batch_size, n)  # a split smaller than one batch is one batch
        n_batches = n // size
        order = jax.random.permutation(key, n)[: n_batches * size]
        batches = {
            k: (v if k == "dims" else v[order].reshape(n_batches, size, *v.shape[1:]))
            for k, v in train.items()
        }
        shared = {k: v for k, v in batches.items() if k == "dims"}
        per_step = {k: v for k, v in batches.items() if k != "dims"}

        def step(carry, batch):
            params, opt_state = carry
            batch = {**batch, **shared}
            params, opt_state, value, _ = optim.gradient_step(
                lambda p: (loss(p, batch), None), params, opt_state, optimizer
            )
            return (params, opt_state), value

        (params, opt_state), values = jax.lax.scan(step, (params, opt_state), per_step)
        return params, opt_state, jnp.mean(values)

    return fit_epoch


def fit(
    params: Any,
    train: dict[str, jax.Array],
    val: dict[str, jax.Array],
    loss: Callable,
    lr: float,
    config: LibraryConfig,
    keys: jax.Array,
    progress: Callable[[int, np.ndarray], None] | None = None,
) -> tuple[Any, list[dict[str, list[float]]]]:
    """Fit stacked parameters (K, ...) of K skills at once; data leaves (K, N, ...), one key
    per skill (K,) (so a skill's fit is the same alone or stacked with others).

    Each pass is one jitted program vmapped over the skill axis. Per skill, the parameters
    with the lowest held-out loss are kept, and the fit ends when no skill has improved for
    `config.patience` passes (or after `config.fit_epochs`). Returns (best parameters,
    history of train / held-out loss per pass, each a list over skills)."""
    optimizer = optax.adam(lr)
    opt_state = jax.vmap(optimizer.init)(params)
    epoch = jax.jit(jax.vmap(make_fit_epoch(loss, optimizer, config.fit_batch)))
    val_loss = jax.jit(jax.vmap(loss))
    best, best_loss = params, np.asarray(val_loss(params, val))
    since = np.zeros(best_loss.shape, int)
    history = []
    for i in range(config.fit_epochs):
        epoch_keys = jax.vmap(lambda k, i=i: jax.random.fold_in(k, i))(keys)
        params, opt_state, train_loss = epoch(params, opt_state, train, epoch_keys)
        current = np.asarray(val_loss(params, val))
        improved = current < best_loss
        best = _keep_improved(best, params, improved)
        best_loss = np.where(improved, current, best_loss)
        since = np.where(improved, 0, since + 1)
        history.append({"train": np.asarray(train_loss).tolist(), "val": current.tolist()})
        if progress is not None:
            progress(i, current)
        if np.all(since >= config.patience):
            break
    return best, history


def _keep_improved(best: Any, params: Any, improved: np.ndarray) -> Any:
    """Per skill (leading axis): the new parameters where `improved`, else the best so far."""
    pick = lambda b, p: jnp.where(improved.reshape(-1, *[1] * (p.ndim - 1)), p, b)
    return jax.tree.map(pick, best, params)


IGNORED = 1e6
"""The std that leaves a dimension out of a net's input (`standardize`, still='ignore')."""


def standardize(
    x: np.ndarray, weights: np.ndarray, still: str = "floor"
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean and std over the sample axis of x (N, d); a std below NORM_FLOOR is
    NORM_FLOOR, or with still='ignore' IGNORED (the dimension reads as 0 whatever it is;
    `LibraryConfig.still_inputs`)."""
    w = weights[:, None] / max(weights.sum(), 1.0)
    mean = (w * x).sum(0)
    std = np.sqrt((w * (x - mean) ** 2).sum(0))
    low = IGNORED if still == "ignore" else NORM_FLOOR
    return mean.astype(np.float32), np.where(std < NORM_FLOOR, low, std).astype(np.float32)


def auc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Area under the ROC curve (probability a positive outranks a negative; ties count
    half); NaN when one class is absent."""
    from scipy.stats import rankdata

    labels = labels.astype(bool)
    n_pos, n_neg = int(labels.sum()), int((~labels).sum())
    if n_pos == 0 or n_neg == 0:
        return float("nan")
    ranks = rankdata(scores)  # ties get their average rank
    return float((ranks[labels].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))
