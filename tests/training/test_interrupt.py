"""Ctrl-C (a real SIGINT) mid-epoch never loses a finished epoch, and a resume says where
it resumes from."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from mjx_skills.training.interrupt import deferred_stop
from mjx_skills.training.metrics_log import read_metrics

# Epochs of about half a second (400 updates a cycle) on transit: the signal lands mid-epoch.
ARGS = [
    "ddpg_her",
    "--task",
    "transit",
    "--epochs",
    "4",
    "--envs",
    "2",
    "--cycles",
    "2",
    "--updates-per-cycle",
    "400",
    "--eval-episodes",
    "2",
    "--replay-capacity",
    "2000",
    "--no-progress",
]


def _train(*argv: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "mjx_skills.train", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for_epochs(run_root, n: int, process: subprocess.Popen, timeout_s: float = 300):
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        runs = list(run_root.glob("transit/ddpg_her/*/metrics.jsonl"))
        if runs and len(runs[0].read_text().splitlines()) >= n:
            return runs[0].parent
        assert process.poll() is None, process.communicate()
        time.sleep(0.05)
    raise AssertionError(f"no {n} epochs logged in {timeout_s} s")


def test_sigint_mid_epoch_saves_the_epoch_and_resume_goes_on_from_it(tmp_path):
    process = _train(*ARGS, "--out", str(tmp_path))  # checkpoint_every 10: none by epoch 4
    run_dir = _wait_for_epochs(tmp_path, 2, process)
    process.send_signal(signal.SIGINT)  # during epoch 3
    _, err = process.communicate(timeout=300)
    assert process.returncode == 130, err
    logged = [r["epoch"] for r in read_metrics(run_dir)]
    saved = sorted(int(p.name) for p in (run_dir / "checkpoints").iterdir() if p.name.isdigit())
    assert logged and logged[-1] >= 2 and saved == [logged[-1]], (logged, saved, err)
    assert f"interrupted after epoch {logged[-1]} (saved)" in err
    resumed = _train("--resume", str(run_dir))
    _, err = resumed.communicate(timeout=300)
    assert resumed.returncode == 0, err
    assert f"from its checkpoint of epoch {logged[-1]} of 4" in err
    assert [r["epoch"] for r in read_metrics(run_dir)] == [1, 2, 3, 4]


def test_a_resume_without_checkpoint_says_it_starts_again(tmp_path, capsys, tiny_train):
    from mjx_skills.config import TrainConfig
    from mjx_skills.training.runner import RunArgs, new_run_dir, save_config, train_run

    args = RunArgs(train=TrainConfig(**tiny_train, epochs=1, out=str(tmp_path)))
    run_dir = new_run_dir(args)
    save_config(run_dir, args)
    train_run(RunArgs(resume=str(run_dir)))
    assert "holds no checkpoint: training it from epoch 0 of 1" in capsys.readouterr().err


def test_the_first_signal_is_deferred_and_the_second_stops_at_once():
    before = signal.getsignal(signal.SIGINT)  # SIG_IGN where the suite runs in the background
    with deferred_stop() as stop:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)  # delivered at the next bytecode
        assert stop and stop.signal == signal.SIGINT
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
    assert signal.getsignal(signal.SIGINT) is before  # the handler it found, given back


def test_a_sweep_stops_at_the_cell_a_signal_stopped(tmp_path, monkeypatch):
    """One cell at a time: a cell that returns unfinished (its run stopped by Ctrl-C and
    saved) ends the sweep there, instead of the next cell starting to train."""
    from mjx_skills.sweeps import local
    from mjx_skills.sweeps.experiments import Experiment

    exp = Experiment(
        name="two",
        description="t",
        tasks=("transit", "grasp"),
        methods=("ddpg_her",),
        seeds=1,
        epochs=1,
    )
    started = []
    run_cell = lambda cell, *a, **k: started.append(cell.name)  # returns, never finishing it
    cells = exp.cells()
    with pytest.raises(SystemExit, match="cells not finished"):
        local.run_cells_local(
            run_cell, cells, [tmp_path / c.name for c in cells], 1, False, store=tmp_path / "store"
        )
    assert started == [cells[0].name]


def test_a_second_signal_while_a_checkpoint_is_written_waits_for_it(tmp_path):
    """The checkpoint and its digest are whole before the second signal stops the run."""
    from mjx_skills.training.checkpoint import Checkpoints

    tree = {"a": np.arange(6.0)}
    checkpoints = Checkpoints(tmp_path / "checkpoints")
    with pytest.raises(KeyboardInterrupt), deferred_stop() as stop:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
        with stop.shielded():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.01)  # delivered here: held, not raised
            checkpoints.save(3, tree)
    checkpoints.close()
    epoch, restored = Checkpoints(tmp_path / "checkpoints").restore(tree)
    assert epoch == 3
    np.testing.assert_array_equal(restored["a"], tree["a"])
    assert "3" in json.loads((tmp_path / "checkpoints" / "digests.json").read_text())


def test_a_signal_while_building_a_library_stops_the_build_with_no_library(
    tmp_path, monkeypatch, capsys
):
    """A skill's training stopped by Ctrl-C (saved, unfinished) ends build_library with exit
    130: the next skills are not trained and no library is written from a half-trained one."""
    from mjx_skills import build_library

    trained = []

    def stopped_after_one_epoch(args):
        trained.append(args.train.task)
        run_dir = tmp_path / "work" / "run"
        run_dir.mkdir(parents=True)
        row = {"epoch": 1, "seed": 0, "eval_success": 0.0}
        (run_dir / "metrics.jsonl").write_text(json.dumps(row) + "\n")
        return run_dir, None

    monkeypatch.setattr(build_library, "train_and_keep", stopped_after_one_epoch)
    out = tmp_path / "lib"
    with pytest.raises(SystemExit) as stopped:
        build_library.main(["--out", str(out), "--work", str(tmp_path / "work"), "--no-progress"])
    assert stopped.value.code == 130
    assert trained == ["transit"] and not out.exists()
    assert "no library written" in capsys.readouterr().err
