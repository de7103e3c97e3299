"""Tasks registered from the user's own module (`register_task`, `--import`): found by the
commands and by a sweep's worker processes; bad registrations and missing modules named."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mjx_skills.core import plugins
from mjx_skills.envs import registry

ROOT = Path(__file__).resolve().parents[2]
LIFT = ROOT / "examples" / "lift_task" / "lift.py"
TINY = ["--envs", "2", "--cycles", "1", "--updates-per-cycle", "2", "--eval-episodes", "2"]


def run(argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != plugins.ENV}
    command = [sys.executable, "-m", *argv]
    return subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=900)


def test_bad_registrations_are_named(monkeypatch):
    monkeypatch.setattr(registry, "ENVS", dict(registry.ENVS))
    base = registry.ENVS["pick_move"]
    with pytest.raises(ValueError, match="'pick_move' is registered already"):
        registry.register_task("pick_move", base)
    with pytest.raises(ValueError, match="identifier"):
        registry.register_task("my task", base)
    with pytest.raises(ValueError, match="unknown robot 'ur5'; valid: baxter, fetch"):
        registry.register_task("mine", type("Mine", (), {"robot_name": "ur5"}))
    registry.register_task("mine", base)
    assert registry.make("mine").episode_length == base.default_episode_length
    monkeypatch.setattr(registry, "ROBOTS", dict(registry.ROBOTS))
    with pytest.raises(ValueError, match="'baxter' is registered already"):
        registry.register_robot(registry.ROBOTS["baxter"])


def test_import_flags_are_taken_and_a_missing_module_is_named(monkeypatch, tmp_path):
    monkeypatch.setenv(plugins.ENV, "")  # restored after: take_imports writes it
    monkeypatch.chdir(tmp_path)
    rest = plugins.take_imports(["--task", "x", "--import=json", "--import", "csv", "-v"])
    assert rest == ["--task", "x", "-v"] and plugins.named() == ["json", "csv"]
    with pytest.raises(SystemExit, match="--import no_such_mod: no module 'no_such_mod'"):
        plugins.take_imports(["--import", "no_such_mod"])
    monkeypatch.setenv(plugins.ENV, "")
    with pytest.raises(SystemExit, match="no such file"):
        plugins.take_imports(["--import", "missing.py"])


def test_a_users_task_trains_from_the_command_line(tmp_path):
    """`train --import examples/lift_task/lift.py --task lift` from another directory; the
    same command without --import names the valid tasks."""
    out = tmp_path / "runs"
    argv = ["mjx_skills.train", "ddpg_her", "--task", "lift", "--epochs", "1", *TINY]
    argv += ["--replay-capacity", "500", "--out", str(out), "--no-progress"]
    done = run([*argv, "--import", str(LIFT)], tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    (config,) = out.glob("lift/ddpg_her/*/config.json")
    assert json.loads(config.read_text())["train"]["task"] == "lift"
    refused = run(argv, tmp_path)
    assert refused.returncode != 0 and "unknown task 'lift'; valid: transit" in refused.stderr


def test_a_sweeps_worker_processes_see_the_users_task(tmp_path):
    """Two cells at once, each in a spawned worker: the workers import the module too."""
    argv = ["mjx_skills.sweep", "--import", str(LIFT), "--tasks", "lift", "transit"]
    argv += ["--methods", "ddpg_her", "--seeds", "1", "--epochs", "1", "--jobs", "2"]
    argv += ["--results", str(tmp_path / "results"), "--store", str(tmp_path / "store")]
    done = run([*argv, "--no-progress"], tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    rows = (tmp_path / "results" / "adhoc.csv").read_text().splitlines()
    assert sorted(r.split(",")[1] for r in rows[1:]) == ["lift", "transit"]


def test_modules_of_one_name_in_two_folders_both_load_and_the_variable_is_named(
    tmp_path, monkeypatch
):
    """Two task.py files register two tasks; `~` is expanded; MJX_SKILLS_IMPORT's entries
    are stripped, and a missing one is named as coming from the variable."""
    monkeypatch.setattr(registry, "ENVS", dict(registry.ENVS))
    monkeypatch.setenv(plugins.ENV, "")
    monkeypatch.setenv("HOME", str(tmp_path))
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "task.py").write_text(
            "from mjx_skills.envs.registry import ENVS, register_task\n"
            f"register_task('task_{folder}', ENVS['pick_move'])\n"
        )
    plugins.take_imports(["--import", "~/a/task.py", f"--import={tmp_path / 'b' / 'task.py'}"])
    assert {"task_a", "task_b"} <= set(registry.ENVS)
    monkeypatch.setenv(plugins.ENV, f" {tmp_path / 'a' / 'task.py'} , nowhere_mod ")
    assert plugins.named() == [str(tmp_path / "a" / "task.py"), "nowhere_mod"]
    with pytest.raises(SystemExit, match="MJX_SKILLS_IMPORT: nowhere_mod: no module"):
        plugins.take_imports([])


def test_an_installed_packages_entry_point_registers_its_task(tmp_path, monkeypatch):
    """A package that declares `[project.entry-points."mjx_skills.plugins"]` is loaded by
    every command with no --import; one that fails to load is named."""
    (tmp_path / "my_lift.py").write_text(
        f"import runpy\nrunpy.run_path({str(LIFT)!r})\n"  # registers the lift task
    )
    (tmp_path / "broken_plugin.py").write_text("raise RuntimeError('no scene here')\n")
    info = tmp_path / "my_plugin-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-plugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[{plugins.GROUP}]\nlift = my_lift\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "ENVS", dict(registry.ENVS))
    monkeypatch.setattr(plugins, "_LOADED_ENTRY_POINTS", set())
    monkeypatch.setenv(plugins.ENV, "")
    assert "lift" not in registry.ENVS
    plugins.take_imports([])
    assert "lift" in registry.ENVS
    (tmp_path / "late_lift.py").write_text(
        "from mjx_skills.envs.registry import ENVS, register_task\n"
        "def register():\n    register_task('late_lift', ENVS['lift'])\n"
    )
    (info / "entry_points.txt").write_text(f"[{plugins.GROUP}]\nlate = late_lift:register\n")
    plugins.take_imports([])
    assert "late_lift" in registry.ENVS  # a function named by the entry point is called
    (info / "entry_points.txt").write_text(f"[{plugins.GROUP}]\nbroken = broken_plugin\n")
    with pytest.raises(SystemExit, match="entry point broken = 'broken_plugin' .* no scene here"):
        plugins.take_imports([])
