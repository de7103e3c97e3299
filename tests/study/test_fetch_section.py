"""The Fetch section's peer runs: Stable-Baselines3 on gymnasium-robotics' own envs
(benchmarks/peer_sb3_fetch.py), grouped by settings and set beside our cells at the same
env steps."""

import json
from pathlib import Path

import numpy as np

from mjx_skills.sweeps.cell import Cell
from study import fetch, fetch_claims, fetch_library


def _row(seed, curve, net=256, steps=2400, starts="fresh per epoch and seed"):
    return {
        "eval_starts": starts,
        "task": "fetch_push",
        "algo": "sb3_ddpg_her",
        "seed": seed,
        "steps": steps,
        "net_arch": [net] * 3,
        "batch_size": 256,
        "curve": [
            {"env_steps": 800 * (i + 1), "wall_s": i, "eval_success": v}
            for i, v in enumerate(curve)
        ],
    }


def test_peer_rows_of_the_same_settings_form_one_run_of_several_seeds(tmp_path):
    path = tmp_path / "peers.jsonl"
    rows = [_row(1, [0.1] * 8), _row(0, [0.0] * 8), _row(0, [0.5] * 8, net=64)]
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    (a, b) = fetch.peer_cells(path)
    assert a[0] == "SB3 DDPG+HER (3 x 256, batch 256)" and a[1:3] == ("fetch_push", 800)
    np.testing.assert_array_equal(a[3], [[0.0] * 8, [0.1] * 8])  # ordered by seed
    assert b[0] == "SB3 DDPG+HER (3 x 64, batch 256)" and b[3].shape == (1, 8)
    assert fetch.peer_cells(tmp_path / "none.jsonl") == []


def test_peer_rows_evaluated_on_one_fixed_set_of_starts_are_a_run_of_their_own(tmp_path):
    path = tmp_path / "peers.jsonl"
    old = {k: v for k, v in _row(0, [0.05] * 8).items() if k != "eval_starts"}
    older = {**old, "seed": 1}
    rows = [old, older, _row(0, [0.1] * 8)]
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    (a, b) = fetch.peer_cells(path)
    assert a[0] == "SB3 DDPG+HER (3 x 256, batch 256, the same eval starts)"
    assert b[0] == "SB3 DDPG+HER (3 x 256, batch 256)"
    # once as many seeds ran on fresh starts, the fixed-start run is left out
    rows.append(_row(1, [0.2] * 8))
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    (only,) = fetch.peer_cells(path)
    assert only[0] == "SB3 DDPG+HER (3 x 256, batch 256)" and only[3].shape == (2, 8)


def test_a_seed_run_twice_counts_once_and_its_last_run_is_kept(tmp_path):
    path = tmp_path / "peers.jsonl"
    old = {k: v for k, v in _row(0, [0.05] * 8).items() if k != "eval_starts"}
    rows = [old, {**old, "seed": 1}, _row(0, [0.1] * 8), _row(0, [0.3] * 8)]
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    # two rows on fresh starts but one seed: the two fixed-start seeds stay
    (fixed, fresh) = fetch.peer_cells(path)
    assert fixed[0].endswith("the same eval starts)") and fixed[3].shape == (2, 8)
    np.testing.assert_array_equal(fresh[3], [[0.3] * 8])  # seed 0's rerun


def test_one_seeds_last_five_epochs_are_said_without_an_interval():
    assert fetch._last(np.full((1, 10), 0.5)) == "0.50 (1 seed, no interval)"
    assert fetch._last(np.tile([[0.4], [0.6]], 10)) == "0.50 [0.40, 0.60]"


