"""The Python API (`mjx_skills.api`): docs/usage.md's snippet runs as written on a freshly
trained run, the policy acts as the trainer evaluates, and renders mark the goal."""

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import numpy as np
import pytest

from mjx_skills.api import load
from mjx_skills.config import TrainConfig
from mjx_skills.evaluate import evaluate_jax
from mjx_skills.training.runner import RunArgs, train_run

USAGE = Path(__file__).resolve().parents[2] / "docs" / "usage.md"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, tiny_train):
    """A two-seed, one-epoch DDPG+HER run on transit."""
    out = tmp_path_factory.mktemp("api_runs")
    config = TrainConfig(**{**tiny_train, "seeds": 2}, epochs=1, out=str(out))
    return train_run(RunArgs(train=config, method="ddpg_her"))


def snippet() -> str:
    """The docs' Python API code block."""
    section = USAGE.read_text().split("## Python API", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_policy_acts_as_the_trainer_evaluates(run_dir):
    """Rolling the policy out by hand with `act` and `step` gives the success the
    trainer's evaluation program gives on the same starts (`evaluate_jax`)."""
    policy = load(run_dir, seed=1)
    key, n = jax.random.PRNGKey(3), 4
    k_reset, k_steps = jax.random.split(key)  # as rollout.run_episodes splits it
    state = policy.reset(k_reset, n)
    memory = policy.init(jax.random.fold_in(key, 1), n)
    for k in jax.random.split(k_steps, policy.env.episode_length):
        memory, action = policy.act(memory, k, state)
        assert action.shape == (n, policy.env.action_dim)
        assert float(np.abs(action).max()) <= 1.0 + 1e-6
        state = policy.step(state, action)
    success, _ = evaluate_jax(policy.run, key, n)
    by_hand = float(np.mean(state.metrics["success"]))
    assert by_hand == pytest.approx(float(success[1]), abs=1e-6)
    assert policy.success(episodes=n, key=key) == pytest.approx(float(success[1]), abs=1e-6)


def test_bad_runs_and_seeds_are_named(run_dir, tmp_path):
    with pytest.raises(ValueError, match=r"seed 2: the run trained seeds 0\.\.1"):
        load(run_dir, seed=2)
    with pytest.raises(FileNotFoundError):
        load(tmp_path)


def test_the_documented_snippet_runs_and_the_render_marks_the_goal(run_dir, tmp_path, monkeypatch):
    """The snippet, as docs/usage.md has it, in a fresh process (MuJoCo picks its GL
    backend on its first import); then the same frames drawn without the goal differ from
    them where the goal's marker is, and there the pixels are green."""
    from mjx_skills.render import choose_gl

    check = textwrap.dedent(
        """
        from mjx_skills.render import draw_frames, record_episodes
        assert frames.shape == (policy.env.episode_length + 1, 360, 480, 3), frames.shape
        qpos, grip, _, goals = record_episodes(policy.run, jax.random.PRNGKey(0), 1)
        plain = draw_frames(policy.env.model, qpos, grip, 480, 360, None)
        changed = np.any(frames != plain, axis=-1)
        assert changed.any(), "no goal drawn"
        r, g, b = frames[changed].mean(0)  # green where the table or arm was
        assert g > 1.5 * r and g > 1.5 * b, (r, g, b)
        print("ok")
        """
    )
    script = tmp_path / "snippet.py"
    script.write_text(f"import numpy as np\nRUN_DIR = {str(run_dir)!r}\n{snippet()}{check}")
    # choose_gl writes MUJOCO_GL: set here first, so that it is restored after the test.
    monkeypatch.setenv("MUJOCO_GL", os.environ.get("MUJOCO_GL", ""))
    try:
        gl = choose_gl()
    except RuntimeError as err:
        pytest.skip(f"no OpenGL backend draws here: {err}")
    env = {**os.environ, "MUJOCO_GL": gl}
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=900, env=env
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip().endswith("ok")
