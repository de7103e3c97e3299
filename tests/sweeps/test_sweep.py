"""Sweeps: experiments are checked data, cells resume and are skipped when finished, results
are aggregated over seeds and never overwritten unasked; cells also run as Ray tasks."""

import csv
import dataclasses
import json
import shutil

import pytest

from mjx_skills import sweep
from mjx_skills.sweeps import local
from mjx_skills.sweeps.experiment_file import names
from mjx_skills.sweeps.experiments import Experiment, load_experiment
from mjx_skills.sweeps.ray_cells import check_ray_address
from mjx_skills.training.metrics_log import read_metrics
from mjx_skills.training.runner import train_run

TINY = {"envs": 2, "cycles": 2, "updates_per_cycle": 3, "eval_episodes": 2, "replay_capacity": 3000}


def _tiny(epochs=2, seeds=2) -> Experiment:
    return Experiment(
        name="tiny",
        description="test",
        tasks=("transit",),
        methods=("ddpg_her",),
        seeds=seeds,
        epochs=epochs,
        train=TINY,
    )


def test_the_thesis_experiments_are_valid_files():
    assert {"smoke", "fig6_3", "fig6_4", "fig6_5"} <= set(names())
    fig = load_experiment("fig6_3")
    assert {(c.task, c.method) for c in fig.cells()} == {
        (t, m)
        for t in ("pick_move", "put_in_container", "put_on", "take_out")
        for m in ("ddpg_her", "pas", "mpas", "ddpg_her_sl")
    }
    ablation = load_experiment("fig6_4").cells()
    assert sorted({c.library for c in ablation}) == ["SL1", "SL2", "SL3"]
    args = ablation[0].run_args("out")
    assert args.full_options()["search"].library == ablation[0].library


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--experiment", "fig9"], "valid: .*fig6_3"),
        (["--tasks", "pick_moov", "--methods", "pas"], "valid: transit"),
        (["--tasks", "pick_move", "--methods", "pass"], "valid: ddpg_her"),
        (["--tasks", "pick_move", "--methods", "pas", "--libraries", "SL9"], "valid: SL1"),
        (["--tasks", "pick_move"], "--methods"),
    ],
)
def test_bad_names_list_the_valid_ones(argv, message, tmp_path):
    with pytest.raises(SystemExit, match=message):
        sweep.main([*argv, "--sweep-dir", str(tmp_path)])


def test_an_unreachable_ray_cluster_fails_fast_naming_it():
    with pytest.raises(SystemExit, match="127.0.0.1:9"):
        check_ray_address("127.0.0.1:9", timeout_s=2.0)


@pytest.fixture(scope="module")
def finished_sweep(tmp_path_factory):
    """A 2-cell-epoch sweep whose only cell was interrupted after epoch 1, then resumed."""
    root = tmp_path_factory.mktemp("sweep")
    exp = _tiny()
    cell = exp.cells()[0]
    cell_dir = root / "cells" / cell.name
    first = train_run(cell.run_args(str(cell_dir), progress=False), stop_after=1)
    paths = sweep.run_sweep(
        exp, root / "cells", root / "results", root / "results" / "cells", progress=False
    )
    return root, exp, first, paths


def test_an_interrupted_cell_resumes_in_its_own_run(finished_sweep):
    root, exp, first, _ = finished_sweep
    cell = exp.cells()[0]
    assert local.cell_run_dir(root / "cells" / cell.name) == first
    rows = read_metrics(first)
    assert sorted((r["epoch"], r["seed"]) for r in rows) == [(1, 0), (1, 1), (2, 0), (2, 1)]


def test_results_aggregate_the_seeds_of_every_epoch(finished_sweep):
    _, _, first, (csv_path, jsonl_path) = finished_sweep
    rows = list(csv.DictReader(csv_path.open()))
    assert [int(r["epoch"]) for r in rows] == [1, 2]
    per_seed = [json.loads(line) for line in jsonl_path.read_text().splitlines()]
    for row in rows:
        seeds = [s["eval_success"] for s in per_seed if s["epoch"] == int(row["epoch"])]
        assert int(row["seeds"]) == len(seeds) == 2
        assert float(row["eval_success_mean"]) == pytest.approx(sum(seeds) / 2, abs=1e-4)
        assert row["task"] == "transit" and row["method"] == "ddpg_her"


