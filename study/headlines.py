"""The headlines on fresh seeds: every experiment with `role = "headline"` and a `target`,
read from its stored cell, refused if the cell ran on a tuning seed (`seeds.check_headline`),
and set against its matched baseline (`baseline = ...`, the same seeds) with the statistics
rliable recommends for few runs (Agarwal et al. 2021): interquartile means with stratified
bootstrap 95 % intervals, and the probability of improvement with its interval."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mjx_skills.analysis import stats
from mjx_skills.core.files import read_json
from mjx_skills.sweeps import cells
from mjx_skills.sweeps.experiment_file import names, raw
from mjx_skills.sweeps.experiments import Experiment, load_experiment
from mjx_skills.sweeps.seeds import check_headline, describe, seed_range
from study.sections import table

INTRO = (
    "Each headline is reported on seeds that no tuning run used (every default was chosen "
    "on seeds 0-4; a stored cell on a tuning seed is refused here), against a matched "
    "baseline: the same learner on the same seeds with the library's part removed. "
    "**reaches the level at** = the first epoch at which the 5-epoch rolling mean of the "
    "seeds' mean reaches the target's level [95 % interval: whole seeds' curves resampled]; "
    "**IQM** = the interquartile mean over seeds [95 % stratified bootstrap interval, rliable] "
    "of each seed's mean over the 5 epochs ending at the target's epoch, or over its last 5; "
    "**P(headline > baseline)** = the probability that a seed of the headline scores above a "
    "seed of the baseline [95 % interval], meaningful when the interval's low end is above 0.5. "
    "The target is **met** when the level is reached by the target's epoch."
)
HEADER = ["measure", "headline", "matched baseline", "P(headline > baseline)"]


def experiments() -> list[Experiment]:
    """The headline experiments (with a target), in name order. Only those are loaded: a
    file of a user's task that needs `--import` does not stop the report."""
    wanted = [n for n in names() if raw(n).get("role") == "headline" and raw(n).get("target")]
    return [load_experiment(name) for name in wanted]


def stored_scores(exp: Experiment, store: Path) -> np.ndarray | None:
    """(seeds, epochs) eval success of `exp`'s one stored cell; None while it is not run.
    ValueError if the experiment has several cells, or its cell ran on a tuning seed."""
    found = exp.cells()
    if len(found) != 1:
        raise ValueError(f"headline {exp.name}: one cell per headline, got {len(found)}")
    where = cells.stored(found[0], store)
    if where is None:
        return None
    check_headline(found[0].name, read_json(where / "definition.json"))
    return stats.scores_from_rows(cells.read_stored_metrics(where))


def _reach(scores: np.ndarray, level: float) -> str:
    hit = stats.first_reaching(scores.mean(axis=0), level)
    low, high = stats.reach_interval(scores, level)
    show = lambda e: "never" if e is None else str(e)  # noqa: E731
    return f"{show(hit)} [{show(low)}, {show(high)}]"


def _iqm(values: np.ndarray) -> str:
    point, low, high = stats.iqm_interval(values)
    return f"{point:.2f} [{low:.2f}, {high:.2f}]"


def _p(x: np.ndarray, y: np.ndarray) -> str:
    point, low, high = stats.improvement(x, y)
    return f"{point:.2f} [{low:.2f}, {high:.2f}]"


