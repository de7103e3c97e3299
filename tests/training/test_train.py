"""The jitted epoch: traced once, deterministic, seeds independent, resumable, learning."""

import dataclasses
import json
from pathlib import Path

import jax
import numpy as np
import pytest

from mjx_skills.config import DDPGConfig, EnvConfig, TrainConfig
from mjx_skills.methods.ddpg_her import make_ddpg_her
from mjx_skills.training import epoch as train_mod
from mjx_skills.training.metrics_log import read_metrics
from mjx_skills.training.runner import RunArgs, check_finite, load_config, train_run
from tests.fakes import tiny_train

TINY = tiny_train()  # every code path of an epoch, compiled in seconds


def tiny_args(tmp_path, **overrides):
    return RunArgs(train=TrainConfig(**{**TINY, "out": str(tmp_path), **overrides}))


@pytest.fixture(scope="module")
def tiny_program(env_factory):
    """(epoch function traced with a counter, initial carry for 2 seeds)."""
    cfg = TrainConfig(**{**TINY, "seeds": 2})
    env = env_factory("transit")
    traces = []
    learner = make_ddpg_her(env, cfg, DDPGConfig())
    epoch = train_mod.make_train_epoch(learner, env, cfg)

    def counted(carry):
        traces.append(1)
        return epoch(carry, None)

    fn = jax.jit(jax.vmap(counted))
    init = jax.jit(jax.vmap(lambda k: train_mod.init_carry(learner, env, cfg, k)))
    return fn, init(train_mod.seed_keys(cfg)), traces


def _run(fn, carry, n):
    history = []
    for _ in range(n):
        carry, metrics = fn(carry)
        history.append(jax.tree.map(np.asarray, metrics))
    return carry, history


def test_epoch_is_traced_once_and_is_deterministic(tiny_program):
    fn, carry0, traces = tiny_program
    _, first = _run(fn, carry0, 3)
    _, second = _run(fn, carry0, 3)
    assert len(traces) == 1
    for a, b in zip(first, second, strict=True):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name])  # bitwise on the CPU


def test_seeds_differ(tiny_program):
    fn, carry0, _ = tiny_program
    _, history = _run(fn, carry0, 1)
    assert history[0]["critic_loss"][0] != history[0]["critic_loss"][1]


def test_runs_differing_only_in_budget_and_seed_share_one_compiled_epoch(tmp_path):
    """A sweep's cells that differ in epochs, first seed or output compile once per process;
    another number of seeds (another shape) is another program."""
    cfg = TrainConfig(**TINY)
    _, _, fn_a, carry_a = train_mod.build("ddpg_her", cfg, EnvConfig())
    other = dataclasses.replace(cfg, epochs=7, seed=3, out=str(tmp_path), checkpoint_every=2)
    _, _, fn_b, carry_b = train_mod.build("ddpg_her", other, EnvConfig())
    assert fn_b is fn_a
    assert not np.array_equal(carry_a.key, carry_b.key)  # its own seeds
    for carry in (carry_a, carry_b):
        jax.block_until_ready(fn_a(carry, None))
    assert fn_a._cache_size() == 1
    _, _, fn_c, _ = train_mod.build("ddpg_her", dataclasses.replace(cfg, seeds=2), EnvConfig())
    assert fn_c is not fn_a


def _rows(run_dir):
    return [{k: v for k, v in row.items() if k != "wall_s"} for row in read_metrics(run_dir)]


def test_resume_equals_uninterrupted_run(tmp_path):
    straight = train_run(tiny_args(tmp_path / "a", epochs=4, checkpoint_every=1))
    pieces = train_run(tiny_args(tmp_path / "b", epochs=4, checkpoint_every=3), stop_after=2)
    assert [r["epoch"] for r in read_metrics(pieces)] == [1, 2]
    resumed = train_run(RunArgs(resume=str(pieces)))
    assert resumed == pieces
    assert _rows(straight) == _rows(pieces)


