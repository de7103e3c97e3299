"""A sweep takes a run directory for its cell only if the run started with the same skill
library, down to the source of a user library's skills (`runner.LIBRARY`): a run made
before a skill's code changed is never saved as the cell's result under the new code."""

from __future__ import annotations

import dataclasses
import json

import pytest

from mjx_skills.skills import registry
from mjx_skills.sweeps import cells
from mjx_skills.sweeps.cell import Cell
from mjx_skills.training.runner import LIBRARY

WHERE = (("library", "SL1_fetch"), ("library_dir", str(registry.default_dir("fetch"))))
CELL = Cell(
    task="fetch_pick_and_place",
    method="ddpg_her_sl",
    library="SL1_fetch",
    seeds=1,
    epochs=2,
    options=(("search", WHERE),),
)


@pytest.fixture
def run_dir(tmp_path):
    """A run directory as the runner starts it for CELL: config.json and library.json."""
    definition = cells.definition(CELL)
    (tmp_path / "config.json").write_text(json.dumps(definition["config"]))
    (tmp_path / LIBRARY).write_text(json.dumps(definition["library"]))
    return tmp_path


def test_a_run_is_taken_only_with_the_library_it_started_with(run_dir, monkeypatch):
    assert cells.run_differences(run_dir, CELL) == []
    recorded = json.loads((run_dir / LIBRARY).read_text())
    assert set(recorded["skills"]) == set(registry.library_skills("SL1_fetch"))
    # the grasp skill's env edited since the run started
    other = dataclasses.replace(registry.SKILLS["fetch_grasp"], env=dataclasses.Field)
    monkeypatch.setitem(registry.SKILLS, "fetch_grasp", other)
    (diff,) = cells.run_differences(run_dir, CELL)
    assert diff.startswith("library.skills.fetch_grasp.env:")


def test_a_run_that_recorded_no_library_is_not_taken(run_dir):
    (run_dir / LIBRARY).unlink()
    (diff,) = cells.run_differences(run_dir, CELL)
    assert diff.startswith("library: not recorded by the run")


def test_a_run_without_a_library_records_none(run_dir):
    plain = dataclasses.replace(CELL, method="ddpg_her", library=None, options=())
    (run_dir / "config.json").write_text(json.dumps(cells.definition(plain)["config"]))
    (run_dir / LIBRARY).unlink()
    assert cells.definition(plain)["library"] is None
    assert cells.run_differences(run_dir, plain) == []


def test_a_stored_cell_keeps_the_library_its_run_started_with(run_dir, tmp_path, monkeypatch):
    """A skill's code changed while the run trained: the cell is stored with the library the
    run recorded, so the new code refuses it instead of taking it for its own."""
    (run_dir / "metrics.jsonl").write_text("")
    started = json.loads((run_dir / LIBRARY).read_text())
    other = dataclasses.replace(registry.SKILLS["fetch_grasp"], env=dataclasses.Field)
    monkeypatch.setitem(registry.SKILLS, "fetch_grasp", other)  # edited after the start
    where = cells.save(CELL, run_dir, tmp_path / "store")
    assert json.loads((where / "definition.json").read_text())["library"] == started
    with pytest.raises(ValueError, match=r"another definition \(library\.skills\.fetch_grasp"):
        cells.stored(CELL, tmp_path / "store")
