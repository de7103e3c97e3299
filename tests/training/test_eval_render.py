"""eval and render of a trained run: fresh-episode success as the trainer measures it, the
same starts on every backend, a video whose frames show the arm, one-line errors."""

import json
import os
import subprocess
import sys

import jax
import numpy as np
import pytest

from mjx_skills import evaluate as evaluation
from mjx_skills import render
from mjx_skills.config import DDPGConfig, TrainConfig
from mjx_skills.methods.ddpg_her import make_ddpg_her
from mjx_skills.training import epoch
from mjx_skills.training.metrics_log import read_metrics
from mjx_skills.training.runner import RunArgs, save_config, train_and_keep

EPISODES = 3
SEED = 5


@pytest.fixture(scope="module")
def trained(tmp_path_factory, tiny_train):
    """(run directory, final carry still in memory) of a one-epoch transit run."""
    out = tmp_path_factory.mktemp("eval_render_runs")
    return train_and_keep(RunArgs(train=TrainConfig(**tiny_train, epochs=1, out=str(out))))


def eval_rows(capsys, run_dir, *flags):
    evaluation.main([str(run_dir), *flags])
    return [json.loads(line) for line in capsys.readouterr().out.splitlines()]


def test_eval_is_the_trainers_evaluation_of_the_checkpoint(
    trained, capsys, env_factory, tiny_train
):
    run_dir, carry = trained
    row, summary = eval_rows(capsys, run_dir, "--episodes", str(EPISODES), "--seed", str(SEED))
    assert 0.0 <= row["success"] <= 1.0
    assert (row["seed"], row["epoch"], row["episodes"], row["physics"]) == (
        0,
        1,
        EPISODES,
        "native",
    )
    # The trainer's evaluation of the agent it ended with (not read back from disk), for the
    # same key: a restore, key or behaviour that differed would move the final distance.
    cfg = TrainConfig(**{**tiny_train, "eval_episodes": EPISODES})
    env = env_factory("transit")
    evaluate = epoch.make_evaluate(make_ddpg_her(env, cfg, DDPGConfig()), env, cfg)
    key = jax.random.PRNGKey(SEED)
    expected = jax.jit(jax.vmap(evaluate, in_axes=(0, None, None)))(carry.agent, None, key)
    assert row["success"] == pytest.approx(float(expected["eval_success"][0]))
    assert row["distance"] == pytest.approx(float(expected["eval_distance"][0]), rel=1e-5)
    assert row["run_eval_success"] == read_metrics(run_dir)[-1]["eval_success"]
    assert summary["seeds"] == 1 and summary["success"] == row["success"]
    other, _ = eval_rows(capsys, run_dir, "--episodes", str(EPISODES), "--seed", str(SEED + 1))
    assert other["distance"] != row["distance"], "another --seed must give other starts"


def test_eval_on_gym_starts_where_native_starts(trained, capsys):
    pytest.importorskip("gymnasium")
    run_dir, _ = trained
    flags = ("--episodes", str(EPISODES), "--seed", str(SEED))
    native, _ = eval_rows(capsys, run_dir, *flags)
    gym, _ = eval_rows(capsys, run_dir, *flags, "--physics", "gym")
    assert gym["physics"] == "gym" and gym["success"] == native["success"]
    # Same starts and the same mj_step physics: only float32 rounding between them.
    assert gym["distance"] == pytest.approx(native["distance"], abs=1e-3)


def test_eval_bad_input_is_one_line(trained, tmp_path, capsys, tiny_train):
    run_dir, _ = trained
    cases = {"not_a_run": "not a run directory", "no_checkpoint": "has no checkpoint"}
    (tmp_path / "no_checkpoint").mkdir()
    (tmp_path / "no_checkpoint" / "config.json").write_text((run_dir / "config.json").read_text())
    for name, message in cases.items():
        with pytest.raises(SystemExit) as exit_info:
            evaluation.main([str(tmp_path / name)])
        text = str(exit_info.value.code)
        assert message in text and "\n" not in text  # a message: exit status 1
    assert not (tmp_path / "no_checkpoint" / "checkpoints").exists(), "eval only reads"
    # PAS / MPAS act through skills in the JAX env: refused on gym before anything loads.
    (tmp_path / "mpas").mkdir()
    save_config(tmp_path / "mpas", RunArgs(train=TrainConfig(**tiny_train), method="mpas"))
    capsys.readouterr()
    with pytest.raises(SystemExit) as exit_info:
        evaluation.main([str(tmp_path / "mpas"), "--physics", "gym"])
    err = capsys.readouterr().err.strip()
    assert exit_info.value.code == 2 and "not supported on the gym adapter" in err
    assert len(err.splitlines()) == 1


