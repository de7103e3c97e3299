"""Running mean / std normaliser of observations and goals, as a pytree.

The naive `sumsq / n - mean^2` loses all precision in float32 when |mean| >> std (a cube
at x = 0.7 m jittering by millimetres). We therefore accumulate sums of `x - shift`, where
`shift` is frozen at the first batch's mean ("shifted data" variance): the shifted sums
stay near zero-mean, so the subtraction no longer cancels catastrophically.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class NormState:
    count: jax.Array
    """() float32 number of rows seen."""
    sum: jax.Array
    """(dim,) float32 sum of `x - shift`."""
    sumsq: jax.Array
    """(dim,) float32 sum of `(x - shift)^2`."""
    shift: jax.Array
    """(dim,) float32 reference point, the mean of the first non-empty batch."""


def init(dim: int) -> NormState:
    """Empty statistics for `dim`-dimensional inputs."""
    zeros = jnp.zeros((dim,), jnp.float32)
    return NormState(count=jnp.zeros((), jnp.float32), sum=zeros, sumsq=zeros, shift=zeros)


def update(state: NormState, x: jax.Array) -> NormState:
    """Add the rows of `x` (N, dim) (any leading axes are flattened) to the statistics."""
    dim = state.sum.shape[-1]
    x = jnp.asarray(x, jnp.float32).reshape(-1, dim)
    if x.shape[0] == 0:  # static shape: nothing to add, and mean([]) would be NaN
        return state
    shift = jnp.where(state.count > 0, state.shift, jnp.mean(x, axis=0))
    d = x - shift
    return NormState(
        count=state.count + x.shape[0],
        sum=state.sum + jnp.sum(d, axis=0),
        sumsq=state.sumsq + jnp.sum(d * d, axis=0),
        shift=shift,
    )


def mean_std(state: NormState, eps: float) -> tuple[jax.Array, jax.Array]:
    """(dim,) mean and (dim,) std floored at `eps`; (0, 1) before any data was seen."""
    n = jnp.maximum(state.count, 1.0)
    m = state.sum / n
    # Rounding can push a (near-)constant column's variance slightly below zero.
    var = jnp.maximum(state.sumsq / n - m * m, 0.0)
    seen = state.count > 0
    mean = jnp.where(seen, state.shift + m, 0.0)
    std = jnp.where(seen, jnp.maximum(jnp.sqrt(var), eps), 1.0)
    return mean, std


def normalize(state: NormState, x: jax.Array, clip: float, eps: float) -> jax.Array:
    """(..., dim) -> (..., dim): `(x - mean) / max(std, eps)` clipped to [-clip, clip]."""
    mean, std = mean_std(state, eps)
    return jnp.clip((x - mean) / std, -clip, clip)
