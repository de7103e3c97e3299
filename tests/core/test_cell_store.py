"""The committed cell store's checksums: a stored cell records them, a flipped byte or a
missing file is refused naming it, a cell stored before checksums is used with a warning (a
cut line refused), and every committed cell matches its own."""

from __future__ import annotations

import json
import logging

import pytest

from mjx_skills.core import files
from mjx_skills.sweeps import cells
from mjx_skills.sweeps.experiments import Experiment
from tests.fakes import flip_byte


# ------------------------------------------------------------------ stored cells
@pytest.fixture
def stored_cell(tmp_path):
    """(cell, its directory in a fresh store) of a cell saved from a hand-written run."""
    exp = Experiment(
        name="tiny",
        description="test",
        tasks=("transit",),
        methods=("ddpg_her",),
        seeds=1,
        epochs=1,
        train={"envs": 2, "cycles": 2},
    )
    cell = exp.cells()[0]
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "metrics.jsonl").write_text('{"epoch": 1, "seed": 0, "eval_success": 0.5}\n')
    where = cells.save(cell, run_dir, tmp_path / "store")
    return cell, where


def test_a_stored_cell_records_and_checks_its_checksums(stored_cell):
    cell, where = stored_cell
    assert json.loads((where / cells.CHECKSUMS).read_text()).keys() == set(cells.FILES)
    assert cells.stored(cell, where.parent) == where
    assert cells.read_stored_metrics(where) == [{"epoch": 1, "seed": 0, "eval_success": 0.5}]


@pytest.mark.parametrize("name", cells.FILES)
def test_a_stored_cell_with_a_flipped_byte_is_refused_naming_the_file(stored_cell, name):
    cell, where = stored_cell
    flip_byte(where / name, offset=len((where / name).read_bytes()) - 3)
    with pytest.raises(ValueError, match=rf"{where} is damaged: {name} does not match"):
        cells.stored(cell, where.parent)
    if name == "metrics.jsonl":
        with pytest.raises(ValueError, match=rf"{where} is damaged: metrics.jsonl"):
            cells.read_stored_metrics(where)


@pytest.mark.parametrize("name", cells.FILES)
def test_a_stored_cell_missing_a_file_is_refused_naming_it(stored_cell, name):
    cell, where = stored_cell
    (where / name).unlink()
    with pytest.raises(ValueError, match=rf"{where} is damaged: {name} is missing"):
        cells.stored(cell, where.parent)


def test_a_cell_stored_before_checksums_is_used_with_a_warning(stored_cell, caplog):
    cell, where = stored_cell
    (where / cells.CHECKSUMS).unlink()
    with caplog.at_level(logging.WARNING):
        assert cells.stored(cell, where.parent) == where
    assert "used unverified" in caplog.text


@pytest.mark.parametrize("cut", [3, 1])
def test_a_cut_line_in_a_cell_stored_before_checksums_is_refused_not_trimmed(stored_cell, cut):
    """A stored cell is copied whole: its metrics cut (no newline, or half a line) is
    damage, read as such even where no checksum can show it, never as fewer rows."""
    _, where = stored_cell
    (where / cells.CHECKSUMS).unlink()
    path = where / "metrics.jsonl"
    path.write_bytes(path.read_bytes()[:-cut])
    with pytest.raises(ValueError, match=rf"stored cell {where} is damaged: .*\(line 1\) is cut"):
        cells.read_stored_metrics(where)


def test_every_committed_cell_matches_its_checksums():
    committed = sorted(d for d in cells.STORE.iterdir() if d.is_dir())
    assert committed
    for where in committed:
        assert (where / cells.CHECKSUMS).exists(), where
        cells.verify(where)
        assert files.read_jsonl(where / "metrics.jsonl")  # whole: no line dropped
