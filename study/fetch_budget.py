"""The learners' gradient budget beside the published DDPG+HER figures: transitions sampled
per env step (batch size x gradient updates per env step), and whether our DDPG+HER
reproduces the published curve. Ours is read from a DDPG+HER experiment's config; the
published learner's from the data file's settings (`study/published/fetch_her.toml`:
`batch_size` and `env_steps_per_update`, read from the source's configuration). A cell run
at the published budget (`fetch_push_her_mrl`) tests whether the budget is the cause."""

from __future__ import annotations

import numpy as np

from mjx_skills.analysis import stats
from mjx_skills.envs.registry import ENVS
from mjx_skills.sweeps.cells import changes
from mjx_skills.sweeps.experiment_file import names, parent
from mjx_skills.sweeps.experiments import load_experiment
from study.claims import seeds


def ours(name: str) -> tuple[float, int, int, int] | None:
    """(transitions per env step, batch, updates per cycle, env steps per cycle) of the
    DDPG+HER cell of experiment `name` (a label: its experiment before any colon); None
    for another method or an unknown experiment."""
    args = _cell_args(name)
    if args is None:
        return None
    batch = args.full_options()["ddpg"].batch_size
    length = args.env.episode_length or ENVS[args.train.task].default_episode_length
    steps = args.train.envs * length  # one cycle: an episode of each env, then the updates
    updates = args.train.updates_per_cycle
    return batch * updates / steps, batch, updates, steps


def relabelling(name: str) -> str | None:
    """The published method whose relabelling the DDPG+HER cell of experiment `name` uses:
    'DDPG w/ HER+FA' (mrl's futureactual) if it draws actual goals (`ddpg.relabel_actual` >
    0), else 'DDPG w/ HER' (future achieved goals only); None for another method or an
    unknown experiment."""
    args = _cell_args(name)
    if args is None:
        return None
    return "DDPG w/ HER+FA" if args.full_options()["ddpg"].relabel_actual > 0 else "DDPG w/ HER"


def _cell_args(label: str):
    """RunArgs of the DDPG+HER cell of experiment `label` (a label 'EXPERIMENT: METHOD
    LABEL' names the cell of that method; a bare one, the first); None for another method or
    an unknown experiment."""
    from mjx_skills.methods import get

    name, _, method = label.partition(": ")
    if name not in names():
        return None
    exp = load_experiment(name)
    cell = next((c for c in exp.cells() if not method or get(c.method).label == method), None)
    if cell is None or cell.method != "ddpg_her":
        return None
    return cell.run_args(out="", progress=False)


UNSAID = ("train.epochs", "train.seeds")
"""Config fields `unlike` leaves out: the budget and seeds, which each entry states."""


def unlike(name: str, names_: set[str]) -> str:
    """'; as PARENT but FIELD VALUE, ...': how DDPG+HER cell `name`'s config differs from the
    experiment it extends, where that one is among `names_` (the cells said beside it), its
    budget and seeds left out; '' otherwise."""
    experiment = name.partition(": ")[0]
    base = parent(experiment) if experiment in names() else None
    if base not in names_:
        return ""
    from mjx_skills.training.runner import config_dict

    mine, theirs_ = _cell_args(name), _cell_args(base)
    if mine is None or theirs_ is None:
        return ""
    diff = changes(config_dict(theirs_), config_dict(mine))
    fields = [f"{p.removeprefix('options.')} {v!r}" for p, _, v in diff if p not in UNSAID]
    return f"; as {base} but {', '.join(fields)}" if fields else ""


def theirs(figure: dict) -> float | None:
    """Transitions per env step of a published figure's learner; None if the file has none."""
    if "batch_size" not in figure:
        return None
    return figure["batch_size"] / figure["env_steps_per_update"]


