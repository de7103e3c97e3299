"""The interval estimates need rliable and arch, which only the dev extra installs: without
them `mjx_skills.analysis.stats` names the extra instead of failing deep in an import."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from mjx_skills.analysis import stats


@pytest.mark.parametrize(
    ("missing", "call"),
    [
        (("rliable", "rliable.metrics"), lambda: stats.iqm_interval(np.arange(4.0))),
        (("rliable", "rliable.library"), lambda: stats.interval(np.ones((3, 2)))),
        (("arch", "arch.bootstrap"), lambda: stats.reach_interval(np.ones((3, 10)))),
    ],
)
def test_a_missing_extra_is_named(monkeypatch, missing, call):
    for name in missing:
        monkeypatch.setitem(sys.modules, name, None)  # as if not installed
    with pytest.raises(ModuleNotFoundError, match=r"the dev extra installs \(pip install -e"):
        call()


def test_with_the_extra_the_estimates_run():
    point, low, high = stats.iqm_interval(np.array([0.0, 0.5, 0.5, 1.0]))
    assert point == 0.5 and low <= point <= high
