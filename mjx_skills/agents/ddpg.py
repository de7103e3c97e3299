"""DDPG with goal-conditioned actor and critic (the learner of DDPG + HER).

`config` (a frozen, hashable DDPGConfig) is never part of the pytree: close over it or
pass it as a static argument, e.g. `jax.jit(functools.partial(update, config=config))`.
All inputs are normalised with the state's running statistics before the networks.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import optax
from flax import struct

from mjx_skills.config import DDPGConfig
from mjx_skills.core import normalizer, optim
from mjx_skills.core.nets import Actor, Critic

Params = dict


@struct.dataclass
class DDPGState:
    actor_params: Params
    critic_params: Params
    target_actor_params: Params
    target_critic_params: Params
    actor_opt_state: optax.OptState
    critic_opt_state: optax.OptState
    obs_norm: normalizer.NormState
    goal_norm: normalizer.NormState
    steps: jax.Array
    """() int32 number of `update` calls."""
    act_dim: int = struct.field(pytree_node=False)
    """Action dimension, static: the actor module needs it to be rebuilt."""
    bounds: str = struct.field(pytree_node=False, default="tanh")
    """How actions stay in [-1, 1]: 'tanh' squashes the actor's output; 'invert' keeps it
    linear and inverts the critic's gradients at the bounds (Hausknecht & Stone 2016, the
    parameterized-action actor of PAS), clipping it wherever an action is used."""
    views: tuple | None = struct.field(pytree_node=False, default=None)
    """The objects' views of a `deep_sets` architecture (`nets.Views`), static; None: MLPs."""


def actor_module(state: DDPGState, config: DDPGConfig) -> Actor:
    return _actor_module(state.act_dim, state.bounds, config, state.views)


def _actor_module(act_dim: int, bounds: str, config: DDPGConfig, views=None) -> Actor:
    return Actor(
        act_dim=act_dim,
        hidden=tuple(config.hidden),
        layer_norm=config.layer_norm,
        squash=bounds == "tanh",
        views=views,
        activation=config.activation,
        weight_init=config.weight_init,
    )


def critic_module(config: DDPGConfig, views=None) -> Critic:
    return Critic(
        hidden=tuple(config.hidden),
        layer_norm=config.layer_norm,
        ensemble=config.critics,
        views=views,
        activation=config.activation,
        weight_init=config.weight_init,
    )


def pessimistic(q: jax.Array, config: DDPGConfig) -> jax.Array:
    """The critics' heads (..., critics) -> their minimum (...) (TD3's clipped double Q);
    with one critic, q (...) itself."""
    return q if config.critics == 1 else jnp.min(q, axis=-1)


def actor_opt(config: DDPGConfig) -> optax.GradientTransformation:
    return optax.adam(config.actor_lr)


def critic_opt(config: DDPGConfig) -> optax.GradientTransformation:
    return optax.adam(config.critic_lr)


BOUNDS = ("tanh", "invert")


def init(
    key: jax.Array,
    obs_dim: int,
    goal_dim: int,
    act_dim: int,
    config: DDPGConfig,
    bounds: str = "tanh",
    critic_act_dim: int | None = None,
    views: tuple | None = None,
) -> DDPGState:
    """Fresh networks (targets equal to the online ones), Adam states, empty normalisers.
    `critic_act_dim`: the critic's action input where it is not the actor's output (the
    per-skill critic of PAS, `pdqn`). `views`: the objects' views (`nets.Views`), for
    `config.architecture` 'deep_sets' (required there, ignored otherwise)."""
    if config.architecture == "mlp":
        views = None
    elif views is None:
        raise ValueError("architecture 'deep_sets' needs the objects' views (nets.Views)")
    if bounds not in BOUNDS:
        raise ValueError(f"unknown action bounds {bounds!r}; valid: {', '.join(BOUNDS)}")
    k_actor, k_critic = jax.random.split(key)
    obs = jnp.zeros((1, obs_dim), jnp.float32)
    goal = jnp.zeros((1, goal_dim), jnp.float32)
    action = jnp.zeros((1, critic_act_dim or act_dim), jnp.float32)
    actor_params = _actor_module(act_dim, bounds, config, views).init(k_actor, obs, goal)
    critic_params = critic_module(config, views).init(k_critic, obs, goal, action)
    return DDPGState(
        actor_params=actor_params,
        critic_params=critic_params,
        target_actor_params=actor_params,
        target_critic_params=critic_params,
        actor_opt_state=actor_opt(config).init(actor_params),
        critic_opt_state=critic_opt(config).init(critic_params),
        obs_norm=normalizer.init(obs_dim),
        goal_norm=normalizer.init(goal_dim),
        steps=jnp.zeros((), jnp.int32),
        act_dim=act_dim,
        bounds=bounds,
        views=views,
    )


