"""Every program of this package runs in float32.

With `JAX_ENABLE_X64=1` (or `jax.config.update("jax_enable_x64", True)`) JAX would build the
replay's actions and goals in float64: other losses for the same config.json (0.590 against
0.535 in one run), and a float32 run's checkpoint no longer restores. The commands switch
x64 off with a warning (`use_float32`); the Python API refuses it (`require_float32`), as
turning it off there would change the caller's own arrays.
"""

from __future__ import annotations

import warnings


def x64_enabled() -> bool:
    import jax

    return bool(jax.config.jax_enable_x64)


def require_float32() -> None:
    """ValueError if JAX runs with 64-bit types enabled."""
    if x64_enabled():
        raise ValueError(
            "mjx_skills trains and evaluates in float32, but JAX has 64-bit types enabled "
            "(JAX_ENABLE_X64 or jax.config.update('jax_enable_x64', True)): turn that off "
            "before building a run"
        )


def use_float32() -> None:
    """For the commands: switch 64-bit types off, with a warning when they were on."""
    if x64_enabled():
        import jax

        warnings.warn(
            "JAX_ENABLE_X64 is set; mjx_skills runs in float32, so it is switched off here",
            stacklevel=2,
        )
        jax.config.update("jax_enable_x64", False)