def test_an_extended_run_equals_one_started_with_the_longer_budget(tmp_path):
    straight = train_run(tiny_args(tmp_path / "a", epochs=3))
    short = train_run(tiny_args(tmp_path / "b", epochs=2))
    with pytest.raises(ValueError, match="epochs: cannot shorten"):
        train_run(RunArgs(resume=str(short), extend_to=1))
    assert [r["epoch"] for r in read_metrics(short)] == [1, 2]
    assert train_run(RunArgs(resume=str(short), extend_to=3)) == short
    assert json.loads((short / "config.json").read_text())["train"]["epochs"] == 3
    assert _rows(straight) == _rows(short)


def test_a_new_run_never_reuses_a_directory(tmp_path):
    first = train_run(tiny_args(tmp_path, epochs=1))
    second = train_run(tiny_args(tmp_path, epochs=1))
    assert first != second and (first / "metrics.jsonl").exists()


def test_resume_with_other_shapes_fails_and_writes_nothing(tmp_path):
    run_dir = train_run(tiny_args(tmp_path, epochs=1))
    config = json.loads((run_dir / "config.json").read_text())
    config["train"]["replay_capacity"] = 4000
    (run_dir / "config.json").write_text(json.dumps(config))
    before = (run_dir / "metrics.jsonl").read_text()
    with pytest.raises(ValueError, match="does not match"):
        train_run(RunArgs(resume=str(run_dir)))
    assert (run_dir / "metrics.jsonl").read_text() == before


def test_corrupt_checkpoint_falls_back_to_the_previous_one(tmp_path):
    run_dir = train_run(tiny_args(tmp_path, epochs=3, checkpoint_every=1))
    newest = run_dir / "checkpoints" / "3"
    for f in newest.rglob("*"):
        if f.is_file() and f.stat().st_size > 0:
            f.write_bytes(b"garbage")
    train_run(RunArgs(resume=str(run_dir)))
    assert [r["epoch"] for r in read_metrics(run_dir)] == [1, 2, 3]
    assert list((run_dir / "checkpoints").glob("3.corrupt-*")), "the bad checkpoint is kept aside"
    assert (run_dir / "checkpoints" / "3").exists()  # epoch 3 trained again and saved


def test_a_run_killed_mid_append_resumes_from_the_command_line(tmp_path):
    """A crash left metrics.jsonl's last line half written: `train --resume RUN` drops it
    (it used to exit on a JSON error) and the log ends with whole lines only."""
    from mjx_skills import train

    run_dir = train_run(tiny_args(tmp_path, epochs=3, checkpoint_every=1), stop_after=2)
    with (run_dir / "metrics.jsonl").open("a") as f:
        f.write('{"epoch": 3, "seed": 0, "eval_succ')
    train.main(["--resume", str(run_dir)])
    text = (run_dir / "metrics.jsonl").read_text()
    assert text.endswith("}\n")
    assert [json.loads(line)["epoch"] for line in text.splitlines()] == [1, 2, 3]


def test_bad_input_names_the_field(tmp_path):
    with pytest.raises(ValueError, match="valid: transit, grasp"):
        train_run(tiny_args(tmp_path, task="stack"))
    with pytest.raises(ValueError, match="valid: ddpg_her"):
        train_run(RunArgs(train=TrainConfig(**TINY, out=str(tmp_path)), method="sac"))
    with pytest.raises(ValueError, match="no option group"):
        train_run(RunArgs(train=TrainConfig(**TINY, out=str(tmp_path)), options={"search": 1}))
    assert not list(tmp_path.iterdir()), "bad input must not create a run directory"
    with pytest.raises(ValueError, match="envs"):
        TrainConfig(envs=0)
    with pytest.raises(ValueError, match="gamma"):
        DDPGConfig(gamma=1.5)
    # No updates would leave the epoch's loss metrics as means of nothing (NaN).
    with pytest.raises(ValueError, match="updates_per_cycle"):
        TrainConfig(updates_per_cycle=0)