def report(exp: Experiment, store: Path = cells.STORE) -> list[str]:
    """One headline's markdown: its table against the matched baseline and its verdict."""
    level, epoch = exp.target["level"], exp.target["epoch"]
    seeds = describe(seed_range(exp.seed, exp.seeds))
    lines = [f"### {exp.name}: {exp.description}", ""]
    ours = stored_scores(exp, store)
    base_exp = load_experiment(exp.baseline) if exp.baseline else None
    if base_exp is not None and (base_exp.seed, base_exp.seeds) != (exp.seed, exp.seeds):
        raise ValueError(f"headline {exp.name}: its baseline {exp.baseline} runs other seeds")
    base = stored_scores(base_exp, store) if base_exp is not None else None
    short = [e.name for e in (exp, base_exp) if e is not None and e.epochs < epoch]
    if epoch < stats.WINDOW or short:
        raise ValueError(
            f"headline {exp.name}: its target epoch {epoch} needs a full {stats.WINDOW}-epoch "
            f"window and every cell to run that long ({', '.join(short) or 'too early'})"
        )
    run = lambda name: f"`python -m mjx_skills.sweep --experiment {name}`"  # noqa: E731
    if ours is None:
        return [*lines, f"Not run yet on seeds {seeds}: {run(exp.name)}."]
    window = slice(epoch - stats.WINDOW, epoch)
    at, last = (lambda s: s[:, window].mean(axis=1)), (lambda s: s[:, -stats.LAST :].mean(axis=1))
    rows = [[f"reaches {level} at epoch", _reach(ours, level), "-", "-"]]
    if base is not None:
        rows[0][2] = _reach(base, level)
    for label, pick in ((f"IQM, epochs {epoch - 4}-{epoch}", at), ("IQM, last 5 epochs", last)):
        row = [label, _iqm(pick(ours)), "-", "-"]
        if base is not None:
            row[2:] = [_iqm(pick(base)), _p(pick(ours), pick(base))]
        rows.append(row)
    hit = stats.first_reaching(ours.mean(axis=0), level)
    verdict = "met" if hit is not None and hit <= epoch else "missed"
    pending = []
    if base_exp is not None and base is None:
        rows = [[*row[:2], "not run yet", "-"] for row in rows]
        pending = [f"The matched baseline is not run yet: {run(base_exp.name)}."]
    return [
        *lines,
        *table(HEADER, rows),
        "",
        f"**Target** ({level} by epoch {epoch}, seeds {seeds}): **{verdict}**. "
        + _widths(ours, base, at, last, len(ours))
        + ("" if verdict == "met" else " " + plateau(ours, level)),
        *pending,
    ]


NEAR = 0.05
"""How close to a missed target's level the rolling mean must come for `plateau` to
describe the curve after it."""


def plateau(scores: np.ndarray, level: float) -> str:
    """Where a missed target's curve went, from (seeds, epochs) scores: the epoch at which
    the 5-epoch rolling mean of the seeds' mean first came within NEAR of `level`, and the
    range and mean of that rolling mean from there to the last epoch, saying whether `level`
    lies inside the range or above it; its peak if it never came that close ('' for a run
    shorter than 5 epochs)."""
    curve = scores.mean(axis=0)
    rolling = stats.rolling_mean(curve)
    near = stats.first_reaching(curve, level - NEAR)
    name = "The headline's 5-epoch rolling mean of the seeds' mean"
    if near is None:
        if not len(rolling):
            return ""
        top = int(np.argmax(rolling))
        return f"{name} peaks at {rolling[top]:.2f} (epoch {top + stats.WINDOW})."
    after = rolling[near - stats.WINDOW :]
    low, high = after.min(), after.max()
    text = (
        f"{name} comes within {NEAR} of {level} at epoch {near} and from there to its last "
        f"epoch ({scores.shape[1]}) ranges over [{_beside(low, level)}, {_beside(high, level)}], "
        f"mean {_beside(after.mean(), level)}"
    )
    if high < level:
        return text + f": below {level} throughout."
    return text + (f": {level} lies inside that band." if low < level else ".")


def _beside(value: float, level: float) -> str:
    """`value` at 2 decimals, or at 3 where 2 would round it onto the other side of `level`
    or onto it (0.897 beside 0.9 reads 0.897, not 0.90)."""
    two = f"{value:.2f}"
    crosses = (value < level) != (float(two) < level)
    return f"{value:.3f}" if crosses else two


def _widths(ours, base, at, last, n: int) -> str:
    """How wide the IQM intervals are with `n` seeds (as printed, 2 decimals), and (with the
    baseline in) the matched baseline's last-5 IQM beside the headline's."""
    at_ours, last_ours = stats.iqm_interval(at(ours)), stats.iqm_interval(last(ours))
    width = lambda i: round(i[2], 2) - round(i[1], 2)  # noqa: E731
    text = (
        f"With {n} seeds the IQM intervals are {width(at_ours):.2f} (at the target's epoch) "
        f"and {width(last_ours):.2f} (last 5) wide"
    )
    if base is None:
        return text + "."
    kept = stats.iqm_interval(last(base))[0]
    return (
        text + f"; without the library's part, the same learner's last-5 IQM is {kept:.2f} "
        f"against the headline's {last_ours[0]:.2f}."
    )


def section(store: Path = cells.STORE) -> list[str]:
    """The report's headline section: the intro, then each headline."""
    out = [INTRO]
    for exp in experiments():
        out += ["", *report(exp, store)]
    return out
