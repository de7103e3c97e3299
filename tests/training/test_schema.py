"""The run config's layout and its migration (`training.schema`): configs record the schema
they were written at; an older one is read as the code that wrote it ran it; a newer one is
refused."""

from __future__ import annotations

import json

import pytest

from mjx_skills.sweeps import cells
from mjx_skills.sweeps.experiments import load_experiment
from mjx_skills.training import runner, schema

FAST = {"method": "ddpg_her_sl_fast", "options": {"fast": {"pick": True}}}


def test_a_config_records_the_schema_it_was_written_at(tmp_path):
    args = load_experiment("fast").cells()[0].run_args(str(tmp_path))
    runner.save_config(tmp_path, args)
    assert json.loads((tmp_path / "config.json").read_text())["schema"] == schema.SCHEMA
    assert cells.definition(load_experiment("fast").cells()[0])["config"]["schema"] == 2


def test_an_unstamped_config_is_schema_1_and_takes_each_step():
    moved = schema.migrate(FAST)
    assert moved["schema"] == schema.SCHEMA == 2
    assert moved["options"]["fast"] == {"pick": True, "pick_in_training": True, "eval_average": 0}
    assert FAST == {"method": "ddpg_her_sl_fast", "options": {"fast": {"pick": True}}}  # a copy
    given = {**FAST, "options": {"fast": {"pick_in_training": False, "eval_average": 0.8}}}
    assert schema.migrate(given)["options"]["fast"] == given["options"]["fast"]  # as written
    other = {"method": "ddpg_her_sl", "options": {"search": {}}}
    assert schema.migrate(other) == {**other, "schema": 2}  # the step is Fast's only


def test_a_config_of_todays_schema_is_read_as_written():
    today = {**FAST, "schema": schema.SCHEMA}
    assert schema.migrate(today) == today  # no field filled in: today's defaults hold


@pytest.mark.parametrize("found", [schema.SCHEMA + 1, 0, "2", True])
def test_an_unknown_schema_is_refused(found):
    with pytest.raises(ValueError, match=rf"config schema {found!r}: this code reads 1 to 2"):
        schema.migrate({**FAST, "schema": found})
