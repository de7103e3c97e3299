"""Every config value is validated: NaN, infinities and out-of-range values of every numeric
field of every config class are refused with the field's name, before anything runs."""

import dataclasses
import math
import typing

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mjx_skills import train as train_command
from mjx_skills.config import (
    DDPGConfig,
    EnvConfig,
    LibraryConfig,
    PASConfig,
    SearchConfig,
    TrainConfig,
)

CLASSES = (DDPGConfig, EnvConfig, TrainConfig, LibraryConfig, SearchConfig, PASConfig)
AT_MOST_ONE = {
    DDPGConfig: ("gamma", "tau", "random_eps", "relabel_prob"),
    EnvConfig: ("held_start_prob", "goal_start_prob"),
    LibraryConfig: ("grasp_held_start_prob", "own_start_share", "holdout"),
    SearchConfig: ("prune_below", "gamma", "waypoint_share", "search_chunk", "eps_start"),
    PASConfig: ("relabel_prob",),
}
"""Probabilities, shares and discounts: a value above 1 is out of range."""


def numeric_fields(cls) -> list[tuple[str, type, bool]]:
    """(name, number type, is a tuple) of every numeric field of `cls`."""
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        kind, is_tuple = hints[f.name], False
        if typing.get_origin(kind) is tuple:
            kind, is_tuple = typing.get_args(kind)[0], True
        if kind in (int, float):
            out.append((f.name, kind, is_tuple))
    return out


FIELDS = [(cls, *f) for cls in CLASSES for f in numeric_fields(cls)]


def test_every_config_class_has_numeric_fields_under_test():
    assert {cls for cls, *_ in FIELDS} == set(CLASSES)
    assert len(FIELDS) >= 60


def _invalid(kind: type) -> st.SearchStrategy:
    if kind is int:
        return st.integers(max_value=-1)
    return st.sampled_from([math.nan, math.inf, -math.inf]) | st.floats(
        max_value=-1e-9, allow_infinity=False, allow_nan=False
    )


@pytest.mark.parametrize(
    ("cls", "name", "kind", "is_tuple"), FIELDS, ids=[f"{c.__name__}.{n}" for c, n, *_ in FIELDS]
)
@settings(max_examples=12, deadline=None)
@given(data=st.data())
def test_nan_inf_and_negative_values_are_refused_naming_the_field(cls, name, kind, is_tuple, data):
    bad = data.draw(_invalid(kind))
    if is_tuple:
        default = getattr(cls(), name)
        value = (*default[:-1], bad) if default else (bad,)
    else:
        value = bad
    with pytest.raises(ValueError, match=f"'{name}'"):
        cls(**{name: value})


@pytest.mark.parametrize(
    ("cls", "name"), [(c, n) for c, names in AT_MOST_ONE.items() for n in names]
)
@settings(max_examples=8, deadline=None)
@given(value=st.floats(min_value=1.0 + 1e-6, max_value=1e12))
def test_probabilities_and_discounts_above_one_are_refused(cls, name, value):
    with pytest.raises(ValueError, match=f"'{name}'"):
        cls(**{name: value})


@pytest.mark.parametrize("value", ["nan", "0", "-1", "inf"])
def test_a_bad_norm_eps_on_the_command_line_stops_before_any_run_directory(value, tmp_path, capsys):
    """`--ddpg.norm-eps nan` (or 0, -1) made every normalised input NaN on real data."""
    with pytest.raises(SystemExit):
        train_command.main(
            ["ddpg_her", "--task", "transit", "--ddpg.norm-eps", value, "--out", str(tmp_path)]
        )
    assert "invalid config value for 'norm_eps'" in " ".join(capsys.readouterr().err.split())
    assert not any(tmp_path.iterdir())