def test_a_finished_sweep_skips_its_cells_and_keeps_its_results(finished_sweep):
    root, exp, first, (csv_path, _) = finished_sweep
    before = (first / "metrics.jsonl").read_text()
    with pytest.raises(SystemExit, match="--overwrite"):
        sweep.run_sweep(
            exp, root / "cells", root / "results", root / "results" / "cells", progress=False
        )
    sweep.run_sweep(
        exp,
        root / "cells",
        root / "results",
        root / "results" / "cells",
        overwrite=True,
        progress=False,
    )
    assert (first / "metrics.jsonl").read_text() == before  # nothing trained again
    assert len(list((root / "cells").iterdir())) == 1


def test_derived_results_in_the_checkouts_folder_are_replaced_without_asking(
    finished_sweep, monkeypatch
):
    """NAME.csv in the checkout's results folder (git-ignored, derived from stored cells) is
    written again; the same file elsewhere is refused without --overwrite (above)."""
    root, exp, _, (csv_path, _) = finished_sweep
    monkeypatch.setattr(sweep, "RESULTS", root / "results")
    monkeypatch.setattr(sweep, "STORE", root / "results" / "cells")
    text = csv_path.read_text()
    csv_path.write_text("stale")
    sweep.run_sweep(
        exp, root / "cells", root / "results", root / "results" / "cells", progress=False
    )
    assert csv_path.read_text() == text


def test_a_stored_cell_is_reused_only_with_the_definition_that_made_it(finished_sweep, tmp_path):
    """The finished cell is kept with its definition; a fresh sweep directory takes it from
    the store without training; the same cell name with another `[train] cycles` is refused
    naming the field, both from the store and from a run directory (it never prints "done"
    with the old definition's results)."""
    root, exp, first, _ = finished_sweep
    results = root / "results"
    cell = exp.cells()[0]
    kept = results / "cells" / cell.name
    assert read_metrics(kept) == read_metrics(first)
    assert json.loads((kept / "definition.json").read_text())["config"]["train"]["cycles"] == 2
    sweep.run_sweep(
        exp, tmp_path / "fresh", results, results / "cells", overwrite=True, progress=False
    )
    assert not (tmp_path / "fresh").exists()  # nothing trained, no run directory made
    other = dataclasses.replace(exp, train={**TINY, "cycles": 1})
    assert other.cells()[0].name == cell.name
    with pytest.raises(ValueError, match=r"train\.cycles: 2 != 1"):
        sweep.run_sweep(
            other, tmp_path / "fresh", results, results / "cells", overwrite=True, progress=False
        )
    with pytest.raises(ValueError, match=r"another definition.*train\.cycles"):
        sweep.run_sweep(
            other,
            root / "cells",
            tmp_path / "elsewhere",
            tmp_path / "elsewhere" / "cells",
            progress=False,
        )


