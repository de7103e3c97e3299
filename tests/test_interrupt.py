"""Ctrl-C (a real SIGINT) mid-epoch never loses a finished epoch, and a resume says where
it resumes from."""

import os
import signal
import subprocess
import sys
import time

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
    with deferred_stop() as stop:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)  # delivered at the next bytecode
        assert stop and stop.signal == signal.SIGINT
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_sweep_stops_at_the_cell_a_signal_stopped(tmp_path, monkeypatch):
    """One cell at a time: a cell that returns unfinished (its run stopped by Ctrl-C and
    saved) ends the sweep there, instead of the next cell starting to train."""
    from mjx_skills import sweep
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
    monkeypatch.setattr(sweep, "run_cell", lambda cell, *a, **k: started.append(cell.name))
    cells = exp.cells()
    with pytest.raises(SystemExit, match="cells not finished"):
        sweep.run_cells_local(
            cells, [tmp_path / c.name for c in cells], 1, False, store=tmp_path / "store"
        )
    assert started == [cells[0].name]