def test_render_refuses_existing_files_and_other_formats(trained, tmp_path):
    run_dir, _ = trained
    existing = tmp_path / "video.gif"
    existing.write_bytes(b"keep me")
    for out, message in ((existing, "--overwrite"), (tmp_path / "video.avi", ".gif or an .mp4")):
        with pytest.raises(SystemExit, match=message):
            render.main([str(run_dir), "--out", str(out)])
    assert existing.read_bytes() == b"keep me"


GL_DRAWS = "import mujoco; mujoco.Renderer(mujoco.MjModel.from_xml_string('<mujoco/>'), 8, 8)"


def some_gl_backend_draws() -> bool:
    for backend in ("egl", "osmesa", "glfw"):
        env = {**os.environ, "MUJOCO_GL": backend}
        if (
            subprocess.run(
                [sys.executable, "-c", GL_DRAWS], env=env, capture_output=True
            ).returncode
            == 0
        ):
            return True
    return False


@pytest.mark.parametrize("gl", [None, "bogus"], ids=["MUJOCO_GL as set", "MUJOCO_GL=bogus"])
def test_render_writes_a_gif_of_the_episode(trained, tmp_path, env_factory, gl):
    """A MUJOCO_GL that cannot draw (bogus, or egl without EGL) stopped the command: now it
    warns and draws with a backend that works."""
    from PIL import Image, ImageSequence

    run_dir, _ = trained
    out = tmp_path / "episode.gif"
    # A fresh process: this one imported mujoco (conftest) before MUJOCO_GL could be set,
    # and MuJoCo picks its GL backend on import. Whether GL works is what render says.
    command = [
        sys.executable,
        "-m",
        "mjx_skills.render",
        str(run_dir),
        "--out",
        str(out),
        "--width",
        "64",
        "--height",
        "64",
    ]
    env = {**os.environ, "MUJOCO_GL": gl} if gl else None
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, env=env)
    if done.returncode != 0 and "no OpenGL context" in done.stderr and not some_gl_backend_draws():
        pytest.skip(done.stderr.strip())
    assert done.returncode == 0, done.stderr
    if gl:
        assert f"MUJOCO_GL={gl!r}" in done.stderr and "drawing with MUJOCO_GL=" in done.stderr
    steps = env_factory("transit").episode_length
    with Image.open(out) as gif:
        frames = [np.asarray(f.convert("RGB"), np.float32) for f in ImageSequence.Iterator(gif)]
        durations = [f.info["duration"] for f in ImageSequence.Iterator(gif)]
    # One frame per state (start + each step), 0.15 s each; identical neighbours are merged
    # into one frame of the summed duration, so the playing time counts them exactly.
    assert sum(durations) == (steps + 1) * 150 and 2 <= len(frames) <= steps + 1
    assert frames[0].shape == (64, 64, 3)
    assert all(f.std() > 10 for f in frames), "a blank frame"
    assert np.abs(frames[0] - frames[-1]).mean() > 0.5, "the arm did not move on screen"


def test_render_solved_draws_only_the_solved_episodes_and_refuses_when_none_is():
    qpos = np.arange(3 * 4 * 2, dtype=np.float32).reshape(3, 4, 2)
    grip = qpos[..., :1].repeat(3, axis=-1)
    kept_q, kept_g = render.solved_only(qpos, grip, np.array([0.0, 1.0, 1.0]))
    np.testing.assert_array_equal(kept_q, qpos[1:])
    np.testing.assert_array_equal(kept_g, grip[1:])
    with pytest.raises(ValueError, match="none of the 3 episode"):
        render.solved_only(qpos, grip, np.zeros(3))
