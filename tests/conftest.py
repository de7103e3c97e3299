"""Shared fixtures. Envs are built once per session: their compiled programs are shared."""

import functools

import pytest

from mjx_skills.core import compile_cache
from mjx_skills.envs import make

# Compiled programs persist across test sessions (and are shared with the CLI's runs).
compile_cache.enable()


@functools.cache
def cached_env(name: str, physics: str = "native"):
    return make(name, physics=physics)


@pytest.fixture(scope="session")
def env_factory():
    return cached_env


@pytest.fixture(scope="session")
def tiny_train() -> dict:
    """TrainConfig fields of a tiny run (every code path of an epoch, compiled in seconds;
    test_train's budget, so the compiled epoch is shared)."""
    return dict(
        task="transit",
        envs=2,
        cycles=2,
        updates_per_cycle=5,
        eval_episodes=2,
        replay_capacity=2000,
        progress=False,
    )