def test_concurrent_cells_resume_apart_and_equal_a_serial_sweep(finished_sweep, tmp_path):
    """--jobs 2 --pin: each cell in its own pinned worker process and directory; the cell
    interrupted before the sweep resumes, and its metrics are the bits a one-at-a-time
    sweep gave (`finished_sweep`, the same cell also interrupted and resumed)."""
    _, _, serial_run, _ = finished_sweep
    exp = Experiment(
        name="tiny",
        description="test",
        tasks=("transit", "transfer"),
        methods=("ddpg_her",),
        seeds=2,
        epochs=2,
        train=TINY,
    )
    cells = exp.cells()
    interrupted = train_run(
        cells[0].run_args(str(tmp_path / "cells" / cells[0].name), progress=False), stop_after=1
    )
    csv_path, jsonl_path = sweep.run_sweep(
        exp,
        tmp_path / "cells",
        tmp_path / "results",
        tmp_path / "results" / "cells",
        progress=False,
        jobs=2,
        pin=True,
    )
    run_dirs = [local.cell_run_dir(tmp_path / "cells" / c.name) for c in cells]
    assert run_dirs[0] == interrupted and len(set(run_dirs)) == 2
    for run_dir in run_dirs:
        rows = read_metrics(run_dir)
        assert sorted((r["epoch"], r["seed"]) for r in rows) == [(1, 0), (1, 1), (2, 0), (2, 1)]
    drop_wall = lambda rows: [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]
    assert drop_wall(read_metrics(run_dirs[0])) == drop_wall(read_metrics(serial_run))
    per_seed = [json.loads(line) for line in jsonl_path.read_text().splitlines()]
    assert {r["task"] for r in per_seed} == {"transit", "transfer"} and len(per_seed) == 8
    with pytest.raises(SystemExit):  # the message: tests/sweeps/test_experiment_files.py
        sweep.main(["--experiment", "smoke", "--jobs", "0", "--sweep-dir", str(tmp_path)])


def test_cells_run_as_ray_tasks(tmp_path):
    ray = pytest.importorskip("ray")
    exp = _tiny(epochs=1, seeds=1)
    try:
        csv_path, _ = sweep.run_sweep(
            exp,
            tmp_path / "cells",
            tmp_path / "results",
            tmp_path / "results" / "cells",
            ray_address="local",
            progress=False,
        )
    finally:
        ray.shutdown()
    rows = list(csv.DictReader(csv_path.open()))
    assert [(r["epoch"], r["seeds"]) for r in rows] == [("1", "1")]


def test_a_field_added_since_a_cell_was_stored_matches_only_at_its_default():
    """A stored definition that predates a config field still matches while the field is at
    its default (the behaviour the older code had), and is refused once it is set."""
    from mjx_skills.sweeps import cells

    cell = _tiny().cells()[0]
    new = cells.definition(cell)
    old = json.loads(json.dumps(new))
    del old["config"]["env"]["single_goal"]
    assert cells._config_differences(old["config"], new["config"]) == []
    variant = dataclasses.replace(cell, env=(("single_goal", True),))
    diff = cells._config_differences(old["config"], cells.definition(variant)["config"])
    assert diff == ["env.single_goal: None != True"]
    old["config"]["env"]["single_goal"] = False  # a stored value is always compared
    assert cells._config_differences(old["config"], cells.definition(variant)["config"])


def test_a_longer_budget_trains_on_from_the_shorter_cells_run(finished_sweep, tmp_path):
    """The cell given 3 epochs where a 2-epoch run of its definition is in the sweep's
    directory trains on from that run's checkpoint (the shorter run is left as it was) and
    equals the cell trained for 3 epochs from the start; another definition is not taken."""
    root, exp, first, _ = finished_sweep
    shorter = exp.cells()[0]
    sweep_dir = tmp_path / "cells"
    shutil.copytree(root / "cells" / shorter.name, sweep_dir / shorter.name)
    before = (first / "metrics.jsonl").read_text()
    longer = dataclasses.replace(exp, epochs=3)
    cell = longer.cells()[0]
    sweep.run_sweep(
        longer, sweep_dir, tmp_path / "results", tmp_path / "results" / "cells", progress=False
    )
    run = local.cell_run_dir(sweep_dir / cell.name)
    rel = first.relative_to(root / "cells" / shorter.name)  # the same run, trained on
    assert run.relative_to(sweep_dir / cell.name) == rel
    assert (sweep_dir / shorter.name / rel / "metrics.jsonl").read_text() == before
    sweep.run_sweep(
        longer,
        tmp_path / "straight",
        tmp_path / "elsewhere",
        tmp_path / "elsewhere" / "cells",
        progress=False,
    )
    fresh = local.cell_run_dir(tmp_path / "straight" / cell.name)
    drop_wall = lambda rows: [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]
    assert drop_wall(read_metrics(run)) == drop_wall(read_metrics(fresh))
    assert max(r["epoch"] for r in read_metrics(run)) == 3
    other = dataclasses.replace(exp, epochs=3, train={**TINY, "cycles": 1})
    assert local.copy_shorter_run(other.cells()[0], sweep_dir / other.cells()[0].name) is None


