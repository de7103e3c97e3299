"""What a Fetch headline's explorer showed its learner (study/fetch_explorer.py), read from
the cell's metrics: training success while the search explored, the frozen policy's success
when it stopped, and the epoch the policy reached the target's level on its own."""

from __future__ import annotations

from mjx_skills.sweeps.experiments import load_experiment
from study import fetch_explorer

HEADLINE = "headline_fetch_pick_and_place"  # DDPG+HER+SL, eps over 30 epochs, target 125


def _rows(epochs: int = 40) -> list[dict]:
    """2 seeds: training success 0.5 and eval 0.1 while the search explores (epochs 1-30),
    then eval 1.0: the rolling mean reaches 0.9 at epoch 35."""
    return [
        {
            "epoch": e,
            "seed": s,
            "train_success": 0.5 if e <= 30 else 0.2,
            "eval_success": 0.1 if e <= 30 else 1.0,
        }
        for e in range(1, epochs + 1)
        for s in (0, 1)
    ]


def test_the_headline_sentence_reads_its_metrics():
    (cell,) = load_experiment(HEADLINE).cells()
    (said,) = fetch_explorer.paragraph([(HEADLINE, cell, _rows())])[1:]
    assert "(eps decaying over epochs 1-30), 0.50 of its training episodes" in said
    assert "succeeded on 0.10 of its evaluations over epochs 26-30" in said
    assert "the policy reached 0.9 at epoch 35 (the target: epoch 125; 100 gradient" in said
    never = [dict(r, eval_success=0.1) for r in _rows()]
    assert "never reached 0.9" in fetch_explorer.paragraph([(HEADLINE, cell, never)])[1]


def test_only_a_ddpg_her_sl_headline_gets_one():
    (tuning,) = load_experiment("fetch_pick_and_place_sl").cells()  # not a headline
    assert fetch_explorer.paragraph([("fetch_pick_and_place_sl", tuning, _rows())]) == []
    (her,) = load_experiment("headline_fetch_pick_and_place_her").cells()  # no explorer
    assert fetch_explorer.paragraph([("headline_fetch_pick_and_place_her", her, _rows())]) == []


def test_the_sentence_names_the_tasks_fast_experiment_and_says_what_it_showed():
    """Each headline names DDPG+HER+SL+Fast's experiment on its own task while none is stored
    (the push headline once named PickAndPlace's), and reads the Fast cell once it is."""
    for headline, fast in [
        (HEADLINE, "fetch_pick_and_place_fast"),
        ("headline_fetch_push", "fetch_push_fast"),
    ]:
        (cell,) = load_experiment(headline).cells()
        (said,) = fetch_explorer.paragraph([(headline, cell, _rows(150))])[1:]
        assert f"is what {fast} measures (not run yet)" in said
        (fast_cell,) = load_experiment(fast).cells()
        rows = [dict(r, eval_success=0.95) for r in _rows(150)]
        rows = [dict(r, eval_success=0.5) if r["epoch"] > 70 else r for r in rows]
        found = [(headline, cell, _rows(150)), (fast, fast_cell, rows)]
        (said,) = fetch_explorer.paragraph(found)[1:]
        # the same epochs as the DDPG+HER+SL sentence's: those before its explorer stops
        end = cell.run_args(out="", progress=False).full_options()["search"].eps_decay_epochs
        assert f"DDPG+HER+SL+Fast ({fast}, seeds 0-2), succeeds on 0.95 over the same" in said
        assert f"epochs {end - 4}-{end} and reaches 0.9 at epoch 5; it differs in" in said
        assert "eps decays over 10 epochs to a floor of 0.03, it takes 400 gradient" in said
        assert "its evaluated policy also acts with the library's skills" in said
        assert "not run yet" not in said


def test_a_fresh_seed_fast_cell_is_the_one_said_before_a_tuning_one():
    (cell,) = load_experiment("headline_fetch_push").cells()
    (tuning,) = load_experiment("fetch_push_fast").cells()
    (fresh,) = load_experiment("headline_fetch_push_fast").cells()
    low = [dict(r, eval_success=0.2) for r in _rows(62)]
    found = [
        ("headline_fetch_push", cell, _rows(150)),
        ("fetch_push_fast", tuning, _rows(62)),
        ("headline_fetch_push_fast", fresh, low),
    ]
    (said,) = fetch_explorer.paragraph(found)[1:]
    assert "(headline_fetch_push_fast, seeds 100-104), succeeds on 0.20" in said


def test_a_fast_cell_that_stops_early_says_its_last_epochs_and_no_baseline_is_read():
    """A Fast cell shorter than the DDPG+HER+SL headline's exploration (here 20 epochs
    against 30; the report once said 'succeeds on nan over epochs 121-125'), and its
    matched baseline (the same method, no library) is not the Fast learner's result."""
    (cell,) = load_experiment(HEADLINE).cells()
    (fresh,) = load_experiment("headline_fetch_pick_and_place_fast").cells()
    (base,) = load_experiment("headline_fetch_pick_and_place_fast_no_library").cells()
    high = [dict(r, eval_success=0.95) for r in _rows(20)]
    low = [dict(r, eval_success=0.05) for r in _rows(20)]
    found = [
        (HEADLINE, cell, _rows(150)),
        ("headline_fetch_pick_and_place_fast_no_library", base, low),
        ("headline_fetch_pick_and_place_fast", fresh, high),
    ]
    (said,) = fetch_explorer.paragraph(found)[1:]
    assert "(headline_fetch_pick_and_place_fast, seeds 100-104), succeeds on 0.95" in said
    assert "over its last epochs 16-20 (it stops at epoch 20) and reaches 0.9 at epoch 5" in said
    assert "the same epochs" not in said