def sentence(name: str, figure: dict) -> str:
    """' Per env step, ...': our cell's budget beside the published learner's, or ''."""
    mine, published = ours(name), theirs(figure)
    if mine is None or published is None:
        return ""
    per, batch, updates, steps = mine
    return (
        f" Per env step, {name}'s learner samples {per:.0f} transitions ({updates} updates "
        f"of {batch} per {steps} env steps); the published one ({figure['source']}) samples "
        f"{published:.0f} "
        f"(batch {figure['batch_size']}, an update every {figure['env_steps_per_update']} "
        f"env steps), {published / per:.0f} times as many: a difference not yet tested as "
        "the cause."
    )


MATCHED = 0.1
"""A cell's gradient budget matches the published learner's when the two differ by at most
this share of the published one."""

REPRODUCED_WITHIN = 1.5
"""Our DDPG+HER reproduces a published figure when it reaches the level within this multiple
of the published env steps (a choice: seeds and envs differ, -v1 there, -v4 here)."""


def repeats(cells: list) -> dict[str, str]:
    """{shorter: longer} for each pair of (label, env steps per epoch, (seeds, epochs)
    success) cells where the longer's first epochs are the shorter's curves bit for bit (the
    same learner and seeds run further): one piece of evidence, not two."""
    out = {}
    for name, per, s in cells:
        for other, per2, s2 in cells:
            longer = s2.shape[1] > s.shape[1] and s2.shape[0] == s.shape[0] and per2 == per
            if other != name and longer and np.array_equal(s2[:, : s.shape[1]], s):
                out[name] = other
    return out


def reproduction(env: str, mine: list, figure: dict, level: float) -> str:
    """Whether our DDPG+HER reproduces the published DDPG+HER on `env`: each DDPG+HER cell
    of `mine` ((label, env steps per epoch, (seeds, epochs) success) on one task), those at
    the published learner's budget first, then the longest, with its budget, where it ends
    and where it reaches `level` (a cell that only repeats a longer one's first epochs is
    named in that one's entry); the verdict, from the cells at the published budget where
    any ran; and, where they fall short, that the budget alone does not explain the gap,
    with the seeds it rests on. '' if no DDPG+HER cell ran."""
    plain, repeated, judged = _cells(mine, figure)
    if not plain:
        return ""
    published = theirs(figure)
    parts = []
    said = {m[0] for m in plain} | set(repeated)
    for name, per, s, (transitions, *_) in plain:
        hit = stats.first_reaching(s.mean(axis=0), level)
        where = f"reaches {level} at {hit * per:,}" if hit is not None else f"never {level}"
        again = [short for short, long in repeated.items() if long == name]
        parts.append(
            f"{name} ({seeds(len(s))}, {transitions:.0f} transitions per env step"
            f"{unlike(name, said)}) ends at a "
            f"last-5 mean of {stats.summarize(s).last[0]:.2f} after {s.shape[1] * per:,} env "
            f"steps ({where}"
            + "".join(f"; its first epochs repeat {short}'s bit for bit" for short in again)
            + ")"
        )
    line = (
        f"DDPG+HER's reproduction on {env}: {figure['method']} ({figure['source']}) reaches "
        f"{level} at {figure['env_steps']:,} env steps"
        + (f", sampling {published:.0f} transitions per env step" if published else "")
        + "; ours: "
        + "; ".join(parts)
        + ". "
        + _verdict(judged, figure["env_steps"], level)
        + (f" The published learner: {figure['learner']}." if "learner" in figure else "")
    )
    if _reproduced(judged, figure["env_steps"], level):
        return line
    if not _matched(judged[0], published):
        return line + (
            " No cell has run at the published learner's budget yet." if published else ""
        )
    name, per, s, _ = judged[0]
    reached = any(_hit(m, level) is not None for m in judged)
    settled = reached or s.shape[1] * per >= REPRODUCED_WITHIN * figure["env_steps"]
    if not settled:  # within the allowance still: the verdict is not in
        return line + (
            f" {name} samples the published learner's transitions per env step and has not "
            f"reached it so far ({seeds(len(s))}): the gradient budget alone has not closed "
            "the gap yet."
        )
    return line + (
        f" {name} samples the published learner's transitions per env step and "
        + ("reaches it only later" if reached else "still falls short")
        + f" ({seeds(len(s))}; it differs in other settings its experiment names): the "
        "gradient budget alone does not explain the gap."
    )


