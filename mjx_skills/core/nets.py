"""Flax networks: a generic MLP, the DDPG actor and critic, the skills' coarse dynamics
model and success classifier.

Every module maps over arbitrary leading axes (Dense and LayerNorm act on the last one), so
the same parameters serve single examples, batches and vmapped envs.
"""

from __future__ import annotations

import functools

import flax.linen as nn
import jax
import jax.numpy as jnp

ACTIVATIONS = {"relu": nn.relu, "gelu": functools.partial(nn.gelu, approximate=False)}
"""Hidden-layer activations by name ('gelu': the exact erf form, PyTorch's default)."""
INITS = ("lecun", "orthogonal")
"""Dense initialisations: flax's default ('lecun': LeCun-normal kernels), or 'orthogonal'
kernels of scale 1 and an output layer of scale 0.1 (mrl's `layer_init`, Pitis et al.);
biases zero in both."""


def _dense(width: int, init: str, scale: float = 1.0) -> nn.Dense:
    if init == "orthogonal":
        return nn.Dense(width, kernel_init=nn.initializers.orthogonal(scale))
    if init != "lecun":
        raise ValueError(f"unknown init '{init}', expected one of {INITS}")
    return nn.Dense(width)


def _hidden_layers(
    x: jax.Array, widths: tuple[int, ...], layer_norm: bool, activation: str, init: str
) -> jax.Array:
    """Dense -> [LayerNorm] -> activation per width, made inside the calling module's compact
    method (so the layers are its own: Dense_0, LayerNorm_0, ...)."""
    for width in widths:
        x = _dense(width, init)(x)
        if layer_norm:
            x = nn.LayerNorm()(x)
        x = ACTIVATIONS[activation](x)
    return x


class MLP(nn.Module):
    """(..., in) -> (..., out_dim): Dense -> [LayerNorm] -> activation per hidden layer, then
    Dense (`ACTIVATIONS`, `INITS`)."""

    hidden: tuple[int, ...]
    layer_norm: bool
    out_dim: int
    activation: str = "relu"
    weight_init: str = "lecun"

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        # The hidden layers before the last Dense: its name.
        x = _hidden_layers(x, self.hidden, self.layer_norm, self.activation, self.weight_init)
        return _dense(self.out_dim, self.weight_init, 0.1)(x)


class DeepSet(nn.Module):
    """(..., n, in) -> (..., out_dim): a set of n elements, each encoded by the same layers
    (Dense -> [LayerNorm] -> activation per width of `hidden` but the last), summed over the
    set, then an MLP of the last width (Deep Sets, Zaheer et al. 2017): the same output for
    any order of the elements."""

    hidden: tuple[int, ...]
    layer_norm: bool
    out_dim: int
    activation: str = "relu"
    weight_init: str = "lecun"

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        x = _hidden_layers(x, self.hidden[:-1], self.layer_norm, self.activation, self.weight_init)
        head = MLP(
            self.hidden[-1:], self.layer_norm, self.out_dim, self.activation, self.weight_init
        )
        return head(x.sum(axis=-2))


Views = tuple[tuple[int, ...], ...]
"""Per object k, the observation's indices that make its view (static): obs[..., views[k]]."""


def object_set(obs: jax.Array, goal: jax.Array, views: Views, *rest: jax.Array) -> jax.Array:
    """(..., obs_dim), (..., goal_dim) [, (..., d) shared by all] -> (..., n, view + goal_dim
    / n [+ d]): object k's view, its part of the goal and what every object shares."""
    n = len(views)
    parts = [
        jnp.stack([obs[..., jnp.asarray(v)] for v in views], axis=-2),
        goal.reshape(*goal.shape[:-1], n, -1),
    ]
    parts += [jnp.broadcast_to(r[..., None, :], (*r.shape[:-1], n, r.shape[-1])) for r in rest]
    return jnp.concatenate(parts, axis=-1)


class Actor(nn.Module):
    """pi(obs, goal): (..., obs_dim), (..., goal_dim) -> (..., act_dim), squashed into
    [-1, 1] by tanh, or linear (`squash=False`: bounds kept by inverting gradients). With
    `views`: a `DeepSet` over the objects' views (`object_set`)."""

    act_dim: int
    hidden: tuple[int, ...] = (64, 64, 64)
    layer_norm: bool = True
    squash: bool = True
    views: Views | None = None
    activation: str = "relu"
    weight_init: str = "lecun"

    @nn.compact
    def __call__(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        if self.views is None:
            x, net = jnp.concatenate([obs, goal], -1), MLP
        else:
            x, net = object_set(obs, goal, self.views), DeepSet
        out = net(self.hidden, self.layer_norm, self.act_dim, self.activation, self.weight_init)(x)
        return jnp.tanh(out) if self.squash else out


class Critic(nn.Module):
    """Q(obs, goal, action): (..., obs_dim), (..., goal_dim), (..., act_dim) -> (...); with
    `ensemble` E > 1, E independently initialised critics side by side -> (..., E)
    (the twin critics of TD3, Fujimoto et al. 2018, at E = 2)."""

    hidden: tuple[int, ...] = (64, 64, 64)
    layer_norm: bool = True
    ensemble: int = 1
    views: Views | None = None
    """As the `Actor`'s: a `DeepSet` over (view, its goal, the action) per object."""
    activation: str = "relu"
    weight_init: str = "lecun"

    @nn.compact
    def __call__(self, obs: jax.Array, goal: jax.Array, action: jax.Array) -> jax.Array:
        if self.views is None:
            x, net = jnp.concatenate([obs, goal, action], axis=-1), MLP
        else:
            x, net = object_set(obs, goal, self.views, action), DeepSet
        heads = [
            net(self.hidden, self.layer_norm, 1, self.activation, self.weight_init)(x)[..., 0]
            for _ in range(self.ensemble)
        ]
        return heads[0] if self.ensemble == 1 else jnp.stack(heads, axis=-1)  # MLP_0, MLP_1, ...


class CoarseDynamics(nn.Module):
    """Terminal state of a skill from its start: (..., obs_dim), (..., goal_dim) -> (..., obs_dim)
    change of the (normalised) observation over the skill's run (thesis 3.3)."""

    obs_dim: int
    hidden: tuple[int, ...] = (256, 256, 256)
    layer_norm: bool = True

    @nn.compact
    def __call__(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        x = jnp.concatenate([obs, goal], axis=-1)
        return MLP(self.hidden, self.layer_norm, self.obs_dim)(x)


class SuccessClassifier(nn.Module):
    """Logit of the skill reaching its goal from this start: (..., obs_dim), (..., goal_dim)
    -> (...); sigmoid of it is the success probability (thesis 3.3)."""

    hidden: tuple[int, ...] = (50, 10)
    layer_norm: bool = True

    @nn.compact
    def __call__(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        x = jnp.concatenate([obs, goal], axis=-1)
        return MLP(self.hidden, self.layer_norm, 1)(x)[..., 0]