def test_a_peer_is_compared_with_our_fresh_cells_up_to_the_shorter_runs_end():
    theirs = np.full((2, 10), 0.5)
    theirs[:, 3:8] = 0.1  # their epochs 4-8: a run of 8 epochs' window (3 of 5 of theirs)
    ours = np.zeros((3, 40))
    ours[:, 5:10] = 0.2  # the same env steps as their last 5 epochs
    ours[:, 10:] = 1.0  # later than their budget: not compared
    (line,) = fetch.peer_comparison(
        [
            ("mine", "fetch_push", 800, ours),
            ("short", "fetch_push", 800, ours[:, :8]),
            ("tuned", "fetch_push", 800, ours),
        ],
        [("SB3 X", "fetch_push", 800, theirs)],
        keep=lambda name: name != "tuned",
    )
    assert line.startswith("- FetchPush, SB3 X (2 seeds) beside our fresh-seed cells")
    assert "mine 0.20 [0.20, 0.20] (3 seeds) against 0.26 [0.26, 0.26], up to 8,000" in line
    assert "short 0.12 [0.12, 0.12] (3 seeds) against 0.10 [0.10, 0.10], up to 6,400" in line
    assert "tuned" not in line
    assert fetch.peer_comparison([], [("SB3 X", "fetch_push", 800, theirs)]) == []
    (one,) = fetch.peer_comparison(
        [("mine", "fetch_push", 800, ours)],
        [("SB3 Y", "fetch_push", 800, theirs[:1])],
        keep=lambda name: True,
    )
    assert "against 0.26 (1 seed, no interval), up to 8,000" in one


def test_the_fetch_librarys_table_counts_the_env_steps_its_build_took(tmp_path):
    model = {"memory_error_cm": 1.0, "model_error_cm": 0.5, "goal_error_cm": 2.0}
    manifest = {
        "commit": "abcdef0123",
        "skill_success": {"fetch_transit": 0.97, "fetch_grasp": 0.9},
        "models": {n: {**model, "classifier_auc": 0.99} for n in ("fetch_transit", "fetch_grasp")},
        "env_steps": {
            "train": {"fetch_transit": 6_400, "fetch_grasp": 32_000},
            "collect": {"fetch_transit": 100_000, "fetch_grasp": 150_000},
        },
    }
    path = tmp_path / "lib" / "manifest.json"
    path.parent.mkdir()
    path.write_text(json.dumps(manifest))
    lines = fetch_library.library_table(path)
    assert "its build took 288,400 env steps" in lines[0] and "`abcdef0`" in lines[0]
    assert lines[5] == "| fetch_grasp | 0.900 | 1.00 | 0.50 | 2.00 | 0.990 | 32,000 | 150,000 |"
    assert "a one-time cost that no stored cell searches with yet." in lines[0]
    served = fetch_library.library_table(path, "SL_x", ("FetchPush", "FetchReach"))[0]
    assert "a one-time cost that the stored cells of FetchPush and FetchReach share." in served
    assert fetch_library.library_table(tmp_path / "none.json", "SL_x")[0].startswith(
        "No skill library SL_x of Fetch"
    )


def test_a_cell_beside_a_published_figure_says_its_seeds_and_its_librarys_cost():
    sl = fetch_claims._caveats("fetch_pick_and_place_sl")
    assert "ran on the tuning seeds 0-2" in sl
    assert "skill library SL1_fetch of Fetch, whose build took" in sl
    flat = fetch_claims._caveats("fetch_push_her")
    assert "tuning seeds 0-2" in flat and "library" not in flat
    assert fetch_claims._caveats("not_an_experiment") == ""
    assert "not a flat actor" not in sl + flat  # DDPG+HER+SL and DDPG+HER evaluate the actor
    fast = fetch_claims._caveats("fetch_push_fast")  # the critic picks among skill actions
    assert "Its evaluated policy is not a flat actor as DDPG+HER's" in fast
    assert "not a flat actor" in fetch_claims._caveats("fetch_pick_and_place_pas: PAS")
    # a matched baseline runs Fast's method with the library removed: neither is said
    base = fetch_claims._caveats("headline_fetch_push_fast_no_library")
    assert "library" not in base and "not a flat actor" not in base
    assert fetch_claims.library_used("headline_fetch_push_fast_no_library") is None


