"""Every legal path works or is refused before training starts (orbax globs its directory)."""

import shutil
import string

import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mjx_skills.config import TrainConfig
from mjx_skills.core.paths import check_writable_path
from mjx_skills.training.checkpoint import Checkpoints
from mjx_skills.training.runner import RunArgs, train_run

TREE = {"a": jnp.arange(4.0), "b": {"c": jnp.ones((2, 3)), "d": jnp.arange(3, dtype=jnp.int32)}}
CHARACTERS = string.punctuation.replace("/", "") + " \t\n\x01é中"  # "/" separates names


def _round_trips_or_is_refused(directory) -> str:
    """'refused' if the path check refuses `directory`, 'ok' if a checkpoint saved there
    restores to the same arrays; fails the test otherwise (a path that loses the data)."""
    try:
        check_writable_path(directory)
    except ValueError:
        assert not directory.exists(), "refused before anything is written"
        return "refused"
    checkpoints = Checkpoints(directory / "checkpoints")
    checkpoints.save(1, TREE)
    checkpoints.close()
    epoch, restored = Checkpoints(directory / "checkpoints").restore(TREE)
    assert epoch == 1
    np.testing.assert_array_equal(restored["b"]["c"], TREE["b"]["c"])
    np.testing.assert_array_equal(restored["a"], TREE["a"])
    return "ok"


@pytest.mark.parametrize("character", list(CHARACTERS))
def test_every_character_in_a_run_path_works_or_is_refused(tmp_path, character):
    for name in (f"run{character}x", f"{character}", f"a{character}b{character}c"):
        _round_trips_or_is_refused(tmp_path / name)


@pytest.mark.parametrize("name", ["runs[v2]", "x[ab]y", "[x]", "a[!b]", "back\\slash", "a**b"])
def test_the_reported_paths_are_refused(tmp_path, name):
    """The glob classes and the backslash that lost trained runs (issue, row 1), and the
    `**` that orbax's glob refuses outright (found by the random-names test below)."""
    assert _round_trips_or_is_refused(tmp_path / name) == "refused"


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(name=st.text(st.sampled_from(CHARACTERS + "ab"), min_size=1, max_size=6))
def test_random_names_work_or_are_refused(tmp_path_factory, name):
    if name in (".", "..") or "/" in name:
        return
    _round_trips_or_is_refused(tmp_path_factory.mktemp("p") / name)


def test_training_into_such_a_path_is_refused_before_anything_is_written(tmp_path):
    out = tmp_path / "runs[v2]"
    args = RunArgs(train=TrainConfig(task="transit", epochs=1, out=str(out), progress=False))
    with pytest.raises(ValueError, match=r"--out .*'\['"):
        train_run(args)
    assert not out.exists()
    with pytest.raises(ValueError, match="--resume"):
        train_run(RunArgs(resume=str(out / "transit" / "ddpg_her" / "1")))


def test_a_good_run_copied_under_such_a_path_is_refused_never_set_aside(tmp_path):
    """Reading a checkpoint there (evaluate, render, --resume) would fail and rename the
    good checkpoint `.corrupt`: the path is refused before orbax reads anything."""
    plain = tmp_path / "plain" / "checkpoints"
    checkpoints = Checkpoints(plain)
    checkpoints.save(1, TREE)
    checkpoints.close()
    copy = tmp_path / "runs[v2]" / "checkpoints"
    shutil.copytree(plain, copy)
    before = sorted(p.name for p in copy.iterdir())
    with pytest.raises(ValueError, match="checkpoint directory"):
        Checkpoints(copy)
    assert sorted(p.name for p in copy.iterdir()) == before


@pytest.mark.parametrize("empty", ["", " "])
def test_an_empty_path_is_refused_by_every_command(tmp_path, monkeypatch, empty):
    """An empty --out, --resume, --work or --sweep-dir is refused, never read as 'not given'
    (the default) nor as the current directory."""
    from mjx_skills import build_library, sweep

    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match="--out: an empty path"):
        train_run(RunArgs(train=TrainConfig(task="transit", epochs=1, out=empty)))
    with pytest.raises(ValueError, match="--resume: an empty path"):
        train_run(RunArgs(resume=empty))
    with pytest.raises(SystemExit, match="--work: an empty path"):
        build_library.main(["--out", str(tmp_path / "lib"), "--work", empty])
    with pytest.raises(SystemExit):
        sweep.main(["--tasks", "transit", "--methods", "ddpg_her", "--sweep-dir", empty])
    assert list(tmp_path.iterdir()) == []


def test_a_tilde_run_is_written_whole_under_the_home_directory(tmp_path, monkeypatch, tiny_train):
    """`--out ~/x` puts config, metrics and checkpoints in one run under $HOME (orbax
    expands `~` itself; the run's own files once went under a directory named `~`)."""
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    run_dir = train_run(RunArgs(train=TrainConfig(**tiny_train, epochs=1, out="~/runs")))
    assert run_dir.is_relative_to(tmp_path / "home" / "runs")
    names = {p.name for p in run_dir.iterdir()}
    assert {"config.json", "metrics.jsonl", "checkpoints"} <= names
    assert not (tmp_path / "~").exists()


def test_the_committed_library_is_found_from_another_working_directory(tmp_path, monkeypatch):
    """The options name the committed skill library relative to the checkout: from any other
    working directory it is still found (it was "no skill library at
    experiments/skill_library"), and a library of that name in the working directory wins."""
    from mjx_skills import methods
    from mjx_skills.config import SearchConfig
    from mjx_skills.core.paths import CHECKOUT
    from mjx_skills.skills.library import read_manifest

    default = SearchConfig().library_dir
    assert not default.startswith("/")  # named relative, as the stored cells record it
    committed = read_manifest(CHECKOUT / default)
    monkeypatch.chdir(tmp_path)
    assert read_manifest(default) == committed
    methods.check_library_robot("ddpg_her_sl", "pick_move")  # reads the committed manifest
    found = r"built for the Baxter robot \(\S*experiments/skill_library\); fetch_push is a Fetch"
    with pytest.raises(ValueError, match=found):
        methods.check_library_robot("ddpg_her_sl", "fetch_push")  # the Baxter library, found
    (tmp_path / default).mkdir(parents=True)  # the working directory's own, half-written
    with pytest.raises(ValueError, match="half-written skill library"):
        read_manifest(default)


def test_an_install_without_the_checkout_says_where_the_library_is_expected(tmp_path, monkeypatch):
    """Installed without the checkout (no experiments/ beside the package), a relative library
    path is looked up in the working directory, then $MJX_SKILLS_HOME; the error names both
    and the command that builds it (no `make`); $MJX_SKILLS_HOME pointing at a checkout finds
    its committed library."""
    from mjx_skills.core import paths
    from mjx_skills.skills.library import read_manifest

    checkout, default = paths.CHECKOUT, "experiments/skill_library"
    monkeypatch.setattr(paths, "CHECKOUT", tmp_path / "site-packages")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(paths.HOME, raising=False)
    with pytest.raises(FileNotFoundError) as missing:
        read_manifest(default)
    said = str(missing.value)
    assert f"looked up in the working directory, then {tmp_path / 'site-packages'}" in said
    assert "`make skills`" not in said and "mjx_skills.build_library --out" in said
    assert f"${paths.HOME}" in said
    monkeypatch.setenv(paths.HOME, str(checkout))
    assert read_manifest(default) == read_manifest(checkout / default)