def normalize_inputs(
    state: DDPGState, obs: jax.Array, goal: jax.Array, config: DDPGConfig
) -> tuple[jax.Array, jax.Array]:
    o = normalizer.normalize(state.obs_norm, obs, config.norm_clip, config.norm_eps)
    g = normalizer.normalize(state.goal_norm, goal, config.norm_clip, config.norm_eps)
    return o, g


def act(state: DDPGState, obs: jax.Array, goal: jax.Array, config: DDPGConfig) -> jax.Array:
    """Deterministic policy: (..., obs_dim), (..., goal_dim) -> (..., act_dim) in [-1, 1]."""
    o, g = normalize_inputs(state, obs, goal, config)
    return _bounded(state, actor_module(state, config).apply(state.actor_params, o, g))


def _bounded(state: DDPGState, action: jax.Array) -> jax.Array:
    # A tanh output is in range already (and stays bit for bit what it was).
    return action if state.bounds == "tanh" else jnp.clip(action, -1.0, 1.0)


def invert_gradients(grad: jax.Array, action: jax.Array) -> jax.Array:
    """dQ/da scaled by the room left towards the bound it points to, for actions bounded by
    [-1, 1]: (1 - a) / 2 when it pushes up, (a + 1) / 2 when down. Past a bound the factor
    turns negative, so the step points back inside (Hausknecht & Stone 2016, eq. 5)."""
    up = grad > 0
    return grad * jnp.where(up, (1.0 - action) / 2.0, (action + 1.0) / 2.0)


def explore(
    state: DDPGState, key: jax.Array, obs: jax.Array, goal: jax.Array, config: DDPGConfig
) -> jax.Array:
    """Exploration action (..., act_dim): policy + N(0, noise_sigma^2) clipped to [-1, 1];
    with probability random_eps a uniform random action in [-1, 1] instead."""
    return perturb(key, act(state, obs, goal, config), config)


def perturb(key: jax.Array, a: jax.Array, config: DDPGConfig) -> jax.Array:
    """DDPG's exploration noise on actions a (..., act_dim) in [-1, 1]: + N(0, noise_sigma^2)
    clipped to [-1, 1]; with probability random_eps a uniform random action instead."""
    k_noise, k_rand, k_pick = jax.random.split(key, 3)
    a = jnp.clip(a + config.noise_sigma * jax.random.normal(k_noise, a.shape), -1.0, 1.0)
    random_a = jax.random.uniform(k_rand, a.shape, minval=-1.0, maxval=1.0)
    pick_random = jax.random.uniform(k_pick, a.shape[:-1]) < config.random_eps
    return jnp.where(pick_random[..., None], random_a, a)


def q_value(
    state: DDPGState, obs: jax.Array, goal: jax.Array, action: jax.Array, config: DDPGConfig
) -> jax.Array:
    """Online critic Q: (..., obs_dim), (..., goal_dim), (..., act_dim) -> (...)."""
    o, g = normalize_inputs(state, obs, goal, config)
    critic = critic_module(config, state.views)
    return pessimistic(critic.apply(state.critic_params, o, g, action), config)


def observe(state: DDPGState, obs: jax.Array, goal: jax.Array) -> DDPGState:
    """Add observations (..., obs_dim) and goals (..., goal_dim) to the running statistics."""
    return state.replace(
        obs_norm=normalizer.update(state.obs_norm, obs),
        goal_norm=normalizer.update(state.goal_norm, goal),
    )


def normalize_batch(
    state: DDPGState, batch: dict[str, jax.Array], config: DDPGConfig
) -> dict[str, jax.Array]:
    """Raw batch (obs, next_obs, goal, action, reward) -> the networks' inputs: normalised
    `obs`, `next_obs` and `goal`, raw `action` and `reward`."""
    o, g = normalize_inputs(state, batch["obs"], batch["goal"], config)
    o2 = normalizer.normalize(state.obs_norm, batch["next_obs"], config.norm_clip, config.norm_eps)
    out = {
        "obs": o,
        "next_obs": o2,
        "goal": g,
        "action": batch["action"],
        "reward": batch["reward"],
    }
    return {**out, **{k: batch[k] for k in ("terminal", "demo", "discount") if k in batch}}