def test_the_wall_clock_of_a_resumed_run_adds_its_stretches():
    # epochs 1-3 in one process, 4-5 after a resume (its clock starts again)
    rows = [
        {"epoch": e, "seed": s, "wall_s": w}
        for e, w in enumerate([10, 20, 30, 5, 15], 1)
        for s in (0, 1)
    ]
    np.testing.assert_allclose(fetch.clock(rows), [10, 20, 30, 35, 45])


def test_the_wall_time_to_the_level_is_read_at_the_epoch_that_reaches_it(tmp_path, monkeypatch):
    manifest, old = tmp_path / "manifest.json", tmp_path / "old.json"
    timings = {"train_a_s": 1.0, "collect_s": 90.0, "fit_s": 30.0}  # a reused skill: 1 s
    manifest.write_text(json.dumps({"timings_s": timings, "train_wall_s": {"a": 60.0}}))
    old.write_text(json.dumps({"timings_s": timings}))  # no training wall recorded
    lib = tmp_path / "skill_library_z"  # predates the record; rebuilt with the same digest
    lib.mkdir()
    (lib / "manifest.json").write_text(json.dumps({"timings_s": timings, "digest": "d1"}))
    rebuilds = tmp_path / "rebuilds"
    rebuilds.mkdir()
    rebuilt = {"timings_s": timings, "train_wall_s": {"a": 240.0}}
    (rebuilds / "skill_library_z.json").write_text(json.dumps({**rebuilt, "digest": "d1"}))
    other = tmp_path / "skill_library_w"  # its rebuild made other arrays: not its record
    other.mkdir()
    (other / "manifest.json").write_text(json.dumps({"timings_s": timings, "digest": "d2"}))
    (rebuilds / "skill_library_w.json").write_text(json.dumps({**rebuilt, "digest": "d3"}))
    libraries = {"searcher": ("SL_x", manifest), "older": ("SL_y", old)}
    libraries |= {"rebuilt": ("SL_z", lib / "manifest.json")}
    libraries |= {"mismatch": ("SL_w", other / "manifest.json")}
    monkeypatch.setattr(fetch, "library_used", libraries.get)
    monkeypatch.setattr(fetch, "REBUILDS", rebuilds)
    curve = [0.0, 0.2, 0.95, 0.95, 0.95, 0.95, 0.95, 1.0]  # rolling mean reaches 0.9 at epoch 7
    ours = [
        {"epoch": e, "seed": s, "wall_s": 60.0 * e, "eval_success": v, "env_steps": 800 * e}
        for e, v in enumerate(curve, 1)
        for s in (0, 1, 2)
    ]
    never = [{**r, "eval_success": 0.0} for r in ours]
    walls = np.tile(np.arange(1, 9) * 120.0, (2, 1))
    theirs = [("SB3 X", "fetch_push", 800, np.tile(curve, (2, 1)), walls)]
    push = Cell(task="fetch_push", method="ddpg_her", library=None, seeds=3, epochs=8)
    found = [("mine", push, ours), ("flat", push, never), ("searcher", push, ours)]
    found += [("older", push, ours), ("rebuilt", push, ours), ("mismatch", push, ours)]
    assert fetch.wall_table(found, theirs) == [
        ["FetchPush", "mine", "3 at once", "7.0 min", "-"],
        ["FetchPush", "searcher", "3 at once", "7.0 min", "10.0 min"],  # + the 3 min build
        ["FetchPush", "older", "3 at once", "7.0 min", "-"],
        ["FetchPush", "rebuilt", "3 at once", "7.0 min", "13.0 min"],  # + the rebuild's 6
        ["FetchPush", "mismatch", "3 at once", "7.0 min", "-"],
        ["FetchPush", "SB3 X", "1 at a time", "14.0 min", "-"],
    ]


