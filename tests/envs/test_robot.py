"""The robot contract (envs/robot.py): every registered robot implements it, a task declares
its robot, unknown names list the valid ones, and a skill library serves only its robot."""

from __future__ import annotations

import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_skills import methods
from mjx_skills.config import DDPGConfig, LibraryConfig, SearchConfig, TrainConfig
from mjx_skills.envs import ENVS, ROBOTS, make, robot_of, tasks_of
from mjx_skills.envs.registry import check_robot
from mjx_skills.envs.robot import Robot
from mjx_skills.skills import library
from mjx_skills.skills.registry import SKILLS, robots_with_skills
from mjx_skills.training.runner import RunArgs, train_run

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = [ROOT / "experiments" / "skill_library", ROOT / "experiments" / "skill_library_thesis"]
SAMPLE_TASK = {"baxter": "pick_move", "fetch": "fetch_pick_and_place"}
"""A task of each robot whose scene has an object (one make per robot: each builds a model)."""


def test_every_robot_has_a_sample_task_and_every_task_a_robot():
    assert set(SAMPLE_TASK) == set(ROBOTS)
    assert {robot_of(task) for task in ENVS} == set(ROBOTS)
    assert sorted(t for r in ROBOTS for t in tasks_of(r)) == sorted(ENVS)
    assert all(robot_of(skill) in robots_with_skills() for skill in SKILLS)


@pytest.fixture(scope="module", params=sorted(SAMPLE_TASK))
def task(request):
    return make(SAMPLE_TASK[request.param])


def test_the_robot_implements_the_contract(task):
    robot = task.robot
    assert isinstance(robot, Robot)
    assert type(robot) is ROBOTS[task.robot_name] and robot.name == task.robot_name
    assert robot.model is task.model and robot.backend is task.backend
    assert robot.action_dim == task.action_dim == 4
    assert robot.layout.size == robot.obs_dim
    assert np.all(np.asarray(robot.workspace_low) < np.asarray(robot.workspace_high))


def _start(task):
    """The contract's start state with the object where a reset of `task` puts it."""
    robot = task.robot
    obs = task.reset(jax.random.PRNGKey(3)).obs
    return robot.start(obs[robot.layout["object"]]), obs


def test_the_layout_slices_the_observation(task):
    robot = task.robot
    physics, reset_obs = _start(task)
    obs = robot.observe(physics)
    assert obs.shape == (robot.obs_dim,) == reset_obs.shape[-1:]
    for part in ("grip", "object", "rel", "fingers"):
        start, stop = getattr(robot.layout, part)
        assert 0 <= start <= stop <= robot.layout.size
    grip = robot.sensors(physics.sensordata)["grip_pos"]
    np.testing.assert_array_equal(obs[robot.layout["grip"]], grip)
    rel = obs[robot.layout["object"]] - obs[robot.layout["grip"]]
    np.testing.assert_allclose(obs[robot.layout["rel"]], rel, atol=1e-6)
    # The object starts where it was asked to (xy; its height is the robot's).
    np.testing.assert_allclose(
        obs[robot.layout["object"]][:2], reset_obs[robot.layout["object"]][:2], atol=2e-3
    )
    assert not bool(robot.grasped(obs))


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_the_controller_moves_the_grip_toward_the_commanded_displacement(task, axis):
    """One env step of action e_axis (gripper open) moves the grip point along that axis by
    a good share of `action_scale`, little across it, and keeps it in the workspace."""
    robot = task.robot
    physics, _ = _start(task)
    grip = robot.sensors(physics.sensordata)["grip_pos"]
    action = jnp.zeros(4).at[axis].set(1.0).at[3].set(1.0)
    moved = robot.step(physics, robot.controls(physics, action))
    delta = np.asarray(robot.sensors(moved.sensordata)["grip_pos"] - grip)
    across = np.delete(delta, axis)
    assert delta[axis] > 0.5 * robot.action_scale, delta
    assert np.linalg.norm(across) < 0.5 * delta[axis], delta
    new = np.asarray(grip) + delta
    assert np.all(new >= np.asarray(robot.workspace_low) - 1e-3), new
    assert np.all(new <= np.asarray(robot.workspace_high) + 1e-3), new