def test_non_finite_metrics_stop_the_run():
    with pytest.raises(FloatingPointError, match="critic_loss"):
        check_finite({"critic_loss": np.array([np.nan]), "actor_loss": np.array([0.0])})


def test_config_round_trips(tmp_path):
    run_dir = train_run(tiny_args(tmp_path, epochs=1))
    loaded = load_config(run_dir)
    assert loaded.train == dataclasses.replace(TrainConfig(**TINY), out=str(tmp_path), epochs=1)
    assert loaded.env == EnvConfig() and loaded.options == {"ddpg": DDPGConfig()}
    assert loaded.method == "ddpg_her"


def test_counters_are_the_x_axes(tmp_path):
    rows = read_metrics(train_run(tiny_args(tmp_path, epochs=2, seeds=2)))
    per_epoch = TINY["envs"] * TINY["cycles"]
    for r in rows:
        assert r["episodes"] == r["epoch"] * per_epoch
        assert r["env_steps"] == r["episodes"] * 20  # transit: 20 steps per episode
        assert r["skill_calls"] == 0 and isinstance(r["env_steps"], int)


@pytest.mark.parametrize(
    "argv,message",
    [
        (["--task", "stack"], "valid: transit, grasp"),
        (["--method", "sac"], "method"),
        (
            ["--method", "pas", "--pas.library-dir", "/nonexistent/lib"],
            "reads its library from --pas.library-dir",
        ),
        (["mpas", "--pas.library", "SL4"], "SL4"),
        (["sac", "--task", "transit"], "valid: ddpg_her"),
        (["--epochs", "0"], "epochs"),
        (["--resume", "/nonexistent/run"], "not a run directory"),
        (["--resume", "/nonexistent/run", "--task", "transit"], "--resume takes only --epochs"),
        (["ddpg_her", "--task", "transit", "--track"], "needs wandb: pip install wandb"),
        (["ddpg_her", "--wandb-project", ""], "wandb_project"),
    ],
)
def test_cli_bad_input_is_a_clear_error(argv, message, capsys):
    from mjx_skills.train import main

    out = [] if "--resume" in argv else ["--out", "/nonexistent/never-written"]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, *out])
    assert message in str(exit_info.value) + capsys.readouterr().err


def test_cli_forms_parse_to_the_same_run():
    from mjx_skills.train import parse

    sub = parse(["ddpg_her", "--task", "transit", "--ddpg.actor-lr", "3e-4", "--physics", "mjx"])
    old = parse(
        [
            "--method",
            "ddpg_her",
            "--task",
            "transit",
            "--ddpg.actor-lr",
            "3e-4",
            "--env.physics",
            "mjx",
        ]
    )
    assert sub == old
    assert sub.method == "ddpg_her" and sub.options["ddpg"].actor_lr == 3e-4
    assert sub.env.physics == "mjx" and sub.train.task == "transit"
    # No method named: the default, DDPG+HER+SL (as `make train`), with the same flags.
    default = parse(["--task", "transit", "--ddpg.actor-lr", "3e-4", "--physics=mjx"])
    assert default.method == "ddpg_her_sl" and default.options["ddpg"] == sub.options["ddpg"]
    assert (default.train, default.env) == (sub.train, sub.env)