def _td_target(state: DDPGState, nbatch: dict[str, jax.Array], config: DDPGConfig) -> jax.Array:
    o2, g = nbatch["next_obs"], nbatch["goal"]
    a2 = _bounded(state, actor_module(state, config).apply(state.target_actor_params, o2, g))
    q2 = critic_module(config, state.views).apply(state.target_critic_params, o2, g, a2)
    return target_from_next_value(nbatch, pessimistic(q2, config), config)


def target_from_next_value(
    nbatch: dict[str, jax.Array], q2: jax.Array, config: DDPGConfig
) -> jax.Array:
    """r + gamma * Q' (Q' dropped after an optional `terminal`: PAS's goal reached; an
    optional `discount` (B,) in gamma's place: n-step returns), optionally clipped to
    [-1 / (1 - gamma), 0]; no gradient flows through it."""
    reward = nbatch["reward"]
    if reward.shape != q2.shape:  # (B, 1) rewards would silently broadcast to (B, B)
        raise ValueError(f"reward shape {reward.shape} != Q shape {q2.shape}")
    if "terminal" in nbatch:
        q2 = q2 * (1.0 - nbatch["terminal"])
    y = reward + nbatch.get("discount", config.gamma) * q2
    if config.clip_target:
        y = jnp.clip(y, -1.0 / (1.0 - config.gamma), 0.0)
    return jax.lax.stop_gradient(y)


def td_target(state: DDPGState, batch: dict[str, jax.Array], config: DDPGConfig) -> jax.Array:
    """(B,) critic target r + gamma * Q_target(s', g, pi_target(s', g)), optionally clipped to
    [-1 / (1 - gamma), 0] (no terminal masking: episodes end by time limit only)."""
    return _td_target(state, normalize_batch(state, batch, config), config)


def update(
    state: DDPGState, batches: dict[str, jax.Array], config: DDPGConfig, bc_weight: float = 0.0
) -> tuple[DDPGState, dict[str, jax.Array]]:
    """n gradient steps, one per batch: each a critic step, an actor step (against the new
    critic) and a soft target update.

    batches: obs / next_obs (n, B, obs_dim), goal (n, B, goal_dim), action (n, B, act_dim),
    reward (n, B). The normalisers stay as they are during the n steps, so all batches are
    normalised in one pass before the loop, which holds only the networks' update (a cycle
    at one update per env step ran 1.44x faster so on 2 CPU cores).
    Returns the new state and per-step metrics (n,): critic_loss (summed over the critics),
    actor_loss, q_mean (over every critic's head).

    `bc_weight` > 0 (batches then hold `demo` (n, B) bool, the rows whose action an expert
    took): the actor also clones the demonstrated actions where the critic rates them above
    its own (`q_filtered_bc_loss`), and the metrics add bc_loss and bc_share.
    """
    nbatches = normalize_batch(state, batches, config)
    step = lambda s, nbatch: _step(s, nbatch, config, bc_weight)  # noqa: E731
    state, metrics = jax.lax.scan(step, state, nbatches)
    return cycle_targets(state, config), metrics


def soft_targets(state: DDPGState, config: DDPGConfig) -> DDPGState:
    """The targets moved towards the online networks by `config.tau`."""
    return state.replace(
        target_actor_params=optim.soft_update(
            state.target_actor_params, state.actor_params, config.tau
        ),
        target_critic_params=optim.soft_update(
            state.target_critic_params, state.critic_params, config.tau
        ),
    )


def cycle_targets(state: DDPGState, config: DDPGConfig) -> DDPGState:
    """After a cycle's gradient steps: the targets moved once where `config.target_update`
    is 'cycle' (the steps left them), else `state` as it is (each step moved them)."""
    return soft_targets(state, config) if config.target_update == "cycle" else state


def td_loss(q: jax.Array, y: jax.Array) -> jax.Array:
    """The critic's loss: the mean squared TD error of q (B,) against targets y (B,)."""
    return jnp.mean((q - y) ** 2)


def actor_loss(q_pi: jax.Array, pi: jax.Array, action_l2: float) -> jax.Array:
    """DDPG's actor loss: -mean Q(s, g, pi) over the batch q_pi (B,), plus `action_l2` times
    the mean squared action pi (B, act_dim), which keeps actions off tanh's flat tails."""
    return -jnp.mean(q_pi) + action_l2 * jnp.mean(pi**2)


