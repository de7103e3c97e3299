"""`--ddpg.weight-init` and `--ddpg.activation`: mrl's networks (orthogonal kernels, output layers
scaled by 0.1, GELU) beside the defaults (flax's LeCun-normal, ReLU), whose parameters keep
their names so that stored skill libraries load as before."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig
from mjx_skills.core import nets

OBS, GOAL, ACT = 10, 3, 4


def _kernels(params) -> list[np.ndarray]:
    flat = jax.tree_util.tree_flatten_with_path(params)[0]
    return [np.asarray(v) for p, v in flat if "kernel" in jax.tree_util.keystr(p)]


def _state(**fields):
    config = DDPGConfig(hidden=(32, 32), **fields)
    return ddpg.init(jax.random.key(0), OBS, GOAL, ACT, config), config


def test_orthogonal_init_has_orthonormal_hidden_kernels_and_output_layers_of_scale_0_1():
    state, _ = _state(weight_init="orthogonal", layer_norm=False)
    for params in (state.actor_params, state.critic_params):
        *hidden, out = _kernels(params)
        for w in hidden:  # (in, out): orthonormal columns where in >= out, rows otherwise
            gram = w.T @ w if w.shape[0] >= w.shape[1] else w @ w.T
            np.testing.assert_allclose(gram, np.eye(len(gram)), atol=1e-4)
        gram = out.T @ out if out.shape[0] >= out.shape[1] else out @ out.T
        np.testing.assert_allclose(gram, 0.01 * np.eye(len(gram)), atol=1e-5)
    lecun, _ = _state(layer_norm=False)
    w = _kernels(lecun.actor_params)[0]
    assert not np.allclose(w.T @ w, np.eye(w.shape[1]), atol=0.1)  # the default is not it


def test_the_options_keep_the_parameter_names_and_change_the_outputs():
    base, config = _state()
    obs, goal = jnp.ones((5, OBS)), jnp.linspace(-1, 1, 5 * GOAL).reshape(5, GOAL)
    a = ddpg.act(base, obs, goal, config)
    for fields in ({"activation": "gelu"}, {"weight_init": "orthogonal"}):
        other, other_config = _state(**fields)
        same = jax.tree.structure(other.actor_params) == jax.tree.structure(base.actor_params)
        assert same, fields
        b = ddpg.act(other, obs, goal, other_config)
        assert b.shape == a.shape and not np.allclose(a, b), fields
    # GELU, not ReLU, on the same parameters: negative pre-activations pass a little.
    gelu = nets.ACTIVATIONS["gelu"]
    np.testing.assert_allclose(gelu(jnp.array([-1.0, 0.0, 1.0])), [-0.1587, 0.0, 0.8413], atol=1e-4)


@pytest.mark.parametrize("field, value", [("weight_init", "xavier"), ("activation", "tanh")])
def test_an_unknown_choice_names_the_field_and_the_choices(field, value):
    with pytest.raises(ValueError, match=field):
        DDPGConfig(**{field: value})