@pytest.mark.parametrize(
    ("task", "library", "method"),
    [
        ("pick_move", "SL1", "ddpg_her_sl"),
        ("fetch_pick_and_place", "SL1_fetch", "ddpg_her_sl_fast"),
        ("fetch_push", "SL_fetch_push", "ddpg_her_sl_fast"),
    ],
)
def test_make_train_gives_a_task_the_skills_of_its_robot(task, library, method):
    """`make train TASK=...` runs the CLI with the library of the task's robot (`--preset
    fetch` on a Fetch task) and the best measured method there (a Fetch preset's:
    DDPG+HER+SL+Fast; a method named wins), and a preset given twice is refused, not
    silently dropped."""
    import shlex
    import subprocess

    from mjx_skills.train import parse

    root = Path(__file__).parents[2]
    dry = subprocess.run(
        ["make", "-n", "-s", "train", f"TASK={task}"], cwd=root, capture_output=True, text=True
    ).stdout
    (line,) = [x for x in dry.splitlines() if "-m mjx_skills.train" in x]
    argv = shlex.split(line.partition("-m mjx_skills.train")[2])
    args = parse(argv)
    assert args.train.task == task and args.options["search"].library == library
    assert args.method == method
    assert parse(["ddpg_her_sl", *argv]).method == "ddpg_her_sl"
    assert args.train.epochs == parse(["--task", task]).train.epochs  # one default budget
    with pytest.raises(SystemExit, match="--preset given twice"):
        parse([*argv, "--preset", "thesis", "--preset=thesis"])
    with pytest.raises(SystemExit, match="--preset needs a value"):  # not the default preset
        parse(["--task", task, "--preset="])


def test_the_help_lists_the_tasks_the_early_flags_and_one_example_a_line(capsys):
    from mjx_skills.envs.registry import ENVS
    from mjx_skills.train import main

    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert f"tasks (--task): {', '.join(ENVS)}" in " ".join(text.split())
    for flag in ("--resume RUN_DIR", "--preset NAME", "--method NAME"):
        assert flag in text
    examples = [line for line in text.splitlines() if "python -m mjx_skills.train " in line]
    assert len(examples) >= 4 and all(line.count("python -m") == 1 for line in examples)
    with pytest.raises(SystemExit):
        main(["pas", "--help"])
    assert "fetch_pick_and_place" in capsys.readouterr().out


def test_resume_takes_only_a_longer_budget_on_the_command_line():
    from mjx_skills.train import parse

    assert parse(["--resume", "RUN"]) == RunArgs(resume="RUN")
    assert parse(["--resume", "RUN", "--epochs", "60"]) == RunArgs(resume="RUN", extend_to=60)
    for extra in (["--task", "transit"], ["--epochs", "many"]):
        with pytest.raises(SystemExit, match="--epochs"):
            parse(["--resume", "RUN", *extra])


def _held(env, state):
    return env.grasped(state.obs)


def _a_cube_at_its_goal(env, state):
    return env.cube_success(state.achieved_goal, state.desired_goal).any(-1)


@pytest.mark.parametrize(
    "task, field, started",
    [
        ("pick_move", "held_start_prob", _held),
        ("two_in_container", "goal_start_prob", _a_cube_at_its_goal),
    ],
)
def test_training_only_starts_never_reach_the_evaluation_episodes(
    monkeypatch, task, field, started
):
    """--env.held-start-prob 1 (a cube in the fingers) or --env.goal-start-prob 1 (a cube
    already at its goal): every training episode starts so, no evaluation episode does (the
    epoch is built with a separate evaluation env)."""
    seen = {}
    real = train_mod.make_train_epoch

    def spy(learner, env, cfg, eval_env=None):
        seen["train"], seen["eval"] = env, eval_env
        return real(learner, env, cfg, eval_env)

    monkeypatch.setattr(train_mod, "make_train_epoch", spy)
    cfg = TrainConfig(**tiny_train(task=task, cycles=1, updates_per_cycle=1, replay_capacity=1000))
    from mjx_skills import methods

    train_mod._build_program(
        methods.get("ddpg_her"), cfg, EnvConfig(**{field: 1.0}), {"ddpg": DDPGConfig()}
    )
    keys = jax.random.split(jax.random.PRNGKey(0), 16)
    starts = {role: jax.jit(jax.vmap(seen[role].reset))(keys) for role in ("train", "eval")}
    assert np.all(np.asarray(started(seen["train"], starts["train"])))
    from mjx_skills.envs import make

    plain = jax.jit(jax.vmap(make(task).reset))(keys).obs  # the task's own starts
    np.testing.assert_array_equal(np.asarray(starts["eval"].obs), np.asarray(plain))
    assert np.mean(np.asarray(started(seen["eval"], starts["eval"]))) < 0.5
