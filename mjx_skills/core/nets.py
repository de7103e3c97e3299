"""Flax networks: a generic MLP, the DDPG actor and critic, the skills' coarse dynamics
model and success classifier.

Every module maps over arbitrary leading axes (Dense and LayerNorm act on the last one), so
the same parameters serve single examples, batches and vmapped envs.
"""

from __future__ import annotations

import flax.linen as nn
import jax
import jax.numpy as jnp


class MLP(nn.Module):
    """(..., in) -> (..., out_dim): Dense -> [LayerNorm] -> ReLU per hidden layer, then Dense."""

    hidden: tuple[int, ...]
    layer_norm: bool
    out_dim: int

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        for width in self.hidden:
            x = nn.Dense(width)(x)
            if self.layer_norm:
                x = nn.LayerNorm()(x)
            x = nn.relu(x)
        return nn.Dense(self.out_dim)(x)


class Actor(nn.Module):
    """pi(obs, goal): (..., obs_dim), (..., goal_dim) -> (..., act_dim), squashed into
    [-1, 1] by tanh, or linear (`squash=False`: bounds kept by inverting gradients)."""

    act_dim: int
    hidden: tuple[int, ...] = (64, 64, 64)
    layer_norm: bool = True
    squash: bool = True

    @nn.compact
    def __call__(self, obs: jax.Array, goal: jax.Array) -> jax.Array:
        x = jnp.concatenate([obs, goal], axis=-1)
        out = MLP(self.hidden, self.layer_norm, self.act_dim)(x)
        return jnp.tanh(out) if self.squash else out


class Critic(nn.Module):
    """Q(obs, goal, action): (..., obs_dim), (..., goal_dim), (..., act_dim) -> (...); with
    `ensemble` E > 1, E independently initialised critics side by side -> (..., E)
    (the twin critics of TD3, Fujimoto et al. 2018, at E = 2)."""

    hidden: tuple[int, ...] = (64, 64, 64)
    layer_norm: bool = True
    ensemble: int = 1

    @nn.compact
    def __call__(self, obs: jax.Array, goal: jax.Array, action: jax.Array) -> jax.Array:
        x = jnp.concatenate([obs, goal, action], axis=-1)
        heads = [MLP(self.hidden, self.layer_norm, 1)(x)[..., 0] for _ in range(self.ensemble)]
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
