"""Expected wall time of a sweep, from the epoch costs `benchmarks/epoch_cost.py` measured.

    python -m mjx_skills.sweep --experiment NAME --epochs 100 --seeds 5 --estimate

The model, per cell (task, method, seeds, epochs):
- an epoch costs what `benchmarks/epoch_cost.py` measured for the method on pick_move at that number
  of seeds (linear between the measured seed counts, and beyond them from the last two), on
  the number of cores the cell gets (`cores_per_job`: rows measured with `--cores 1` for
  two cells at once on two cores);
- the steps of the episodes scale with the task's episode length (pick_move has 50), the
  updates do not: epoch = updates + (epoch - updates) x length / 50;
- DDPG+HER+SL's epochs cost between its eps = 1 and eps = 0.001 epochs in proportion to
  eps, which decays linearly over `eps_decay_epochs` (the search runs only where it is
  used: `search.search_where`);
- plus the compile once per cell.
A method the benchmark does not measure (DDPG+HER+SL+Fast: wider networks, four times the
updates) costs what its stored cells took per epoch (`experiments/results/cells`, run two
at a time on two cores), scaled linearly to the cell's seeds (and episode length, from
another task's cell).
Cells are then given to `jobs` workers longest first; the estimate is the last worker's end.
Budgets other than the default (envs, cycles, updates, evaluation episodes, episode
length, batch size, network widths, twin critics) are not modelled: the estimate names such a cell's fields (`unmodelled`).
"""

from __future__ import annotations

import dataclasses
import heapq
import json
from pathlib import Path

from mjx_skills.sweeps.cell import Cell
from mjx_skills.sweeps.cells import STORE
from mjx_skills.sweeps.experiments import Experiment

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "epoch_cost.jsonl"
BENCHMARKED = ("ddpg_her", "pas", "mpas", "ddpg_her_sl", "ddpg_her_sl_bc")
"""Methods whose epochs `benchmarks/epoch_cost.py` measures (BC's extra loss term is noise
beside DDPG+HER+SL's epoch)."""
BUDGET = {
    "train": ("envs", "cycles", "updates_per_cycle", "eval_episodes"),
    "env": ("episode_length",),
    "ddpg": ("batch_size", "hidden", "critics"),
    "pas": ("updates_per_cycle",),
}
"""A benchmarked method's fields that change what an epoch costs but that the model does not
scale (`unmodelled`): the estimate names them rather than pass its figure off as theirs."""
REFERENCE_LENGTH = 50
"""Episode length of pick_move, the task the epoch costs are measured on."""


def load_rows(path: Path = RESULTS) -> list[dict]:
    """The measured rows (one per variant, seeds and cores); a clear error when missing."""
    if not path.exists():
        raise FileNotFoundError(f"{path} is missing: run python benchmarks/epoch_cost.py first")
    from mjx_skills.core.files import read_jsonl

    rows = read_jsonl(path)  # a half-written last line (a killed benchmark) is dropped
    return [r for r in rows if "variant" in r]


def _interpolate(points: dict[int, float], seeds: int) -> float:
    xs = sorted(points)
    if seeds in points or len(xs) == 1:
        return points.get(seeds, points[xs[0]] * seeds / xs[0])
    lo = max([x for x in xs if x < seeds], default=xs[0])
    hi = min([x for x in xs if x > seeds], default=xs[-1])
    if lo == hi:  # outside the measured range: the last two points' line
        lo, hi = (xs[0], xs[1]) if seeds < xs[0] else (xs[-2], xs[-1])
    return points[lo] + (points[hi] - points[lo]) * (seeds - lo) / (hi - lo)


