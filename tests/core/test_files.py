"""Files read back robustly after a crash: the JSONL reader drops exactly a half-written last
line, a damaged file is refused naming it, an atomic write leaves the old file when it
fails. Stored cells: test_cell_store.py; checkpoints: test_checkpoint_damage.py; the logs:
test_logging.py."""

from __future__ import annotations

import json
import logging
import types
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mjx_skills.core import files
from mjx_skills.sweeps import local
from mjx_skills.training.metrics_log import MetricsWriter, read_metrics
from mjx_skills.training.runner import load_config, summary

ROWS = st.lists(
    st.fixed_dictionaries(
        {
            "epoch": st.integers(1, 10**6),
            "seed": st.integers(0, 9),
            "eval_success": st.floats(allow_nan=False),
            "note": st.text(max_size=8),
        }
    ),
    min_size=1,
    max_size=6,
)


def _jsonl(rows: list[dict], ascii_only: bool) -> bytes:
    return "".join(json.dumps(r, ensure_ascii=ascii_only) + "\n" for r in rows).encode()


# ------------------------------------------------------------------------------ JSONL
@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(rows=ROWS, ascii_only=st.booleans())
def test_every_truncation_reads_back_as_its_complete_lines(tmp_path, rows, ascii_only):
    """A crash can cut an append anywhere (inside a UTF-8 character too): the reader returns
    the lines written whole and never raises."""
    data = _jsonl(rows, ascii_only)
    path = tmp_path / "metrics.jsonl"
    for cut in range(len(data) + 1):
        path.write_bytes(data[:cut])
        assert files.read_jsonl(path) == rows[: data[:cut].count(b"\n")]


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(rows=ROWS.filter(lambda r: len(r) >= 2), data=st.data())
def test_damage_before_the_last_line_raises_naming_file_and_line(tmp_path, rows, data):
    line = data.draw(st.integers(0, len(rows) - 2))
    lines = _jsonl(rows, True).decode().splitlines()
    lines[line] = lines[line][: len(lines[line]) // 2]  # a cut line inside the file
    path = tmp_path / "metrics.jsonl"
    path.write_text("".join(x + "\n" for x in lines))
    with pytest.raises(ValueError, match=rf"{path}.* line {line + 1}\b"):
        files.read_jsonl(path)


def test_a_half_written_last_line_is_dropped_with_a_warning(tmp_path, caplog):
    path = tmp_path / "metrics.jsonl"
    path.write_text('{"epoch": 1, "seed": 0}\n{"epoch": 2, "seed": 0, "eval_succ')
    with caplog.at_level(logging.WARNING):
        assert files.read_jsonl(path) == [{"epoch": 1, "seed": 0}]
    assert str(path) in caplog.text and "line 2 is half written" in caplog.text
    path.write_text('{"epoch": 1}\n\x00\x00\x00\n')  # a tail of zeros a power loss can leave
    assert files.read_jsonl(path) == [{"epoch": 1}]


def test_a_damaged_json_file_is_named(tmp_path):
    path = tmp_path / "config.json"
    files.write_json_atomic(path, {"method": "ddpg_her", "train": {"epochs": 3}}, indent=2)
    assert files.read_json(path)["train"]["epochs"] == 3
    path.write_text(path.read_text()[:25])
    with pytest.raises(ValueError, match=rf"{path} is damaged or half written"):
        files.read_json(path)


def test_an_atomic_write_leaves_the_old_file_when_it_fails(tmp_path, monkeypatch):
    path = tmp_path / "results.csv"
    files.write_text_atomic(path, "old\n")

    def fail(*_):
        raise OSError("disk full")

    monkeypatch.setattr(files.os, "replace", fail)
    with pytest.raises(OSError, match="disk full"):
        files.write_text_atomic(path, "new\n")
    assert path.read_text() == "old\n" and [p.name for p in tmp_path.iterdir()] == [path.name]


def test_tree_digest_sees_contents_shapes_and_dtypes():
    tree = {"a": np.arange(6, dtype=np.float32), "b": np.zeros(2, bool)}
    same = {"a": np.arange(6, dtype=np.float32), "b": np.zeros(2, bool)}
    assert files.tree_sha256(tree) == files.tree_sha256(same)
    for other in (
        {**tree, "a": tree["a"].reshape(2, 3)},
        {**tree, "a": tree["a"].astype(np.int32)},
        {**tree, "b": np.ones(2, bool)},
    ):
        assert files.tree_sha256(other) != files.tree_sha256(tree)


# ---------------------------------------------------------------- the run's own files
def _half_written_run(tmp_path: Path) -> Path:
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    rows = [
        {"epoch": e, "seed": s, "eval_success": 0.5, "wall_s": 1.0 * e}
        for e in (1, 2)
        for s in (0, 1)
    ]
    (run_dir / "metrics.jsonl").write_text(
        "".join(json.dumps(r) + "\n" for r in rows) + '{"epoch": 3, "seed": 0, "eval_succ'
    )
    return run_dir


def test_readers_of_a_run_take_its_half_written_log(tmp_path):
    """What `train --resume`, the sweep, evaluate and the summary read: the whole lines."""
    run_dir = _half_written_run(tmp_path)
    assert [r["epoch"] for r in read_metrics(run_dir)] == [1, 1, 2, 2]
    assert "epoch 2, eval success 0.50" in summary(run_dir)
    cell = types.SimpleNamespace(samples=0, epochs=2, seeds=2)
    assert local.finished(run_dir, cell)
    assert not local.finished(run_dir, types.SimpleNamespace(samples=0, epochs=3, seeds=2))


def test_resuming_drops_the_half_line_and_appends_whole_ones(tmp_path):
    run_dir = _half_written_run(tmp_path)
    writer = MetricsWriter(run_dir, resume_from_epoch=2)
    writer.write(3, {"eval_success": np.array([0.75, 1.0]), "env_steps": np.array([9, 9])})
    writer.close()
    text = (run_dir / "metrics.jsonl").read_text()
    assert text.endswith("\n") and "eval_succ\n" not in text
    assert [(r["epoch"], r["seed"]) for r in map(json.loads, text.splitlines())] == [
        (1, 0),
        (1, 1),
        (2, 0),
        (2, 1),
        (3, 0),
        (3, 1),
    ]


def test_a_truncated_config_json_is_an_error_naming_it(tmp_path):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "config.json").write_text('{"method": "ddpg_her", "train": {"ta')
    with pytest.raises(ValueError, match=rf"{run_dir / 'config.json'} is damaged"):
        load_config(run_dir)


# --------------------------------------------------------------- optional machinery
