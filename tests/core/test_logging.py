"""A run's logs: TensorBoard per seed and their mean under namespaced tags, metrics.csv
beside the JSONL, Weights & Biases behind --track, the ETA from the second epoch; a failing
writer or progress bar never stops the run."""

from __future__ import annotations

import logging
import types
from pathlib import Path

import numpy as np
import pytest

from mjx_skills.training import metrics_log
from mjx_skills.training.metrics_log import MetricsWriter, read_metrics

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