@dataclasses.dataclass(frozen=True)
class CostTable:
    rows: tuple[dict, ...]
    cores: int
    """Cores each cell runs on (the rows measured on that many are used)."""

    def _rows(self, variant: str) -> list[dict]:
        rows = [r for r in self.rows if r["variant"] == variant and r["cores"] == self.cores]
        if not rows:
            have = sorted({(r["variant"], r["cores"]) for r in self.rows})
            raise ValueError(
                f"no epoch cost measured for {variant!r} on {self.cores} core(s); measured: {have}"
            )
        return rows

    def epoch_s(self, variant: str, seeds: int, length: int = REFERENCE_LENGTH) -> float:
        rows = self._rows(variant)
        epoch = _interpolate({r["seeds"]: r["epoch_s"] for r in rows}, seeds)
        split = [r for r in rows if "updates_s" in r]
        updates_share = split[0]["updates_s"] / split[0]["epoch_s"] if split else 0.0
        return epoch * (updates_share + (1 - updates_share) * length / REFERENCE_LENGTH)

    def compile_s(self, variant: str) -> float:
        return max(r["compile_s"] for r in self._rows(variant))


def stored_epoch_s(cell: Cell, store: Path = STORE) -> float:
    """Seconds per epoch of `cell` from the stored cells of its method (ValueError if none),
    preferring one of the same task, then one of the same options, then the slowest; from
    another task scaled by episode length; then scaled by seeds."""
    from mjx_skills.core.files import read_json
    from mjx_skills.envs.registry import ENVS
    from mjx_skills.sweeps.cells import (
        defaults,
        differences,
        read_stored_metrics,
        run_config,
        verify,
    )
    from mjx_skills.training.metrics_log import wall_seconds
    from mjx_skills.training.schema import migrate

    options = run_config(cell.run_args(out="", progress=False))["options"]
    default = defaults(cell.method)["options"]
    found = []
    for d in sorted(store.glob(f"*-{cell.method}-*")):
        verify(d, ("definition.json",))  # damage is named, never used
        config = migrate(read_json(d / "definition.json")["config"])
        if config["method"] != cell.method:
            continue
        metrics = read_stored_metrics(d)
        train = config["train"]
        wall = wall_seconds(metrics) / max(m["epoch"] for m in metrics)
        rank = (
            train["task"] != cell.task,
            bool(differences(config["options"], options, default=default)),
            -wall / train["seeds"],
        )
        found.append((rank, train["task"]))
    if not found:
        raise ValueError(
            f"no epoch cost measured for {cell.method}: no stored cell of it in {store}"
        )
    (other, _, per_seed), task = min(found)
    length = ENVS[cell.task].default_episode_length / ENVS[task].default_episode_length
    return -per_seed * cell.seeds * (length if other else 1.0)


def cell_seconds(cell: Cell, table: CostTable, store: Path = STORE) -> float:
    """Expected wall seconds of one training cell."""
    import jax.numpy as jnp

    from mjx_skills import methods
    from mjx_skills.config import SearchConfig
    from mjx_skills.envs.registry import ENVS
    from mjx_skills.methods.ddpg_her_sl import epsilon

    if cell.method not in BENCHMARKED:
        return cell.epochs * stored_epoch_s(cell, store)
    length = ENVS[cell.task].default_episode_length
    groups = methods.get(cell.method).options
    default = groups.get("search", SearchConfig())
    search = dataclasses.replace(default, **dict(dict(cell.options).get("search", ())))
    # The methods that explore with the search (DDPG+HER+SL and its variants) cost about
    # what DDPG+HER+SL does.
    searching = "search" in groups
    if searching and search.explorer == "search":
        # Between the eps = 0.001 and eps = 1 epochs in proportion to eps (the search runs
        # only where it is used), over the method's own eps schedule.
        full = table.epoch_s("sl_eps1", cell.seeds, length)
        least = table.epoch_s("sl_eps0", cell.seeds, length)
        eps = float(jnp.sum(epsilon(search, jnp.arange(cell.epochs))))
        return table.compile_s("sl_eps1") + cell.epochs * least + (full - least) * eps
    variant = "oracle" if searching else cell.method
    return table.compile_s(variant) + cell.epochs * table.epoch_s(variant, cell.seeds, length)