def test_beside_a_published_figure_the_fresh_seed_headline_is_the_figure_we_stand_by():
    """A tuning cell that reaches 0.9 sooner is not the one set against mrl's figure when a
    headline on fresh seeds reaches it too."""
    fast, slow = np.zeros((3, 200)), np.zeros((10, 200))
    fast[:, 50:], slow[:, 150:] = 1.0, 1.0
    ours = [
        ("fetch_pick_and_place_sl", "fetch_pick_and_place", 800, fast),
        ("headline_fetch_pick_and_place", "fetch_pick_and_place", 800, slow),
    ]
    (line,) = [x for x in fetch_claims.shortfalls(ours) if x.startswith("On FetchPickAndPlace")]
    assert line.startswith(
        "On FetchPickAndPlace, headline_fetch_pick_and_place reaches 0.9 at 124,000"
    )
    assert "seeds 100-109, fresh" in line and "tuning" not in line
    root = Path(__file__).resolve().parents[2]
    steps = json.loads((root / "experiments/skill_library_fetch/manifest.json").read_text())
    steps = steps["env_steps"]  # SL1_fetch's: its skills' training and its data runs
    build = sum(steps["train"].values()) + sum(steps["collect"].values())
    assert f"Counting the library's build, {124_000 + build:,} env steps [95 % interval" in line
    (line,) = [x for x in fetch_claims.shortfalls(ours[:1]) if x.startswith("On FetchPickAndPlace")]
    assert "reaches 0.9 at 44,000" in line and "ran on the tuning seeds 0-2" in line


def test_a_rank_holds_only_when_the_upper_interval_clears_the_lower():
    from study import fetch_ranking

    rng = np.random.default_rng(0)
    high, low = 0.8 + 0.05 * rng.random((3, 125)), 0.1 + 0.05 * rng.random((3, 125))
    spread = np.stack([np.full(125, 0.0), np.full(125, 0.5), np.full(125, 1.0)])
    assert fetch_ranking.verdict(high, low) == "holds"
    assert fetch_ranking.verdict(low, high) == "reversed"
    assert fetch_ranking.verdict(spread, np.full((3, 125), 0.5)) == "not shown"
    found = {"ddpg_her_sl": high, "pas": low, "mpas": spread, "ddpg_her": low * 0}
    lines = fetch_ranking.section(found)
    assert lines[-1] == (
        "DDPG+HER+SL above PAS: holds; DDPG+HER+SL above MPAS: not shown; "
        "PAS above DDPG+HER: holds; MPAS above DDPG+HER: not shown."
    )
    assert fetch_ranking.section({k: v for k, v in found.items() if k != "pas"}) == []
    assert "with 3 seeds a method, a percentile bootstrap's interval is narrow" in lines[1]
    # a cell shorter than the budget is not averaged over fewer env steps
    short = [("fetch_pick_and_place_pas: PAS", "pas", 800, low[:, :100])]
    assert fetch_ranking.scores(short) == {}
    (kept,) = fetch_ranking.scores([("fetch_pick_and_place_pas: PAS", "pas", 800, low)]).values()
    assert kept.shape == (3, 125)


def test_a_cell_is_charged_the_build_of_the_library_it_searches_with(tmp_path, monkeypatch):
    """FetchPush's cells search with the push library, not SL1_fetch: its manifest is the one
    read for their build cost, and its table joins the section once it is built."""
    pnp, push = (
        fetch_claims.library_used("fetch_pick_and_place_sl"),
        fetch_claims.library_used("fetch_push_sl"),
    )
    for (name, path), library in ((pnp, "SL1_fetch"), (push, "SL_fetch_push")):
        assert name == library and path.resolve() == fetch_library.manifests()[library]
    assert fetch_claims.library_used("fetch_push_her") is None
    built = tmp_path / "manifest.json"
    manifest = {
        "commit": "0123456789",
        "skill_success": {"fetch_push_block": 0.9},
        "models": {
            "fetch_push_block": {
                "memory_error_cm": 1.0,
                "model_error_cm": 1.0,
                "goal_error_cm": 2.0,
                "classifier_auc": 0.9,
            }
        },
        "env_steps": {"train": {"fetch_push_block": 800}, "collect": {"fetch_push_block": 1000}},
    }
    built.write_text(json.dumps(manifest))
    monkeypatch.setattr(fetch_claims, "library_used", lambda name: ("SL_fetch_push", built))
    assert fetch_claims.library_cost("fetch_push_sl") == 1800
    missing = {"SL1_fetch": tmp_path / "no.json", "SL_fetch_push": built}
    monkeypatch.setattr(fetch_library, "manifests", lambda: missing)
    lines = fetch_library.library_tables()
    assert lines[0].startswith("No skill library SL1_fetch of Fetch")
    assert any(line.startswith("The skill library SL_fetch_push of Fetch") for line in lines)
    # a library at another directory that a stored cell used, each one once
    smaller = tmp_path / "small" / "manifest.json"
    smaller.parent.mkdir()
    smaller.write_text(json.dumps(manifest))
    twice = fetch_library.library_tables([("SL1_fetch", smaller), ("SL1_fetch", smaller)])
    titles = [line for line in twice if line.startswith("The skill library")]
    assert len(titles) == 2 and "small" in titles[1]


