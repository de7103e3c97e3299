"""The learners' gradient budget beside the published DDPG+HER (study/fetch_budget.py):
transitions per env step read from an experiment's config and from the data file."""

from __future__ import annotations

import numpy as np

from study import fetch_budget

MRL = {"source": "mrl", "batch_size": 2000, "env_steps_per_update": 2}


def test_our_budget_is_read_from_the_experiments_config():
    # fetch_push_her: 2 envs x 50-step episodes a cycle, 40 updates of 256 after each.
    assert fetch_budget.ours("fetch_push_her") == (256 * 40 / 100, 256, 40, 100)
    # its one-env diagnostic: the same updates after one episode, twice the budget
    per, *_ = fetch_budget.ours("fetch_push_her_1env: DDPG+HER")
    assert per == 2 * fetch_budget.ours("fetch_push_her")[0]
    assert fetch_budget.ours("fetch_pick_and_place_sl") is None  # not DDPG+HER
    assert fetch_budget.ours("no_such_experiment") is None


def test_the_sentence_sets_both_budgets_side_by_side():
    said = fetch_budget.sentence("fetch_push_her", MRL)
    assert "fetch_push_her's learner samples 102 transitions (40 updates of 256 per 100" in said
    assert "published one (mrl) samples 1000 (batch 2000, an update every 2 env steps), 10" in said
    assert fetch_budget.sentence("fetch_push_her", {"source": "x"}) == ""  # no learner given
    assert fetch_budget.sentence("fetch_pick_and_place_sl", MRL) == ""


def test_where_a_library_cell_leads_the_best_ddpg_her_cell_is_set_beside_the_published():
    low, high = np.full((3, 10), 0.1), np.full((3, 10), 0.2)
    mine = [("fetch_push_sl", 800, np.full((3, 10), 0.3)), ("fetch_her", 800, low)]
    mine.append(("fetch_push_her", 800, high))
    said = fetch_budget.best_plain(mine, MRL)
    assert said.startswith(" Our best DDPG+HER cell there, fetch_push_her, ends at a last-5")
    assert "0.20 after 8,000 env steps" in said and "samples 102 transitions" in said
    assert fetch_budget.best_plain(mine[:1], MRL) == ""  # no DDPG+HER cell
