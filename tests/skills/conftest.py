"""Shared by the search's tests (test_search, test_search_tree, test_stalls)."""

import pytest

from mjx_skills.skills.library import skill_envs


@pytest.fixture(scope="module")
def env():
    """The transfer skill's env: the scene the hand-built library's states live in."""
    return skill_envs(("transfer",))[0]
