"""The learners' gradient budget beside the published DDPG+HER (study/fetch_budget.py):
transitions per env step read from an experiment's config and from the data file."""

from __future__ import annotations

import numpy as np
import pytest

from study import fetch_budget

MRL = {"source": "mrl", "batch_size": 2000, "env_steps_per_update": 2}


def test_our_budget_is_read_from_the_experiments_config():
    # fetch_push_her: 2 envs x 50-step episodes a cycle, 40 updates of 256 after each.
    assert fetch_budget.ours("fetch_push_her") == (256 * 40 / 100, 256, 40, 100)
    # its one-env diagnostic: the same updates after one episode, twice the budget
    per, *_ = fetch_budget.ours("fetch_push_her_1env: DDPG+HER")
    assert per == 2 * fetch_budget.ours("fetch_push_her")[0]
    assert fetch_budget.ours("fetch_pick_and_place_sl") is None  # not DDPG+HER
    # a label names its cell's method: PAS's and MPAS's cells of one experiment are not DDPG+HER
    assert fetch_budget.ours("fetch_pick_and_place_pas: MPAS") is None
    assert fetch_budget.ours("fetch_push_her_1env: PAS") is None  # no such cell there
    assert fetch_budget.ours("no_such_experiment") is None


def test_the_sentence_sets_both_budgets_side_by_side():
    said = fetch_budget.sentence("fetch_push_her", MRL)
    assert "fetch_push_her's learner samples 102 transitions (40 updates of 256 per 100" in said
    assert "published one (mrl) samples 1000 (batch 2000, an update every 2 env steps), 10" in said
    assert fetch_budget.sentence("fetch_push_her", {"source": "x"}) == ""  # no learner given
    assert fetch_budget.sentence("fetch_pick_and_place_sl", MRL) == ""


FIGURE = {**MRL, "method": "DDPG w/ HER", "env_steps": 350_000}


def test_the_reproduction_lists_the_ddpg_her_cells_longest_first_with_a_verdict():
    low, high = np.full((3, 10), 0.1), np.full((3, 12), 0.2)
    mine = [("fetch_push_sl", 800, np.ones((3, 10))), ("fetch_her", 800, low)]
    mine.append(("fetch_push_her", 800, high))
    said = fetch_budget.reproduction("FetchPush", mine, FIGURE, 0.9)
    assert said.startswith("DDPG+HER's reproduction on FetchPush: DDPG w/ HER (mrl) reaches")
    assert "sampling 1000 transitions per env step; ours: fetch_push_her (3 seeds, 102" in said
    assert said.index("fetch_push_her (") < said.index("fetch_her (")  # the longer first
    assert "fetch_push_sl" not in said  # a library cell is not DDPG+HER
    assert "ends at a last-5 mean of 0.20 after 9,600 env steps (never 0.9)" in said
    assert "Not tested yet: no cell ran to the published 350,000 env steps." in said
    assert "No cell has run at the published learner's" in said
    assert fetch_budget.reproduction("FetchPush", mine[:1], FIGURE, 0.9) == ""


def test_a_cell_at_the_published_budget_that_falls_short_says_the_budget_does_not_explain_it():
    short = np.full((1, 450), 0.5)
    said = fetch_budget.reproduction("FetchPush", [("fetch_push_her_mrl", 800, short)], FIGURE, 0.9)
    assert "fetch_push_her_mrl (1 seed, 1000 transitions per env step)" in said
    assert "Not reproduced yet: fetch_push_her_mrl (1 seed) ran 360,000 env steps, past" in said
    assert "(the allowance, 1.5 times, runs to 525,000)" in said
    assert (
        "fetch_push_her_mrl samples the published learner's transitions per env step and " in said
    )
    assert "has not reached it so far (1 seed): the gradient budget alone has not closed" in said
    long = [("fetch_push_her_mrl", 800, np.full((1, 700), 0.5))]  # past the allowance
    said = fetch_budget.reproduction("FetchPush", long, FIGURE, 0.9)
    assert "still falls short (1 seed;" in said and "does not explain the gap" in said


def test_the_verdict_is_the_published_budgets_cell_not_a_longer_one_at_another_budget():
    at_mrl = ("fetch_push_her_mrl", 800, np.full((1, 450), 0.5))  # 360k at mrl's budget
    longer = ("fetch_push_her", 800, np.full((3, 700), 0.2))  # 560k at a tenth of it
    said = fetch_budget.reproduction("FetchPush", [longer, at_mrl], FIGURE, 0.9)
    assert said.index("fetch_push_her_mrl (") < said.index("fetch_push_her (3 seeds")
    assert "Not reproduced yet: fetch_push_her_mrl (1 seed) ran 360,000" in said


