"""Tuning seeds and headline seeds are kept apart by the code (issue "Results that stand up
to review"): a headline experiment on a tuning seed is refused when read, its cells run and
are named by their fresh seeds, and a stored cell trained on the tuning seeds cannot be read
as a headline."""

import jax
import numpy as np
import pytest

from mjx_skills.core.files import read_json
from mjx_skills.sweeps import cells, seeds
from mjx_skills.sweeps.experiments import Experiment, load_experiment
from mjx_skills.training.epoch import seed_keys

BASE = {"description": "test", "tasks": ("pick_move",), "methods": ("ddpg_her",), "epochs": 2}


def _experiment(**raw) -> Experiment:
    return Experiment(name="t", **{**BASE, **raw})


@pytest.mark.parametrize(("first", "count"), [(0, 10), (4, 3), (0, 1), (2, 1)])
def test_a_headline_on_a_tuning_seed_is_refused_when_read(first, count):
    with pytest.raises(ValueError, match=r"experiment t: .*tuning seeds .*seed = 100"):
        _experiment(role="headline", seed=first, seeds=count)
    _experiment(role="tuning", seed=first, seeds=count)  # tuning runs may use them


def test_a_headline_runs_and_is_named_by_its_fresh_seeds():
    exp = _experiment(role="headline", seed=100, seeds=10)
    (cell,) = exp.cells()
    assert cell.name == "pick_move-ddpg_her-seeds100-109-e2"
    train = cell.run_args(out="").train
    assert (train.seed, train.seeds) == (100, 10)
    keys = np.asarray(seed_keys(train))
    assert np.array_equal(keys[3], np.asarray(jax.random.PRNGKey(103)))
    # The budget flags keep the first seed: --seeds 3 runs 100-102.
    (cell,) = exp.with_budget(seeds=3).cells()
    assert cell.name.endswith("-seeds100-102-e2")
    # Seed 0 keeps the names every stored cell was filed under.
    assert _experiment(seeds=5).cells()[0].name == "pick_move-ddpg_her-s5-e2"


def test_the_seed_is_the_experiments_own_key_and_checked():
    with pytest.raises(ValueError, match=r"\[train\] \['seed'\]: set by the experiment"):
        _experiment(train={"seed": 100})
    with pytest.raises(ValueError, match=r"unknown role 'final'; valid: tuning, headline"):
        _experiment(role="final")
    with pytest.raises(ValueError, match=r"seed must be >= 0, got -1"):
        _experiment(seed=-1)


def test_a_stored_cell_on_the_tuning_seeds_is_not_a_headline():
    """Every committed cell that ran on a tuning seed is refused as a headline, naming the
    cell; the headlines' cells (seeds 100 on) are accepted, and so is a tuning cell's
    definition moved to the fresh seeds."""
    stored = sorted(p for p in cells.STORE.iterdir() if (p / "definition.json").exists())
    tuned = fresh = 0
    for where in stored:
        definition = read_json(where / "definition.json")
        train = definition["config"]["train"]
        if set(range(train["seed"], train["seed"] + train["seeds"])) & set(seeds.TUNING_SEEDS):
            tuned += 1
            with pytest.raises(ValueError, match=f"cell {where.name}: .*tuning seeds"):
                seeds.check_headline(where.name, definition)
        else:
            fresh += 1
            assert seeds.check_headline(where.name, definition)
    assert tuned and fresh
    definition = read_json(next(p for p in stored if "seeds100" not in p.name) / "definition.json")
    definition["config"]["train"]["seed"] = 100
    count = definition["config"]["train"]["seeds"]
    assert seeds.check_headline("moved", definition) == range(100, 100 + count)


def test_every_headline_experiment_file_runs_on_fresh_seeds():
    """The committed files: each headline's seeds avoid the tuning seeds (a file would fail
    to load otherwise; this names it)."""
    from mjx_skills.sweeps.experiment_file import names

    for name in names():
        exp = load_experiment(name)
        if exp.role == "headline":
            assert not set(range(exp.seed, exp.seed + exp.seeds)) & set(seeds.TUNING_SEEDS)
