"""Episode-aligned ring replay buffer as pure functions over a `ReplayState` pytree.

An episode of length T is a pytree (`rollout.Episode`, a dict, or a method's own record)
whose leaves have leading axis T (per-step fields: `g`, `actions`) or T + 1 (per-state
fields: `obs`, `ag`). Whole episodes are stored per slot, which lets HER look up later
achieved goals of the same episode by index.

Slots fill in order 0, 1, ... from an empty buffer, so while it is not full the filled
slots are exactly [0, size); `sample_indices` relies on that.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct


@struct.dataclass
class ReplayState:
    data: Any
    """The episode pytree with leaves (n_slots, T or T + 1, ...), each in its own dtype."""
    insert: jax.Array
    """() int32 slot the next episode is written to."""
    size: jax.Array
    """() int32 number of filled slots (saturates at n_slots)."""
    T: int = struct.field(pytree_node=False)
    """Episode length (transitions per episode)."""
    n_slots: int = struct.field(pytree_node=False)
    """Episode slots; static so it stays right when states are stacked over seeds."""


def _shape(x: Any) -> tuple[int, ...]:
    return tuple(x.shape) if hasattr(x, "shape") else np.shape(x)


def _fields(tree: Any) -> list[tuple[str, Any]]:
    """(path name, leaf) of every leaf, for messages."""
    return [(jax.tree_util.keystr(p), x) for p, x in jax.tree_util.tree_leaves_with_path(tree)]


def _infer_T(example_episode: Any) -> int:
    lengths = {_shape(x)[0] for x in jax.tree.leaves(example_episode)}
    if len(lengths) == 1:
        return lengths.pop()
    if len(lengths) == 2 and max(lengths) == min(lengths) + 1:
        return min(lengths)
    raise ValueError(f"episode fields need leading axis T or T + 1, got lengths {lengths}")


def _dtype(x: Any) -> jnp.dtype:
    # numpy float64 examples become float32 unless jax_enable_x64 is on.
    return jax.dtypes.canonicalize_dtype(x.dtype if hasattr(x, "dtype") else jnp.result_type(x))


def init(capacity_transitions: int, example_episode: Any, T: int | None = None) -> ReplayState:
    """Empty buffer of max(1, capacity_transitions // T) episode slots.

    `example_episode` gives each field's shape and dtype (arrays or jax.ShapeDtypeStruct,
    no batch axis). T is inferred from the leading axes (the shorter of T and T + 1); pass
    it explicitly when every field has the same leading axis T + 1.
    """
    if not jax.tree.leaves(example_episode):
        raise ValueError("example_episode has no fields")
    T = _infer_T(example_episode) if T is None else int(T)
    if T < 1:
        raise ValueError(f"episode length T must be >= 1, got {T}")
    for k, x in _fields(example_episode):
        if _shape(x)[0] not in (T, T + 1):
            raise ValueError(f"field '{k}' has leading axis {_shape(x)[0]}, not {T} or {T + 1}")
    n_slots = max(1, capacity_transitions // T)
    data = jax.tree.map(lambda x: jnp.zeros((n_slots, *_shape(x)), _dtype(x)), example_episode)
    zero = jnp.zeros((), jnp.int32)
    return ReplayState(data=data, insert=zero, size=zero, T=T, n_slots=n_slots)


def add(state: ReplayState, episodes: Any) -> ReplayState:
    """Write B episodes (leaves (B, T or T + 1, ...)) at `insert`, wrapping around.

    When B exceeds the number of slots only the last n_slots episodes survive, exactly as if
    they had been added one by one.
    """
    if jax.tree.structure(episodes) != jax.tree.structure(state.data):
        names = lambda t: sorted(k for k, _ in _fields(t))
        raise ValueError(f"episode fields {names(episodes)} != buffer's {names(state.data)}")
    n = state.n_slots
    B = jax.tree.leaves(episodes)[0].shape[0]
    for (k, new), buf in zip(_fields(episodes), jax.tree.leaves(state.data), strict=True):
        if new.shape != (B, *buf.shape[1:]):
            raise ValueError(f"field {k}: got {new.shape}, want {(B, *buf.shape[1:])}")
    # Scatters with duplicate indices have no defined winner: drop what would be overwritten.
    keep = min(B, n)
    start = state.insert + (B - keep)
    idx = (start + jnp.arange(keep, dtype=jnp.int32)) % n
    data = jax.tree.map(
        lambda buf, new: buf.at[idx].set(new[B - keep :].astype(buf.dtype)), state.data, episodes
    )
    return ReplayState(
        data=data,
        insert=((state.insert + B) % n).astype(jnp.int32),
        size=jnp.minimum(state.size + B, n).astype(jnp.int32),
        T=state.T,
        n_slots=n,
    )


def sample_indices(
    state: ReplayState, key: jax.Array, batch_size: int
) -> tuple[jax.Array, jax.Array]:
    """(batch_size,) int32 episode slots uniform over the filled ones and (batch_size,) int32
    steps t uniform in [0, T). On an empty buffer it returns slot 0 (zeros)."""
    k_ep, k_t = jax.random.split(key)
    episode_idx = jax.random.randint(k_ep, (batch_size,), 0, jnp.maximum(state.size, 1))
    t = jax.random.randint(k_t, (batch_size,), 0, state.T)
    return episode_idx.astype(jnp.int32), t.astype(jnp.int32)
