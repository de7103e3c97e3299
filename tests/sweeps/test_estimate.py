"""The sweep's cost estimate: the measured epoch costs added up per cell, stored cells
costing nothing, and the cores each job gets."""

import dataclasses
import json

import pytest

from mjx_skills.sweeps.experiments import Experiment


def test_core_groups_are_disjoint_and_cover_the_cores():
    from mjx_skills.core.workers import core_groups

    assert core_groups(2, [0, 1]) == [(0,), (1,)]
    assert core_groups(2, [0, 1, 2, 3, 4]) == [(0, 1, 2), (3, 4)]
    assert core_groups(3, [0, 1]) == [(0,), (1,), (0,)]  # more jobs than cores: shared
    with pytest.raises(ValueError, match="jobs"):
        core_groups(0, [0, 1])


def test_the_estimate_adds_up_the_measured_epoch_costs():
    from mjx_skills.sweeps import cost

    rows = [
        {
            "variant": v,
            "seeds": s,
            "cores": 1,
            "epoch_s": e * s,
            "compile_s": 10.0,
            "updates_s": 0.0 if v != "ddpg_her" else e * s,
        }
        for v, e in (("ddpg_her", 1.0), ("sl_eps1", 3.0), ("sl_eps0", 1.0))
        for s in (1, 3)
    ]
    exp = Experiment(
        name="t",
        description="",
        tasks=("pick_move", "put_in_container"),
        methods=("ddpg_her", "ddpg_her_sl"),
        seeds=5,
        epochs=40,
    )
    est = cost.estimate(exp, jobs=1, rows=rows)
    cells = est["cells"]
    # DDPG+HER: all updates, so the episode length (100 vs 50) does not matter; 5 seeds
    # extrapolate the line through 1 and 3 seeds: 5 s per epoch.
    assert cells["pick_move-ddpg_her-s5-e40"] == cells["put_in_container-ddpg_her-s5-e40"] == 210
    # SL: eps 1 -> 0.001 over 30 epochs, then 10 epochs at eps 0.001; twice on 100 steps.
    eps = [1.0 + min(e / 30, 1.0) * (0.001 - 1.0) for e in range(40)]
    sl = 10 + sum(5 + 10 * x for x in eps)
    assert cells["pick_move-ddpg_her_sl-SL1-s5-e40"] == round(sl)
    assert cells["put_in_container-ddpg_her_sl-SL1-s5-e40"] == round(10 + 2 * (sl - 10))
    assert est["serial_s"] == pytest.approx(sum(cells.values()), abs=2)
    two = cost.estimate(exp, jobs=2, rows=rows)
    assert max(cells.values()) <= two["wall_s"] < est["serial_s"]
    assert cost.makespan([3, 5, 3, 4, 3], 2) == 10  # longest first: 5 + 3, 4 + 3 + 3


def test_a_method_the_benchmark_does_not_measure_costs_what_its_stored_cells_took(tmp_path):
    """DDPG+HER+SL+Fast's estimate comes from its stored cells' wall time per epoch: the
    same task's cell of the same options first (an ablation of another option is not
    taken), scaled by seeds; another task's scaled by episode length."""
    from mjx_skills.sweeps import cells, cost

    def store(exp: Experiment, seconds_per_epoch: float) -> None:
        cell = exp.cells()[0]
        where = tmp_path / cell.name
        where.mkdir()
        (where / "definition.json").write_text(json.dumps(cells.definition(cell)))
        rows = [
            {"epoch": e, "seed": s, "wall_s": seconds_per_epoch * e, "eval_success": 0.0}
            for e in range(1, exp.epochs + 1)
            for s in range(exp.seeds)
        ]
        (where / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))

    fast = {"tasks": ("pick_move",), "methods": ("ddpg_her_sl_fast",), "libraries": ("SL1",)}
    store(Experiment(name="a", description="", seeds=5, epochs=4, **fast), 50.0)
    store(
        Experiment(
            name="b",
            description="",
            seeds=5,
            epochs=4,
            label="no_pick",
            options={"ddpg_her_sl_fast": {"fast": {"pick": False}}},
            **fast,
        ),
        500.0,
    )
    exp = Experiment(name="t", description="", seeds=2, epochs=10, **fast)
    assert cost.estimate(exp, jobs=1, rows=[], store=tmp_path)["wall_s"] == 10 * 50 * 2 / 5
    other = dataclasses.replace(exp, tasks=("put_in_container",))  # 100 steps, pick_move 50
    assert cost.estimate(other, jobs=1, rows=[], store=tmp_path)["wall_s"] == 10 * 50 * 2 / 5 * 2
    with pytest.raises(ValueError, match="no stored cell of it"):
        cost.estimate(exp, jobs=1, rows=[], store=tmp_path / "empty")