def test_a_cell_that_repeats_a_longer_ones_first_epochs_is_named_in_its_entry():
    curve = np.linspace(0.0, 0.8, 660)[None]
    mine = [("fetch_push_her_mrl", 800, curve[:, :450]), ("fetch_push_her_mrl_long", 800, curve)]
    said = fetch_budget.reproduction("FetchPush", mine, FIGURE, 0.9)
    assert said.count("(1 seed, 1000 transitions per env step)") == 1
    assert "(never 0.9; its first epochs repeat fetch_push_her_mrl's bit for bit)" in said
    assert "Not reproduced: fetch_push_her_mrl_long (1 seed) ran 528,000 env steps, 1.5" in said
    changed = curve[:, :450].copy()
    changed[0, 10] += 0.01  # not the same run: both are evidence
    said = fetch_budget.reproduction(
        "FetchPush", [(mine[0][0], 800, changed), mine[1]], FIGURE, 0.9
    )
    assert said.count("(1 seed, 1000 transitions per env step)") == 2


def test_reaching_the_level_within_the_allowed_multiple_reproduces_and_later_does_not():
    def reaching_at(epoch):
        s = np.zeros((3, 800))
        s[:, epoch:] = 1.0
        return [("fetch_push_her", 800, s)]

    within = int(fetch_budget.REPRODUCED_WITHIN * 350_000 / 800) - 10
    said = fetch_budget.reproduction("FetchPush", reaching_at(within), FIGURE, 0.9)
    assert "Reproduced by fetch_push_her (3 seeds; within" in said and "explain" not in said
    said = fetch_budget.reproduction("FetchPush", reaching_at(within + 20), FIGURE, 0.9)
    # ones from epoch within + 21 (1-based): the rolling mean of 5 is 1 at epoch within + 25
    at = (within + 25) * 800
    assert f"Not reproduced: fetch_push_her (3 seeds) reaches 0.9 at {at:,} env steps, past" in said
    assert f"(reaches 0.9 at {at:,})" in said  # the entry and the verdict agree


def test_a_cell_past_the_allowance_without_the_level_is_not_reproduced():
    long = [("fetch_push_her_mrl", 800, np.full((1, 700), 0.5))]  # 560,000 > 1.5 x 350,000
    said = fetch_budget.reproduction("FetchPush", long, FIGURE, 0.9)
    assert "Not reproduced: fetch_push_her_mrl (1 seed) ran 560,000 env steps, 1.5 times" in said


def test_a_cell_beside_the_one_its_experiment_extends_says_what_it_changes():
    # fetch_push_her_mrl_ln extends fetch_push_her_mrl and sets LayerNorm on, nothing else
    beside = {"fetch_push_her_mrl"}
    assert fetch_budget.unlike("fetch_push_her_mrl_ln", beside) == (
        "; as fetch_push_her_mrl but ddpg.layer_norm True"
    )
    eight = fetch_budget.unlike("fetch_push_her_mrl_8env", {"fetch_push_her_mrl_ln"})
    assert eight == (
        "; as fetch_push_her_mrl_ln but train.cycles 2, train.envs 8, train.updates_per_cycle 200"
    )  # its 250 epochs (450 there) are said in its entry, not here
    assert fetch_budget.unlike("fetch_push_her_mrl_ln", {"fetch_push_her"}) == ""  # not beside
    assert fetch_budget.unlike("fetch_her", {"fetch_push_her"}) == ""  # extends nothing
    short = np.full((1, 450), 0.5)
    mine = [("fetch_push_her_mrl", 800, short), ("fetch_push_her_mrl_ln", 800, short + 0.1)]
    said = fetch_budget.reproduction("FetchPush", mine, FIGURE, 0.9)
    assert (
        "fetch_push_her_mrl_ln (1 seed, 1000 transitions per env step; as fetch_push_her_mrl"
        in said
    )


def test_the_published_learners_settings_follow_the_verdict_where_the_data_file_gives_them():
    mine = [("fetch_push_her_mrl", 800, np.full((1, 450), 0.5))]
    said = fetch_budget.reproduction("FetchPush", mine, {**FIGURE, "learner": "3 x 512"}, 0.9)
    assert said.split("(the allowance, 1.5 times, runs to 525,000).")[1].startswith(
        " The published learner: 3 x 512."
    )
    assert "published learner:" not in fetch_budget.reproduction("FetchPush", mine, FIGURE, 0.9)


