"""Two cubes with the one-cube skill library used as it is (beyond the thesis): the report's
section on `experiments/two_objects.toml`, computed from the stored cells."""

from __future__ import annotations

import numpy as np

from mjx_skills.analysis import stats
from study.claims import LABEL, MEASURED, ci, measured

EXPERIMENT = "two_objects"
FAST = "two_objects_fast"
"""DDPG+HER+SL+Fast on two_in_container, a shorter budget (its own experiment)."""
VARIANTS = {
    "two_objects_fast_reward": "step-wise reward",
    "two_objects_fast_goal_start": "step-wise reward, goal starts 0.5",
    "two_objects_fast_pick_move_two": "step-wise reward",
    "two_objects_fast_goal_start_clear": "step-wise reward, goal starts 0.5, clear goals",
    "two_objects_fast_in_order": "step-wise reward, goal starts 0.5, clear goals, in order",
    "two_objects_fast_deep_sets": "step-wise reward, goal starts 0.5, clear goals, deep sets",
}
"""DDPG+HER+SL+Fast on two_in_container with the options of docs/simulation.md (their own
experiments), by experiment: what the method column adds to the method's name."""
EXPERIMENTS = (EXPERIMENT, FAST, *VARIANTS)
TITLE = "Beyond the thesis: two cubes, the one-cube skill library used as it is"
TARGET = ("two_in_container", 0.8, ("ddpg_her_sl", "mpas", "ddpg_her_sl_fast"))
"""(task, the last-5 mean one of these methods must reach, the methods)."""
INTRO = (
    "`experiments/two_objects.toml`: every method on the two-cube tasks through the same "
    "trainer, and DDPG+HER+SL+Fast with its second default (eps over 5 epochs to 0.1, the "
    "pick also in training) on two_in_container (`experiments/two_objects_fast.toml`, "
    "a shorter budget; with the step-wise reward and goal starts of docs/simulation.md in "
    "`two_objects_fast_reward.toml` and `two_objects_fast_goal_start.toml`; on pick_move_two "
    "with the step-wise reward in `two_objects_fast_pick_move_two.toml`; with the step-wise "
    "reward, goal starts and clear goals (each cube's goal, as the explorer and the pick aim "
    "it, moved 5 cm clear of the other cube: `--search.goal-clearance 0.05`, docs/methods.md) "
    "in `two_objects_fast_goal_start_clear.toml`; with the explorers working on the cubes in "
    "one order besides, the first not at its goal (`--search.in-order`), in "
    "`two_objects_fast_in_order.toml`; with the step-wise reward, goal starts, clear goals and "
    "actor and critic as deep sets over the cubes' views (`--ddpg.architecture deep_sets`) "
    "in `two_objects_fast_deep_sets.toml`), "
    "the skill library "
    "SL1 trained with one cube and not retrained (its skills act on either cube through the "
    "scene's projection, docs/methods.md). Success needs both "
    "cubes at their goals; 'cubes at their goals' is the share of the two cubes there at "
    "the end of the evaluation episodes (0.5: one of two), which says which stage fails; "
    "'training success, first 5 epochs' is what the behaviour itself achieves while a library "
    "method's exploration is at its strongest."
)
NEAR_ZERO = 0.1
"""DDPG+HER 'stays near 0' below this last-5 mean (the report's 'fails' rule)."""

HEADER = [
    "task",
    "method",
    *MEASURED,
    "cubes at their goals, last 5 [95 % CI]",
    "training success, first 5 epochs",
    "min",
]


def cubes(r, cell) -> stats.Summary:
    """The share of cubes at their goals at the end of the evaluation episodes (`eval_cubes`:
    1/2 where one of two got there), summarised as eval success is."""
    return stats.summarize(stats.scores_from_rows(r.metrics[cell.name], "eval_cubes"))


def explored(r, cell, epochs: int = 5) -> float:
    """The training episodes' success over the first `epochs` epochs (mean over seeds): what
    the explorer itself achieves while eps is near 1."""
    return float(
        np.mean([m["train_success"] for m in r.metrics[cell.name] if m["epoch"] <= epochs])
    )


def rows(r) -> list[list[str]]:
    """One row per cell of the grid, from `results.Results` r."""
    out = []
    for experiment in EXPERIMENTS:
        for cell, s in r.cells[experiment]:
            out.append(_row(r, cell, s, _name(cell.method, experiment)))
    return out


def _name(method: str, experiment: str) -> str:
    """The method's label, with its variant's where the experiment is one (`VARIANTS`)."""
    return f"{LABEL[method]} ({VARIANTS[experiment]})" if experiment in VARIANTS else LABEL[method]


def _row(r, cell, s, name: str) -> list[str]:
    if s is None:
        return [cell.task, name, "not run yet", "", "", "", "", "", ""]
    return [
        cell.task,
        name,
        *measured(s),
        ci(cubes(r, cell).last),
        f"{explored(r, cell):.2f}",
        f"{s.wall_s / 60:.0f}",
    ]


def dashed(r, task: str) -> list[tuple]:
    """The figure's dashed curves on `task`: (cell, summary, variant, True) of every cell of
    DDPG+HER+SL+Fast's experiments (each variant gets its own colour)."""
    return [
        (c, s, VARIANTS.get(e, ""), True)
        for e in EXPERIMENTS[1:]
        for c, s in r.cells[e]
        if c.task == task
    ]


def colour(variant: str) -> int:
    """A variant's colour, after the methods': the first experiment holding it (`VARIANTS`)."""
    return list(VARIANTS.values()).index(variant)


def _runs(r, task: str, methods) -> list[tuple[str, str, object]]:
    """(method, name, Summary) of every cell run of `methods` on `task` in `EXPERIMENTS`."""
    out = []
    for experiment in EXPERIMENTS:
        for method in methods:
            try:
                s = r.get(experiment, task, method)
            except KeyError:  # not part of that experiment
                continue
            if s is not None:
                out.append((method, _name(method, experiment), s))
    return out


def verdict(r) -> list[str]:
    """The issue's bar on two_in_container, in one sentence from the data (over the cells
    run so far, naming those not run yet)."""
    task, level, methods = TARGET
    flat = r.get(EXPERIMENT, task, "ddpg_her")
    done = _runs(r, task, methods)
    if flat is None or not done:
        return [
            f"The bar on {task} (last 5 >= {level} for {' or '.join(LABEL[m] for m in methods)}"
            ", DDPG+HER near 0): not all its cells are run yet."
        ]
    _, best, s = max(done, key=lambda run: run[2].last[0])
    met = s.last[0] >= level and flat.last[0] < NEAR_ZERO
    missing = [LABEL[m] for m in methods if m not in {method for method, _, _ in done}]
    later = f" ({', '.join(missing)}: not run yet)" if missing else ""
    return [
        f"The bar on {task}: last 5 >= {level} for "
        f"{' or '.join(LABEL[m] for m in methods)} while DDPG+HER stays below {NEAR_ZERO}. "
        f"Best: {best}, {ci(s.last)}; DDPG+HER {ci(flat.last)}: "
        f"**{'met' if met else 'not met'}**{later}."
    ]
