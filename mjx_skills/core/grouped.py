"""Each row through its own skill's network, with fixed shapes: rows grouped by skill.

The library stacks its K skills' parameters along a leading axis. Running row b through
skill[b]'s network can be done three ways in a jitted program:
- every skill on every row, then keep row b's skill (`select`): K x the arithmetic, no
  copies; the cheapest for few rows;
- each row gathers its own parameters: a whole network copied per row;
- rows sorted by skill into blocks of `block` rows that all use one skill, each block
  gathering its skill's parameters once (`grouped`): about 1 x the arithmetic plus one
  parameter copy per block. For the search's thousands of rows through the 3 x 256 coarse
  models this is 2-3x cheaper than `select` (benchmarks/search.py).
`apply_per_row` picks by the number of rows (a static shape). Results agree to float
rounding: the same products, summed in blocks of another size.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

GROUPED_MIN_ROWS = 512
"""Fewer rows than this: `select` (the parameter copies would cost what they save)."""


def select(stacked: jax.Array, skill: jax.Array) -> jax.Array:
    """stacked (K, B, ...), skill (B,) -> (B, ...): row skill[b] for env b."""
    return jnp.take_along_axis(stacked, skill.reshape(1, -1, *[1] * (stacked.ndim - 2)), 0)[0]


def block_size(rows: int) -> int:
    """Rows per block: about a 16th of the rows, a power of two in [64, 1024]."""
    size = 64
    while size < 1024 and size * 32 <= rows:
        size *= 2
    return size


def apply_per_row(
    fn: Callable[..., jax.Array], tree: Any, skill: jax.Array, *rows: jax.Array
) -> jax.Array:
    """fn(tree[skill[b]], *rows[b]) for every row b -> (R, ...).

    fn(params, *row_blocks) must map a batch of rows (n, ...) to (n, ...) outputs; `tree`
    holds the K skills' parameters stacked on a leading axis; skill (R,) int in [0, K)."""
    n_skills = jax.tree.leaves(tree)[0].shape[0]
    R = skill.shape[0]
    if R < GROUPED_MIN_ROWS or n_skills == 1:
        return select(jax.vmap(lambda p: fn(p, *rows))(tree), skill)
    T = block_size(R)
    blocks = -(-R // T) + n_skills  # every skill's last block may be partly empty
    onehot = skill[:, None] == jnp.arange(n_skills)
    counts = jnp.sum(onehot, axis=0)
    padded = (counts + T - 1) // T * T
    ends = jnp.cumsum(padded)
    rank = jnp.take_along_axis(jnp.cumsum(onehot, axis=0) - 1, skill[:, None], 1)[:, 0]
    pos = (ends - padded)[skill] + rank  # each row's place in the blocked layout
    block_skill = jnp.minimum(
        jnp.searchsorted(ends, jnp.arange(blocks) * T, side="right"), n_skills - 1
    )
    params = jax.tree.map(lambda p: p[block_skill], tree)
    laid_out = [
        jnp.zeros((blocks * T, *r.shape[1:]), r.dtype)
        .at[pos]
        .set(r)
        .reshape(blocks, T, *r.shape[1:])
        for r in rows
    ]
    out = jax.vmap(fn)(params, *laid_out)
    return out.reshape(blocks * T, *out.shape[2:])[pos]
