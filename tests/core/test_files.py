"""Files read back robustly after a crash, and stored artifacts verified when loaded: the
JSONL reader drops exactly a half-written last line, a damaged file is refused naming it,
stored cells, skill libraries and checkpoints whose bytes changed are never used, and
TensorBoard or the progress bar failing never stops a run."""

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
from mjx_skills.sweeps import cells, local
from mjx_skills.sweeps.experiments import Experiment
from mjx_skills.training import metrics_log
from mjx_skills.training.checkpoint import Checkpoints
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


def _flip(path: Path, offset: int | None = None) -> None:
    """Invert one byte of `path` (its middle by default)."""
    data = bytearray(path.read_bytes())
    data[len(data) // 2 if offset is None else offset] ^= 0xFF
    path.write_bytes(bytes(data))


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
METRICS = {"eval_success": np.array([0.5]), "env_steps": np.array([100])}


def test_an_unwritable_tensorboard_directory_does_not_stop_the_log(tmp_path, caplog):
    (tmp_path / "tb").write_text("a file where the tb/ directory would go")
    with caplog.at_level(logging.WARNING):
        writer = MetricsWriter(tmp_path)
        writer.write(1, METRICS, wall_s=0.0)
        writer.close()
    assert [r["epoch"] for r in read_metrics(tmp_path)] == [1]
    assert "TensorBoard logging is off" in caplog.text


def test_a_summary_writer_failing_later_warns_once_and_the_log_goes_on(
    tmp_path, monkeypatch, caplog
):
    import tensorboardX

    calls = []

    class DiskFull:
        def __init__(self, *_):
            pass

        def add_scalar(self, *_):
            calls.append(1)
            raise OSError("No space left on device")

        def close(self):
            raise OSError("No space left on device")

    monkeypatch.setattr(tensorboardX, "SummaryWriter", DiskFull)
    with caplog.at_level(logging.WARNING):
        writer = MetricsWriter(tmp_path)
        for epoch in (1, 2, 3):
            writer.write(epoch, METRICS, wall_s=0.0)
        writer.close()
    assert [r["epoch"] for r in read_metrics(tmp_path)] == [1, 2, 3]
    assert len(calls) == 1 and caplog.text.count("TensorBoard logging failed") == 1

    class Refused(DiskFull):
        def __init__(self, *_):
            raise PermissionError("tb/ is read-only")

    monkeypatch.setattr(tensorboardX, "SummaryWriter", Refused)
    writer = MetricsWriter(tmp_path, resume_from_epoch=3)
    writer.write(4, METRICS, wall_s=0.0)
    writer.close()
    assert [r["epoch"] for r in read_metrics(tmp_path)] == [1, 2, 3, 4]


def test_a_failing_progress_bar_is_dropped_with_one_warning(monkeypatch, caplog):
    class Broken:
        def __init__(self, *_, **__):
            pass

        def update(self, n=1):
            raise OSError("the terminal went away")

        set_postfix = close = update

    monkeypatch.setattr(metrics_log, "tqdm", Broken)
    with caplog.at_level(logging.WARNING):
        bar = metrics_log.progress_bar(3, 0, enabled=True, desc="x")
        for _ in range(3):
            bar.set_postfix(eval_success="0.5")
            bar.update(1)
        bar.close()
    assert caplog.text.count("progress bar failed") == 1

    def refuse(*_, **__):
        raise RuntimeError("no terminal")

    monkeypatch.setattr(metrics_log, "tqdm", refuse)
    bar = metrics_log.progress_bar(3, 0, enabled=True, desc="x")
    bar.update(1)
    bar.close()


def _events(directory: Path) -> dict[str, list[tuple[int, float]]]:
    """tag -> [(step, value)] of the TFRecord event files in `directory` (tensorboardX's
    own protobuf; the record framing: length, its CRC, the data, its CRC)."""
    import struct

    from tensorboardX.proto import event_pb2

    out: dict[str, list[tuple[int, float]]] = {}
    for path in sorted(directory.glob("events.out.tfevents.*")):
        data = path.read_bytes()
        at = 0
        while at < len(data):
            (length,) = struct.unpack("<Q", data[at : at + 8])
            event = event_pb2.Event.FromString(data[at + 12 : at + 12 + length])
            at += 12 + length + 4
            for value in event.summary.value:
                out.setdefault(value.tag, []).append((event.step, value.simple_value))
    return out


def test_tensorboard_logs_each_seed_and_their_mean_under_namespaced_tags(tmp_path):
    two = {
        "eval_success": np.array([0.25, 0.75]),
        "critic_loss": np.array([1.0, 3.0]),
        "env_steps": np.array([800, 800]),
    }
    writer = MetricsWriter(tmp_path)
    writer.write(1, two, wall_s=0.0)
    writer.write(2, {**two, "env_steps": np.array([1600, 1600])}, wall_s=0.0)
    writer.close()
    seed_1, mean = _events(tmp_path / "tb" / "seed_1"), _events(tmp_path / "tb" / "mean")
    assert sorted(mean) == ["counters/env_steps", "eval/success", "loss/critic"]
    assert seed_1["eval/success"] == [(800, 0.75), (1600, 0.75)]
    assert mean["loss/critic"] == [(800, 2.0), (1600, 2.0)]
    assert _events(tmp_path / "tb" / "seed_0")["eval/success"][0] == (800, 0.25)


def test_metrics_csv_holds_the_jsonl_rows(tmp_path):
    import csv

    writer = MetricsWriter(tmp_path)
    writer.write(1, {**METRICS, "q_mean": np.array([-1.5])}, wall_s=0.5)
    writer.write(2, METRICS, wall_s=1.0)  # a metric one row lacks is empty in the table
    writer.close()
    rows = list(csv.DictReader((tmp_path / "metrics.csv").open()))
    assert list(rows[0])[:2] == ["epoch", "seed"]
    assert [(r["epoch"], r["eval_success"], r["q_mean"]) for r in rows] == [
        ("1", "0.5", "-1.5"),
        ("2", "0.5", ""),
    ]


def test_track_logs_to_weights_and_biases_or_is_refused_without_it(tmp_path, monkeypatch):
    """--track: the run's config, each metric's seed mean and each seed's value per epoch,
    env steps as the step; without wandb, ValueError naming track before anything runs."""
    import sys
    import types

    from mjx_skills.training import trackers

    calls = {"log": []}

    class FakeRun:
        def log(self, row, step):
            calls["log"].append((step, row))

        def finish(self):
            calls["finished"] = True

    def init(**kwargs):
        calls["init"] = kwargs
        return FakeRun()

    monkeypatch.setitem(sys.modules, "wandb", types.SimpleNamespace(init=init))
    run_dir = tmp_path / "transit" / "ddpg_her" / "20261203-120000"
    run_dir.mkdir(parents=True)
    writer = MetricsWriter(run_dir, track="proj", config={"method": "ddpg_her"})
    writer.write(1, {"eval_success": np.array([0.0, 1.0]), "env_steps": np.array([800, 800])})
    writer.close()
    assert calls["init"]["project"] == "proj" and calls["init"]["config"] == {"method": "ddpg_her"}
    assert calls["init"]["resume"] == "allow" and calls["finished"]
    step, row = calls["log"][0]
    assert step == 800 and row["eval/success"] == 0.5 and row["seed_1/eval/success"] == 1.0
    monkeypatch.setitem(sys.modules, "wandb", None)  # not installed
    with pytest.raises(ValueError, match="track: .*pip install wandb"):
        trackers.check_track(True)
    trackers.check_track(False)


def test_the_eta_counts_from_the_second_epoch(monkeypatch):
    """The first epoch of a process holds the compile: after `restart_clock` the bar's rate
    (and so its ETA) is that of the epochs since, not an average over the compile."""
    import io

    import tqdm

    now = [0.0]

    def clocked(**options):
        bar = tqdm.tqdm(file=io.StringIO(), mininterval=0, **options)
        bar._time = lambda: now[0]  # tqdm reads its clock through this attribute
        bar.start_t = bar.last_print_t = 0.0
        return bar

    monkeypatch.setattr(metrics_log, "tqdm", clocked)
    bar = metrics_log.progress_bar(11, 0, enabled=True, desc="x")
    now[0] = 100.0  # compile and epoch 1
    bar.update(1)
    bar.restart_clock()
    for _ in range(4):
        now[0] += 2.0
        bar.update(1)
    shown = bar._bar.format_dict
    assert shown["n"] == 5 and shown["initial"] == 1
    assert shown["rate"] == pytest.approx(0.5, rel=0.05)  # 2 s an epoch, not 108 s / 5
    assert "[00:08<00:12" in str(bar._bar)  # 6 epochs left at 2 s each
    bar.close()


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
    _flip(where / name, offset=len((where / name).read_bytes()) - 3)
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


# ------------------------------------------------------------------ checkpoints
def test_a_checkpoint_whose_contents_changed_falls_back_to_the_previous_one(tmp_path, caplog):
    """Bytes flipped in a saved array still decode, to other numbers: the digest recorded at
    save time refuses them and the epoch before is restored."""
    tree = {"w": np.arange(4096, dtype=np.float32), "n": np.arange(3, dtype=np.int32)}
    ckpt = Checkpoints(tmp_path / "checkpoints")
    ckpt.save(1, tree)
    ckpt.save(2, {**tree, "w": tree["w"] + 1})
    assert set(json.loads((tmp_path / "checkpoints" / "digests.json").read_text())) == {"1", "2"}
    data = sorted(
        (p for p in (tmp_path / "checkpoints" / "2").rglob("*") if p.is_file()),
        key=lambda p: p.stat().st_size,
    )[-1]
    _flip(data)
    with caplog.at_level(logging.WARNING):
        epoch, restored = ckpt.restore(tree)
    ckpt.close()
    assert epoch == 1 and np.array_equal(restored["w"], tree["w"])
    assert list((tmp_path / "checkpoints").glob("2.corrupt-*"))
    assert "epoch 2" in caplog.text


def test_a_checkpoint_without_a_recorded_digest_restores_with_a_warning(tmp_path, caplog):
    tree = {"w": np.arange(8, dtype=np.float32)}
    ckpt = Checkpoints(tmp_path / "checkpoints")
    ckpt.save(1, tree)
    (tmp_path / "checkpoints" / "digests.json").unlink()  # as an older run's
    with caplog.at_level(logging.WARNING):
        epoch, restored = ckpt.restore(tree)
    ckpt.close()
    assert epoch == 1 and np.array_equal(restored["w"], tree["w"])
    assert "no recorded digest" in caplog.text


def test_a_checkpoint_missing_its_arrays_falls_back_and_keeps_the_good_ones(tmp_path):
    """One damaged step must not make the manager refuse, and set aside, every good one."""
    import shutil

    import jax.numpy as jnp

    from mjx_skills.training.checkpoint import Checkpoints

    tree = {"a": jnp.arange(4.0), "b": jnp.ones(3)}
    checkpoints = Checkpoints(tmp_path / "checkpoints")
    for epoch in (1, 2, 3):
        checkpoints.save(epoch, {"a": tree["a"] + epoch, "b": tree["b"]})
    checkpoints.close()
    shutil.rmtree(tmp_path / "checkpoints" / "3" / "default")
    epoch, restored = Checkpoints(tmp_path / "checkpoints").restore(tree)
    assert epoch == 2 and float(restored["a"][0]) == 2.0
    names = {p.name for p in (tmp_path / "checkpoints").iterdir()}
    assert {"1", "2"} <= names and any(n.startswith("3.corrupt-") for n in names)


def test_every_file_of_a_checkpoint_emptied_falls_back_with_a_short_message(tmp_path, caplog):
    """A zero-byte file (a full disk, a cut copy) anywhere in the newest checkpoint: the one
    before is restored, and the warning is a line, not tensorstore's 1 kB spec."""
    import shutil

    tree = {"w": np.arange(64, dtype=np.float32), "n": np.arange(3, dtype=np.int32)}
    base = tmp_path / "base"
    ckpt = Checkpoints(base / "checkpoints")
    ckpt.save(1, tree)
    ckpt.save(2, {"w": tree["w"] + 1, "n": tree["n"]})
    ckpt.close()
    files = [p.relative_to(base) for p in (base / "checkpoints" / "2").rglob("*") if p.is_file()]
    assert len(files) >= 5
    for i, rel in enumerate(files):
        copy = tmp_path / str(i)
        shutil.copytree(base, copy)
        (copy / rel).write_bytes(b"")
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            epoch, restored = Checkpoints(copy / "checkpoints").restore(tree)
        # a file the restore does not read (a second copy) leaves epoch 2 whole
        expected = tree["w"] + (epoch == 2)
        np.testing.assert_array_equal(restored["w"], expected, err_msg=str(rel))
        assert all(len(r.getMessage()) < 500 for r in caplog.records), (rel, caplog.text)
        assert "tensorstore_spec" not in caplog.text


def test_a_checkpoint_newer_than_the_whole_log_is_not_resumed_from(tmp_path, tiny_train):
    """A crash cut epoch 3's log line after its checkpoint was saved: the resume starts from
    epoch 2's checkpoint, so epoch 3 is trained again and logged, not lost."""
    from mjx_skills.config import TrainConfig
    from mjx_skills.training.metrics_log import read_metrics
    from mjx_skills.training.runner import RunArgs, train_run

    args = RunArgs(train=TrainConfig(**tiny_train, epochs=3, checkpoint_every=1, out=str(tmp_path)))
    run_dir = train_run(args)
    path = run_dir / "metrics.jsonl"
    path.write_bytes(path.read_bytes()[:-20])  # epoch 3's line cut short
    train_run(RunArgs(resume=str(run_dir), extend_to=4))
    assert [r["epoch"] for r in read_metrics(run_dir)] == [1, 2, 3, 4]