def test_a_headlines_matched_baseline_is_fresh_even_when_it_extends_a_tuning_file():
    assert fetch_claims.fresh("headline_fetch_push_her")  # named by headline_fetch_push
    assert fetch_claims.fresh("headline_fetch_push_fast_no_library")  # a headline by extends
    assert not fetch_claims.fresh("fetch_push_her") and not fetch_claims.fresh("no_such_one")
    # run further from a headline's baseline on its fresh seeds: fresh too
    assert fetch_claims.fresh("headline_fetch_pick_and_place_her_1m")
    assert fetch_claims.fresh("headline_fetch_push_her_500k")
    # a diagnostic on seed 0 is said to have run on a tuning seed
    assert "ran on the tuning seeds 0-0" in fetch_claims._caveats("fetch_push_her_mrl")


def test_against_a_published_figure_the_reading_error_and_the_librarys_build_count():
    at = np.zeros((3, 100))
    at[:, 40:] = 1.0  # reaches 0.9 at epoch 45 on every seed: 36,000 env steps
    read = fetch_claims.read_error()
    _, verdict = fetch_claims._against(at, 800, 36_000 + read + 800)
    assert verdict.startswith("ahead of")
    _, verdict = fetch_claims._against(at, 800, 36_000 + read // 2)  # within the reading
    assert verdict.startswith("level with")
    shown, verdict = fetch_claims._against(at, 800, 36_000 + read // 2, offset=300_000)
    assert shown == "[95 % interval 336,000, 336,000]" and verdict.startswith("behind")


def test_a_gap_to_a_published_figure_is_qualified_until_our_ddpg_her_reproduces_it():
    fast = np.zeros((3, 700))
    fast[:, 40:] = 1.0
    slow, quick = np.full((1, 700), 0.5), np.zeros((1, 700))
    quick[:, 300:] = 1.0  # at mrl's budget, 0.9 at 244,000 env steps: reproduced
    mine = [("fetch_push_sl", "fetch_push", 800, fast)]
    (line,) = fetch_claims.shortfalls([*mine, ("fetch_push_her_mrl", "fetch_push", 800, slow)])[1:2]
    assert "Our own DDPG+HER has not reproduced that figure on FetchPush (below)" in line
    (line,) = fetch_claims.shortfalls([*mine, ("fetch_push_her_mrl", "fetch_push", 800, quick)])[
        1:2
    ]
    assert "has not reproduced" not in line and "has not run" not in line


def test_the_peers_evaluation_starts_differ_across_epochs_and_seeds():
    import runpy
    from pathlib import Path

    script = Path(__file__).resolve().parents[2] / "benchmarks" / "peer_sb3_fetch.py"
    peer = runpy.run_path(str(script))
    starts = [s for seed in range(3) for e in range(1, 126) for s in peer["eval_seeds"](seed, e)]
    assert len(starts) == len(set(starts)) == 3 * 125 * 20
