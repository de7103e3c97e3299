"""Shared fixtures. Envs are built once per session: their compiled programs are shared."""

import functools

import pytest

from mjx_skills.core import compile_cache
from mjx_skills.envs import make
from tests import fakes

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
    return fakes.tiny_train()