def inverting_actor_loss(q_of: Callable[[jax.Array], jax.Array], pi: jax.Array) -> jax.Array:
    """The actor loss of actions bounded by inverting gradients (Hausknecht & Stone 2016): its
    gradient through pi (B, act_dim) is -invert_gradients(dQ/da, a) / B at a = pi, so the
    actor ascends Q while each step shrinks towards the bound it approaches; its value is
    -mean Q. q_of(a (B, act_dim)) -> the sum of Q over the batch."""
    a = jax.lax.stop_gradient(pi)
    dq = invert_gradients(jax.grad(q_of)(a), a) / a.shape[0]
    surrogate = -jnp.sum(dq * pi)
    return surrogate - jax.lax.stop_gradient(surrogate + q_of(a) / a.shape[0])


def q_filtered_bc_loss(
    pi: jax.Array, action: jax.Array, demo: jax.Array, q_demo: jax.Array, q_pi: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """Behaviour cloning with the Q-filter (Nair et al. 2018, "Overcoming Exploration in RL
    with Demonstrations", eq. 5): the squared error between the actor's actions pi (B, A)
    and the demonstrated ones (B, A), on the demonstration rows `demo` (B,) whose action the
    critic values above the actor's (q_demo (B,) > q_pi (B,), no gradient). -> (the mean over
    the rows kept, 0 if none; the share of rows kept)."""
    keep = demo & jax.lax.stop_gradient(q_demo > q_pi)
    err = jnp.sum((pi - action) ** 2, axis=-1)
    loss = jnp.sum(jnp.where(keep, err, 0.0)) / jnp.maximum(jnp.sum(keep), 1)
    return loss, jnp.mean(keep.astype(jnp.float32))


def _step(
    state: DDPGState, nbatch: dict[str, jax.Array], config: DDPGConfig, bc_weight: float = 0.0
) -> tuple[DDPGState, dict[str, jax.Array]]:
    actor, critic = actor_module(state, config), critic_module(config, state.views)
    o, g, action = nbatch["obs"], nbatch["goal"], nbatch["action"]
    y = _td_target(state, nbatch, config)

    def critic_loss_fn(params: Params) -> tuple[jax.Array, jax.Array]:
        q = critic.apply(params, o, g, action)  # (B,) or (B, critics): every head fits y
        if config.critics == 1:
            return td_loss(q, y), q
        return sum(td_loss(q[..., i], y) for i in range(config.critics)), q

    critic_params, critic_opt_state, critic_value, q = optim.gradient_step(
        critic_loss_fn, state.critic_params, state.critic_opt_state, critic_opt(config)
    )

    def actor_loss_fn(params: Params) -> tuple[jax.Array, None]:
        pi = actor.apply(params, o, g)
        if state.bounds == "invert":
            q_of = lambda a: jnp.sum(pessimistic(critic.apply(critic_params, o, g, a), config))
            return inverting_actor_loss(q_of, pi), None
        q_pi = pessimistic(critic.apply(critic_params, o, g, pi), config)
        loss = actor_loss(q_pi, pi, config.action_l2)
        if not bc_weight:
            return loss, None
        q_demo = pessimistic(critic.apply(critic_params, o, g, action), config)
        bc, share = q_filtered_bc_loss(pi, action, nbatch["demo"], q_demo, q_pi)
        return loss + bc_weight * bc, {"bc_loss": bc, "bc_share": share}

    actor_params, actor_opt_state, actor_value, aux = optim.gradient_step(
        actor_loss_fn, state.actor_params, state.actor_opt_state, actor_opt(config)
    )
    new_state = advance(
        state, actor_params, critic_params, actor_opt_state, critic_opt_state, config
    )
    metrics = {
        "critic_loss": critic_value,
        "actor_loss": actor_value,
        "q_mean": jnp.mean(q),
        **(aux or {}),
    }
    return new_state, metrics


def advance(
    state: DDPGState,
    actor_params: Params,
    critic_params: Params,
    actor_opt_state: optax.OptState,
    critic_opt_state: optax.OptState,
    config: DDPGConfig,
) -> DDPGState:
    """The state after one gradient step: new networks and optimiser states, the step
    counted, and the targets moved by Polyak averaging where `config.target_update` is
    'step' (else after the cycle: `cycle_targets`)."""
    state = state.replace(
        actor_params=actor_params,
        critic_params=critic_params,
        actor_opt_state=actor_opt_state,
        critic_opt_state=critic_opt_state,
        steps=state.steps + 1,
    )
    return soft_targets(state, config) if config.target_update == "step" else state