def test_published_figures_carry_their_sources():
    """study/published/fetch_her.toml: every figure names its source, a link to the plot it
    was read from and that repository's commit, the env with its version, the method and its
    setting, and a level and env steps that can be set beside ours; the learner's gradient
    budget and settings where the source gives them."""
    import re
    import tomllib
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "study" / "published" / "fetch_her.toml"
    figures = tomllib.loads(path.read_text())["figure"]
    assert figures
    for f in figures:
        keys = {"source", "url", "commit", "env", "method", "setting", "level", "env_steps"}
        learner = {"batch_size", "env_steps_per_update"}  # the gradient budget, both or none
        # `learner` (the published learner's settings in words) only beside its budget
        assert set(f) - {"learner", "relabelling"} in (keys, keys | learner), f
        assert "learner" not in f or learner <= set(f), f
        assert "relabelling" not in f or "learner" in f, f  # it completes a learner's text
        assert all(f.get(k, 1) >= 1 for k in learner), f
        assert f["url"].startswith("https://github.com/") and f["url"].endswith(".png")
        assert re.fullmatch(r"[0-9a-f]{7,40}", f["commit"])
        assert re.fullmatch(r"Fetch(Reach|Push|Slide|PickAndPlace)-v\d", f["env"])
        assert 0 < f["level"] <= 1 and 0 < f["env_steps"] <= 10_000_000


def test_a_figures_learner_is_the_text_its_name_has_in_the_learners_table():
    """The learners' settings stand once in the data file (`[learners]`) and each figure names
    one; `published` gives the figure that text, and a name the table lacks is a KeyError
    naming those it has."""
    from study import fetch_claims

    with_learner = [f for f in fetch_claims.published() if "learner" in f]
    assert with_learner and all(" x 512" in f["learner"] for f in with_learner)
    figure = '[[figure]]\nmethod = "m"\nenv = "FetchPush-v4"\nlearner = "{}"\n'
    table = '[learners]\nmine = "3 x 256, batch 2000"\n\n'
    (one,) = fetch_claims.published(table + figure.format("mine"))
    assert one["learner"] == "3 x 256, batch 2000"
    with pytest.raises(KeyError, match=r"learner 'theirs'.*\['mine'\]"):
        fetch_claims.published(table + figure.format("theirs"))


def test_a_figures_relabelling_completes_its_learners_text():
    from study import fetch_claims

    figure = '[[figure]]\nmethod = "m"\nenv = "FetchPush-v4"\nlearner = "mine"\n'
    table = '[learners]\nmine = "3 x 256"\n\n'
    (one,) = fetch_claims.published(table + figure + 'relabelling = "then 4 in 5"\n')
    assert one["learner"] == "3 x 256, then 4 in 5" and "relabelling" not in one
    by_method = {f["method"]: f["learner"] for f in fetch_claims.published()}
    assert "future_4" in by_method["DDPG w/ HER"]
    assert "futureactual_2_2" in by_method["DDPG w/ HER+FA"]


def test_a_cell_drawing_actual_goals_is_set_against_her_fa_and_no_other():
    from study import fetch_claims

    assert fetch_budget.relabelling("fetch_push_her_mrl") == "DDPG w/ HER"
    assert fetch_budget.relabelling("fetch_push_her_mrl_goals") == "DDPG w/ HER+FA"
    assert fetch_budget.relabelling("fetch_pick_and_place_sl") is None
    ours = [
        ("fetch_push_her_mrl", "fetch_push", 800, np.full((1, 450), 0.5)),
        ("fetch_push_her_mrl_goals", "fetch_push", 800, np.full((1, 250), 0.3)),
    ]
    said = [s for s in fetch_claims.shortfalls(ours) if "reproduction" in s]
    plain, fa = said
    assert plain.startswith("DDPG+HER's reproduction on FetchPush: DDPG w/ HER (mrl")
    assert "fetch_push_her_mrl (" in plain and "fetch_push_her_mrl_goals" not in plain
    assert fa.startswith("DDPG+HER's reproduction on FetchPush: DDPG w/ HER+FA (mrl")
    assert "reaches 0.9 at 249,000" in fa
    assert "fetch_push_her_mrl_goals (" in fa and "fetch_push_her_mrl (" not in fa
    assert "futureactual_2_2" in fa and "future_4" not in fa


def test_a_relabelling_without_a_learner_is_refused():
    from study import fetch_claims

    figure = '[[figure]]\nmethod = "m"\nenv = "FetchPush-v4"\nrelabelling = "then 4 in 5"\n'
    with pytest.raises(KeyError, match="relabelling but no learner"):
        fetch_claims.published(figure)
