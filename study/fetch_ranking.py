"""The thesis's ranking on Fetch (issue #45): DDPG+HER+SL above PAS and MPAS, and those above
DDPG+HER, in the mean eval success over the first 100,000 task env steps of
FetchPickAndPlace, from the stored tuning cells (seeds 0-2) of each method at the same
budget (PAS and MPAS: their own meta-controllers over the same library). A rank holds when
the upper method's 95 % interval of that mean lies entirely above the lower's (the
report's "faster" rule); it is reversed when the interval lies entirely below; otherwise
our data does not show it."""

from __future__ import annotations

import numpy as np

from mjx_skills.analysis import stats
from mjx_skills.methods import get
from study.claims import seeds
from study.sections import table

EXPERIMENTS = ("fetch_pick_and_place_sl", "fetch_pick_and_place_pas", "fetch_pick_and_place_her")
"""The tuning cells of each method on FetchPickAndPlace, seeds 0-2, 250 epochs."""
BUDGET = 100_000
"""Task env steps over which the mean is taken (the issue's)."""
RANKS = (
    ("ddpg_her_sl", "pas"),
    ("ddpg_her_sl", "mpas"),
    ("pas", "ddpg_her"),
    ("mpas", "ddpg_her"),
)
"""(upper, lower) pairs of the thesis's ranking."""


def scores(ours) -> dict[str, np.ndarray]:
    """method -> (seeds, epochs) eval success over the first BUDGET env steps, from the
    cells of EXPERIMENTS among `ours`: (label, method, env steps per epoch, (seeds, epochs)
    success) of the Fetch section's stored cells (a label: its experiment, then any colon).
    A cell shorter than BUDGET is left out (its mean would cover fewer env steps)."""
    return {
        method: s[:, : BUDGET // per]
        for label, method, per, s in ours
        if label.split(":")[0] in EXPERIMENTS and s.shape[1] * per >= BUDGET
    }


def verdict(upper: np.ndarray, lower: np.ndarray) -> str:
    """'holds', 'reversed' or 'not shown' for 'upper above lower' ((seeds, epochs) each)."""
    _, up_lo, up_hi = stats.summarize(upper).auc
    _, low_lo, low_hi = stats.summarize(lower).auc
    if up_lo > low_hi:
        return "holds"
    return "reversed" if up_hi < low_lo else "not shown"


def section(found: dict[str, np.ndarray]) -> list[str]:
    """The ranking's table and one sentence per rank from `scores`' dict; [] while any of its
    cells is missing."""
    if not all(m in found for pair in RANKS for m in pair):
        return []
    order = sorted(found, key=lambda m: -found[m].mean())
    rows = []
    for m in order:
        point, low, high = stats.summarize(found[m]).auc
        rows.append([get(m).label, f"{len(found[m])}", f"{point:.2f} [{low:.2f}, {high:.2f}]"])
    said = [f"{get(a).label} above {get(b).label}: {verdict(found[a], found[b])}" for a, b in RANKS]
    return [
        "",
        "The thesis's ranking on FetchPickAndPlace (the tuning cells, seeds 0-2, the same "
        "task, starts, evaluation and budget; DDPG+HER+SL and DDPG+HER share this project's "
        "default learner, PAS and MPAS are their own meta-controllers over the same skill "
        f"library, at their default options): the mean eval success over the first "
        f"{BUDGET:,} env steps [95 % interval]. A rank holds when the upper interval lies "
        f"entirely above the lower: with {seeds(min(len(s) for s in found.values()))} a "
        "method, a percentile bootstrap's interval is narrow, so a rank that holds here is "
        "weak evidence, and between two methods near 0 it says little of either.",
        "",
        *table(["method", "seeds", f"mean success, first {BUDGET:,} env steps"], rows),
        "",
        "; ".join(said) + ".",
    ]
