"""`python -m mjx_skills.sweep --list`: the experiments grouped by what they are for
(`experiment_file.GROUPS`), each with how many of its cells are stored and what the rest
would cost here (`sweeps.cost`)."""

from __future__ import annotations

import csv
from pathlib import Path

from mjx_skills.sweeps.cells import STORE
from mjx_skills.sweeps.experiment_file import GROUPS, names
from mjx_skills.sweeps.experiments import Experiment, load_experiment


def cost_text(exp: Experiment, jobs: int, store: Path) -> tuple[int, str]:
    """(stored cells, the rest's expected wall time as text) of one experiment."""
    from mjx_skills.sweeps import cost

    if exp.kind != "train":  # a library experiment: its cells are built libraries
        built = tabled_samples(store.parent / f"{exp.name}.csv")
        stored = sum(n in built for n in exp.samples)
        return stored, "done" if stored == len(exp.samples) else "-"
    try:
        est = cost.estimate(exp, jobs, store=store)
    except (ValueError, FileNotFoundError):  # no measured cost for one of its methods
        stored = sum(cost.is_stored(c, store) for c in exp.cells())
        return stored, "?"
    if not est["cells"]:
        return len(est["stored"]), "done"
    return len(est["stored"]), f"{est['wall_s'] / 3600:.1f} h"


def tabled_samples(table: Path) -> set[int]:
    """The sample counts whose libraries a library sweep's committed table holds (its
    `samples` column; the libraries themselves are not stored, their rows are)."""
    if not table.exists():
        return set()
    with table.open(newline="") as f:
        return {int(row["samples"]) for row in csv.DictReader(f)}


def listing(jobs: int = 1, store: Path = STORE) -> str:
    """Every experiment under its group's heading: name, stored/total cells, the expected
    wall time of the cells not stored (`jobs` at once; '?' where a method's cost was never
    measured; a library experiment's libraries count as stored when its committed table has
    their rows, '-' for the rest) and its description."""
    by_group: dict[str, list[Experiment]] = {g: [] for g in GROUPS}
    broken = []
    for name in names():
        try:
            exp = load_experiment(name)
        except ValueError as err:  # e.g. a task of a module not imported: say so, list the rest
            broken.append(f"  {name}: cannot be read: {err}")
            continue
        by_group[exp.group].append(exp)
    width = max(len(n) for n in names())
    lines = [] if not broken else ["unreadable:", *broken]
    for group, exps in by_group.items():
        if not exps:
            continue
        lines.append(f"{group}: {GROUPS[group]}")
        for exp in exps:
            stored, cost = cost_text(exp, jobs, store)
            total = len(exp.cells())
            lines.append(
                f"  {exp.name:{width}s} {stored:3d}/{total:<3d} stored {cost:>7s}  "
                f"{exp.description}"
            )
    return "\n".join(lines)