def test_the_estimate_says_the_jobs_it_models():
    """One cell gets one worker whatever --jobs asks: the summary line says the same as the
    JSON line under it."""
    from mjx_skills.sweeps import cost
    from mjx_skills.sweeps.experiments import adhoc

    text = cost.report(adhoc("one", ("transit",), ("ddpg_her",)), jobs=4)
    summary, est = text.splitlines()[-2], json.loads(text.splitlines()[-1])
    assert est["jobs"] == 1 and f"--jobs {est['jobs']} (" in summary, summary


def test_a_cell_at_a_budget_the_benchmark_did_not_measure_is_named_with_its_fields():
    """The epoch costs were measured at the default budget: a cell with 4x the updates and a
    bigger batch gets the same figure, so the estimate names those fields beside it."""
    from mjx_skills.sweeps import cost

    rows = [
        {"variant": "ddpg_her", "seeds": s, "cores": 1, "epoch_s": s, "compile_s": 1.0}
        for s in (1, 3)
    ]
    plain = Experiment(name="t", description="", tasks=("pick_move",), methods=("ddpg_her",))
    big = dataclasses.replace(
        plain,
        train={"updates_per_cycle": 400},
        options={"ddpg_her": {"ddpg": {"batch_size": 2000}}},
    )
    assert cost.estimate(plain, jobs=1, rows=rows)["unmodelled"] == {}
    est = cost.estimate(big, jobs=1, rows=rows)
    ((name, fields),) = est["unmodelled"].items()
    assert fields == [
        "--updates-per-cycle 400 (default 100)",
        "--ddpg.batch-size 2000 (default 128)",
    ]
    assert est["cells"][name] == cost.estimate(plain, jobs=1, rows=rows)["serial_s"]


def test_pas_s_own_update_count_and_the_episode_length_are_named_too():
    """PAS reads --pas.updates-per-cycle, not the trainer's; a longer episode costs more
    steps than the task's default that the model reads."""
    from mjx_skills.sweeps import cost
    from mjx_skills.sweeps.cell import Cell

    pas = Cell(
        task="pick_move",
        method="pas",
        library="SL1",
        seeds=1,
        epochs=1,
        options=(("pas", (("updates_per_cycle", 400),)),),
        env=(("episode_length", 500),),
    )
    assert cost.unmodelled(pas) == [
        "--env.episode-length 500 (default 0)",
        "--pas.updates-per-cycle 400 (default 40)",
    ]


def test_an_adhoc_grid_takes_a_preset_and_is_checked_at_the_budget_asked_for(capsys):
    """`sweep --tasks fetch_push ... --preset fetch_push` points the library method at the
    push library (without it, the Baxter library is refused, naming the cell as asked: s2-e3);
    an experiment file states its own preset."""
    from mjx_skills import sweep

    grid = ["--tasks", "fetch_push", "--methods", "ddpg_her_sl", "--libraries", "SL_fetch_push"]
    budget = ["--seeds", "2", "--epochs", "3", "--estimate"]
    sweep.main([*grid, "--preset", "fetch_push", *budget])
    out = capsys.readouterr().out
    assert "fetch_push-ddpg_her_sl-SL_fetch_push-fetch_push-s2-e3" in out
    assert "--updates-per-cycle 200 (default 100)" in out  # the preset's tuned learner
    with pytest.raises(SystemExit, match="cell fetch_push-ddpg_her_sl-SL_fetch_push-s2-e3: the"):
        sweep.main([*grid, *budget])
    with pytest.raises(SystemExit, match="an experiment file states its own"):
        sweep.main(["--experiment", "fetch_her", "--preset", "fetch", "--estimate"])
