"""Gradient steps and soft target updates, shared by DDPG, PAS and the skill-model fits."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import optax


def gradient_step(
    loss_fn: Callable[[Any], tuple[jax.Array, Any]],
    params: Any,
    opt_state: optax.OptState,
    optimizer: optax.GradientTransformation,
) -> tuple[Any, optax.OptState, jax.Array, Any]:
    """One optimiser step on `loss_fn(params) -> (loss, aux)`.

    Returns (new params, new optimiser state, loss, aux)."""
    (loss, aux), grads = jax.value_and_grad(loss_fn, has_aux=True)(params)
    updates, opt_state = optimizer.update(grads, opt_state, params)
    return optax.apply_updates(params, updates), opt_state, loss, aux


def soft_update(target: Any, online: Any, tau: float) -> Any:
    """Polyak averaging: target <- (1 - tau) target + tau online, leaf by leaf."""
    return jax.tree.map(lambda t, p: (1.0 - tau) * t + tau * p, target, online)