def reproduced(mine: list, figure: dict, level: float) -> bool | None:
    """Whether `reproduction`'s verdict on the same cells is 'Reproduced' (None: no DDPG+HER
    cell ran)."""
    judged = _cells(mine, figure)[2]
    return _reproduced(judged, figure["env_steps"], level) if judged else None


def _cells(mine: list, figure: dict) -> tuple[list, dict[str, str], list]:
    """(DDPG+HER cells of `mine` as (label, per, success, `ours` budget), those at the
    published learner's budget first, then the longest, less `repeats`; the repeats; the
    cells the verdict is judged on: those at the published budget if any ran, else all)."""
    budgets = [(name, per, s, ours(name)) for name, per, s in mine]
    plain = [(name, per, s, budget) for name, per, s, budget in budgets if budget is not None]
    published = theirs(figure)
    repeated = repeats([(name, per, s) for name, per, s, _ in plain])
    plain = [m for m in plain if m[0] not in repeated]
    plain.sort(key=lambda m: (not _matched(m, published), -m[2].shape[1] * m[1]))
    return plain, repeated, [m for m in plain if _matched(m, published)] or plain


def _matched(cell, published: float | None) -> bool:
    """A (label, per, success, budget) cell samples the published learner's transitions per
    env step (within `MATCHED`)."""
    return bool(published) and abs(cell[3][0] - published) <= MATCHED * published


def _hit(cell, level: float) -> int | None:
    """Env steps at which a (label, per, success, budget) cell's mean reaches `level`."""
    hit = stats.first_reaching(cell[2].mean(axis=0), level)
    return None if hit is None else hit * cell[1]


def _reproduced(cells: list, published: int, level: float) -> bool:
    return any(
        (h := _hit(m, level)) is not None and h <= REPRODUCED_WITHIN * published for m in cells
    )


def _verdict(cells: list, published: int, level: float) -> str:
    """Reproduced (a cell reached `level` within the allowance); not reproduced (a cell
    reached it only past the allowance, or the longest ran past the allowance without it);
    not reproduced yet (past the published env steps, not past the allowance); or not tested
    yet (no cell ran to the published ones). Each names the cell and its seeds."""
    allowance = REPRODUCED_WITHIN * published
    hits = [(h, m) for m in cells if (h := _hit(m, level)) is not None]
    if hits:
        at, (name, _, s, _) = min(hits, key=lambda x: x[0])
        if at <= allowance:
            return (
                f"Reproduced by {name} ({seeds(len(s))}; within {REPRODUCED_WITHIN} times the "
                "published env steps)."
            )
        return (
            f"Not reproduced: {name} ({seeds(len(s))}) reaches {level} at {at:,} env steps, "
            f"past {REPRODUCED_WITHIN} times the published {published:,} ({allowance:,.0f})."
        )
    name, budget, n = max(
        ((m[0], m[2].shape[1] * m[1], len(m[2])) for m in cells), key=lambda m: m[1]
    )
    if budget >= allowance:
        return (
            f"Not reproduced: {name} ({seeds(n)}) ran {budget:,} env steps, "
            f"{REPRODUCED_WITHIN} times the published {published:,} and more, without "
            f"reaching {level}."
        )
    if budget >= published:
        return (
            f"Not reproduced yet: {name} ({seeds(n)}) ran {budget:,} env steps, past the "
            f"published {published:,}, without reaching {level} (the allowance, "
            f"{REPRODUCED_WITHIN} times, runs to {allowance:,.0f})."
        )
    return f"Not tested yet: no cell ran to the published {published:,} env steps."