def test_a_field_whose_default_changed_matches_older_definitions_at_its_earlier_value():
    """A stored definition of schema 1 lacking `fast.pick_in_training` was made with the pick
    in training (`training.schema`'s step 1 -> 2), today's default being off: it matches a
    cell that sets it on, not one at today's default. An option the method does not read
    with the cell's switches (the pick's options with `fast.pick` off) is no difference."""
    from mjx_skills.sweeps import cells

    second = load_experiment("fast").cells()[0]  # pins the second default's values
    new = cells.definition(second)["config"]
    old = json.loads(json.dumps(new))
    del old["schema"]  # written before the layout was numbered
    del old["options"]["fast"]["pick_in_training"], old["options"]["fast"]["eval_average"]
    assert new["options"]["fast"]["pick_in_training"] is True
    assert cells._config_differences(old, new) == []
    today = json.loads(json.dumps(new))
    today["options"]["fast"].update(pick_in_training=False, eval_average=0.8)
    assert cells._config_differences(old, today) == [
        "options.fast.eval_average: 0.0 != 0.8",
        "options.fast.pick_in_training: True != False",
    ]
    no_pick = json.loads(json.dumps(new))
    no_pick["options"]["fast"].update(pick=False, proposals=32)
    old["options"]["fast"]["pick"] = False
    assert cells._config_differences(old, no_pick) == []
    no_pick["options"]["fast"]["pick"] = True  # read again once the pick is on
    assert cells._config_differences(old, no_pick) == [
        "options.fast.pick: False != True",
        "options.fast.proposals: 8 != 32",
    ]


def test_a_run_written_before_a_default_changed_loads_at_the_earlier_value(tmp_path):
    """A ddpg_her_sl_fast run whose config.json predates `fast.eval_average` and
    `fast.pick_in_training` resumes as it was made: online networks evaluated, the pick in
    training (`training.schema`'s step 1 -> 2), not at today's defaults."""
    from mjx_skills.methods.ddpg_her_sl_fast import FastConfig
    from mjx_skills.training import runner

    args = load_experiment("fast_eval_pick_low_floor_avg").cells()[0].run_args(str(tmp_path))
    runner.save_config(tmp_path, args)
    raw = json.loads((tmp_path / "config.json").read_text())
    assert raw["options"]["fast"]["eval_average"] == FastConfig().eval_average == 0.8
    del raw["options"]["fast"]["eval_average"], raw["options"]["fast"]["pick_in_training"]
    del raw["schema"]  # written before the layout was numbered
    (tmp_path / "config.json").write_text(json.dumps(raw))
    fast = runner.load_config(tmp_path).options["fast"]
    assert fast.eval_average == 0.0 and fast.pick_in_training is True


def test_a_sweep_run_elsewhere_takes_the_committed_store_and_trains_nothing(tmp_path, monkeypatch):
    """From another working directory, `--results TMP` writes a thesis CSV from the
    checkout's committed cells: every epoch of every cell over its 5 seeds, and no cell
    directory made (nothing trained). `--estimate` counts those cells as done."""
    from mjx_skills.sweeps import cost

    monkeypatch.chdir(tmp_path)
    sweep.main(["--experiment", "fig6_5", "--results", "out", "--no-progress"])
    rows = list(csv.DictReader((tmp_path / "out" / "fig6_5.csv").open()))
    stored = load_experiment("fig6_5").cells()
    assert {(r["task"], r["method"]) for r in rows} == {(c.task, c.method) for c in stored}
    assert len(rows) == sum(c.epochs for c in stored) and {r["seeds"] for r in rows} == {"5"}
    assert not (tmp_path / "runs").exists()
    text = cost.report(load_experiment("fig6_5"), jobs=1)
    est = json.loads(text.splitlines()[-1])
    assert est["cells"] == {} and len(est["stored"]) == 2 and est["wall_s"] == 0
    assert "2 cells, 2 stored; 0.00 h" in text
