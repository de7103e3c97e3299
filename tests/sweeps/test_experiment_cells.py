"""What an experiment's cells carry: a library sweep's one library per data size, its
library overrides, a variant's env overrides under its own name."""

import pytest

from mjx_skills.sweeps import local
from mjx_skills.sweeps.experiments import Experiment, load_experiment


def test_the_table_experiment_builds_one_library_per_data_size(tmp_path):
    table = load_experiment("table5_1")
    cells = table.cells()
    assert [c.samples for c in cells] == list(table.samples) and len(cells) >= 2
    assert len({c.name for c in cells}) == len(cells)
    assert not local.finished(local.cell_run_dir(tmp_path / cells[0].name), cells[0])
    with pytest.raises(ValueError, match="samples"):
        Experiment(name="t", description="", kind="library")
    with pytest.raises(ValueError, match="valid: train, library"):
        Experiment(name="t", description="", kind="tables")


def test_a_library_experiment_carries_its_library_overrides():
    anchored = load_experiment("table5_1_thesis")
    cells = anchored.cells()
    assert [c.name for c in cells] == [f"library-n{n}-anchor-start" for n in anchored.samples]
    assert not {c.name for c in cells} & {c.name for c in load_experiment("table5_1").cells()}
    with pytest.raises(ValueError, match="anchor"):
        Experiment(
            name="t", description="", kind="library", samples=(100,), library={"anchor": "middle"}
        )
    with pytest.raises(ValueError, match="unknown .library. field.*valid:"):
        Experiment(
            name="t", description="", kind="library", samples=(100,), library={"anchr": "goal"}
        )
    with pytest.raises(ValueError, match="kind"):
        Experiment(
            name="t",
            description="",
            tasks=("pick_move",),
            methods=("ddpg_her",),
            library={"anchor": "goal"},
        )


def test_an_experiment_variant_carries_its_env_overrides_under_its_own_name():
    """`[env]` reaches the run's EnvConfig and `label` keeps the variant's cells apart from
    the default cells (the store would refuse a shared name); bad env fields are named."""
    single = load_experiment("pas_single_goal").cells()
    default = [
        c for c in load_experiment("fig6_3").cells() if (c.task, c.method) == ("pick_move", "pas")
    ]
    assert single[0].name == "pick_move-pas-SL1-single_goal-s5-e100" != default[0].name
    assert (
        single[0].run_args("out").env.single_goal and not default[0].run_args("out").env.single_goal
    )
    held = load_experiment("take_out_held").cells()[0].run_args("out")
    assert held.env.held_start_prob == 0.5 and held.train.task == "take_out"
    with pytest.raises(ValueError, match=r"unknown \[env\] field.*valid:.*single_goal"):
        Experiment(
            name="t",
            description="",
            tasks=("pick_move",),
            methods=("ddpg_her",),
            env={"single_gaol": True},
        )
    with pytest.raises(ValueError, match="held_start_prob"):
        Experiment(
            name="t",
            description="",
            tasks=("pick_move",),
            methods=("ddpg_her",),
            env={"held_start_prob": 2.0},
        )