def test_fetch_starts_only_where_its_setup_leaves_the_grip():
    robot = make("fetch_reach").robot
    with pytest.raises(ValueError, match="grip=None"):
        robot.start(None, grip=jnp.zeros(3))


def test_unknown_robot_or_task_lists_the_valid_ones():
    with pytest.raises(ValueError, match="unknown robot 'ur5'; valid: baxter, fetch"):
        tasks_of("ur5")
    with pytest.raises(ValueError, match="unknown robot 'ur5'; valid: baxter, fetch"):
        check_robot("ur5")
    for ask in (robot_of, make):
        with pytest.raises(ValueError, match="unknown task 'stack'; valid: transit, grasp"):
            ask("stack")
    with pytest.raises(ValueError, match="fetch_pick_and_place"):
        methods.check_task("ddpg_her_sl", "stack")


def test_a_library_method_on_a_fetch_task_is_refused_before_any_run_directory(tmp_path):
    out = tmp_path / "runs"
    for method in ("ddpg_her_sl", "pas"):
        args = RunArgs(method=method, train=TrainConfig(task="fetch_push", out=str(out)))
        with pytest.raises(ValueError) as refused:
            train_run(args)
        said = str(refused.value)
        assert "library is built for the Baxter robot (experiments/skill_library)" in said
        assert "fetch_push is a Fetch task" in said
        assert f"pass --{method[:3] if method == 'pas' else 'search'}.library SL1_fetch" in said
        assert "experiments/skill_library_fetch" in said and "--robot fetch" in said
    assert not out.exists()
    methods.check_task("ddpg_her", "fetch_push")  # the flat methods run it


def _fake_library(directory: Path, robot: str) -> Path:
    """A manifest only: what the robot check reads (the arrays would fail later, at load)."""
    directory.mkdir()
    (directory / "manifest.json").write_text(json.dumps({"robot": robot}))
    return directory


def test_a_baxter_task_with_another_robots_library_is_refused_with_the_build_command(tmp_path):
    lib = _fake_library(tmp_path / "fetch_lib", "fetch")
    out = tmp_path / "runs"
    options = {"search": SearchConfig(library_dir=str(lib))}
    args = RunArgs(
        method="ddpg_her_sl", train=TrainConfig(task="pick_move", out=str(out)), options=options
    )
    with pytest.raises(ValueError) as refused:
        train_run(args)
    said = str(refused.value)
    assert f"built for the Fetch robot ({lib})" in said and "pick_move is a Baxter task" in said
    assert "pass --search.library SL1 or SL2 or SL3 (the Baxter skills)" in said
    assert "--search.library-dir experiments/skill_library, which `python -m" in said
    assert not out.exists()


def test_a_library_named_for_another_robot_is_refused(tmp_path):
    """The Fetch library at --search.library-dir but the Baxter skills named (SL1)."""
    lib = _fake_library(tmp_path / "fetch_lib", "fetch")
    said = "SL1 names Baxter skills; fetch_pick_and_place is a Fetch task: pass --search.library"
    with pytest.raises(ValueError, match=said + " SL1_fetch"):
        methods.check_library_robot(
            "ddpg_her_sl", "fetch_pick_and_place", {"search": SearchConfig(library_dir=str(lib))}
        )


def test_the_build_command_named_takes_out(tmp_path):
    """The command the refusal names parses as written (it stops at the existing --out)."""
    from mjx_skills import build_library

    with pytest.raises(SystemExit, match="exists; a library is never overwritten"):
        build_library.main(["--out", str(tmp_path)])


@pytest.mark.parametrize("directory", COMMITTED, ids=lambda p: p.name)
def test_a_committed_manifest_without_robot_loads_as_baxter(directory):
    raw = json.loads((directory / "manifest.json").read_text())
    assert "robot" not in raw  # written before robots were recorded, and never rewritten
    assert library.library_robot(library.read_manifest(directory)) == "baxter"
    options = {"search": SearchConfig(library_dir=str(directory))}
    methods.check_task("ddpg_her_sl", "pick_move", options)


def test_a_saved_library_records_its_robot(tmp_path):
    lib = library.empty_like(tuple(SKILLS), DDPGConfig(), LibraryConfig(), memory_size=2)
    path = library.save(lib, tmp_path / "lib", {"memory_size": 2})
    assert library.read_manifest(path)["robot"] == "baxter"
    assert library.library_robot({}) == "baxter"