def unmodelled(cell: Cell) -> list[str]:
    """`BUDGET` fields of `cell` that differ from its method's defaults, as '--flag value
    (default d)', for a method whose epochs the benchmark measured at the defaults; [] for
    one costed from its stored cells (they ran at the budgets they ran at)."""
    from mjx_skills import methods
    from mjx_skills.config import EnvConfig, TrainConfig

    if cell.method not in BENCHMARKED:
        return []
    args = cell.run_args(out="", progress=False)
    given = {"train": args.train, "env": args.env, **args.options}
    default = {"train": TrainConfig(), "env": EnvConfig(), **methods.get(cell.method).options}
    return [
        f"{methods.option_flag(group, field)} {getattr(given[group], field)} "
        f"(default {getattr(default[group], field)})"
        for group, fields in BUDGET.items()
        if group in given
        for field in fields
        if getattr(given[group], field) != getattr(default[group], field)
    ]


def makespan(seconds: list[float], jobs: int) -> float:
    """Wall time of independent jobs on `jobs` workers, longest first to the first free."""
    free = [0.0] * max(jobs, 1)
    for s in sorted(seconds, reverse=True):
        heapq.heapreplace(free, free[0] + s)
    return max(free)


def is_stored(cell: Cell, store: Path = STORE) -> bool:
    """`cell` is in the store with the definition that would make it again (a sweep takes
    it without training); a stored cell of another definition is not (a sweep refuses it)."""
    from mjx_skills.sweeps.cells import stored

    try:
        return stored(cell, store) is not None
    except ValueError:
        return False


def estimate(
    exp: Experiment,
    jobs: int,
    rows: list[dict] | None = None,
    cores: int | None = None,
    store: Path = STORE,
    from_scratch: bool = False,
) -> dict:
    """{cells: {name: s}, stored: [name], serial_s, wall_s, jobs, cores_per_job} for a
    training experiment on `cores` cores (default: the ones this process may use). A cell
    already in `store` costs nothing (the sweep takes it) and is listed in `stored`, unless
    `from_scratch` (what every cell would cost to train)."""
    from mjx_skills.core.workers import usable_cores

    done = [] if from_scratch else [c for c in exp.cells() if is_stored(c, store)]
    todo = [c for c in exp.cells() if c not in done]
    jobs = max(1, min(jobs, len(todo)))  # as the sweep: no more workers than cells to run
    cells: dict[str, float] = {}
    odd: dict[str, list[str]] = {}
    if todo:
        rows = [r for r in rows if "variant" in r] if rows is not None else load_rows()
        want = max(1, (cores or usable_cores()) // jobs)
        # The measured core count nearest to what each cell gets here.
        cores = min({r["cores"] for r in rows} or {want}, key=lambda c: (abs(c - want), c))
        table = CostTable(tuple(rows), cores)
        cells = {c.name: cell_seconds(c, table, store) for c in todo}
        odd = {c.name: fields for c in todo if (fields := unmodelled(c))}
    return {
        "experiment": exp.name,
        "jobs": jobs,
        "cores_per_job": cores,
        "cells": {k: round(v) for k, v in cells.items()},
        "stored": [c.name for c in done],
        "serial_s": round(sum(cells.values())),
        "wall_s": round(makespan(list(cells.values()), jobs)),
        "unmodelled": odd,
    }


def report(exp: Experiment, jobs: int, store: Path = STORE) -> str:
    """Human-readable estimate; the last line is the estimate as JSON."""
    if exp.kind != "train":
        raise SystemExit(f"error: --estimate models training experiments; {exp.name} is {exp.kind}")
    est = estimate(exp, jobs, store=store)
    odd = est["unmodelled"]
    lines = [
        f"{name:50s} {s / 60:6.1f} min"
        + (
            f"  (at the default budget; not modelled: {', '.join(odd[name])})"
            if name in odd
            else ""
        )
        for name, s in est["cells"].items()
    ]
    lines += [f"{name:50s} stored (taken from {store})" for name in est["stored"]]
    total = len(est["cells"]) + len(est["stored"])
    head = f"{exp.name}: {total} cells, {len(est['stored'])} stored; "
    if est["cells"]:
        lines.append(
            f"{head}{est['wall_s'] / 3600:.2f} h with --jobs {est['jobs']} "
            f"({est['cores_per_job']} core(s) each; {est['serial_s'] / 3600:.2f} h of cell time)"
            + (f"; {len(odd)} cell(s) at a budget the estimate does not model" if odd else "")
        )
    else:
        lines.append(f"{head}0.00 h: nothing to train")
    return "\n".join([*lines, json.dumps(est)])
