"""The Fetch section of the report (issue #45, so far): every stored cell of an experiment on
a Fetch task, with env steps to 0.9 and its last-5 success, beside the published DDPG+HER
figures (`study/published/fetch_her.toml`, read from their sources' plots) and what a user
would run instead (Stable-Baselines3 on gymnasium-robotics' own envs,
`benchmarks/results/peer_sb3_fetch.jsonl`), and a figure of the curves over env steps with
the published points marked and the peers' curves dashed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mjx_skills.analysis import stats
from mjx_skills.core.files import read_jsonl
from mjx_skills.sweeps import cells
from mjx_skills.sweeps.cell import Cell
from mjx_skills.sweeps.experiment_file import names
from mjx_skills.sweeps.experiments import load_experiment
from study import fetch_explorer, fetch_ranking
from study.claims import seeds
from study.fetch_claims import ENVS, LEVEL, fresh, library_used, published, shortfalls
from study.fetch_library import library_tables
from study.sections import table

PEERS = Path(__file__).parents[1] / "benchmarks" / "results" / "peer_sb3_fetch.jsonl"
"""Stable-Baselines3 on gymnasium-robotics' own envs (benchmarks/peer_sb3_fetch.py)."""


def _stored() -> list[tuple[str, Cell, list[dict]]]:
    """(label, cell, metrics rows) of every stored cell of an experiment on a Fetch task, in
    experiment order; the label is the experiment's name, with the method's label after a
    colon where the experiment runs several methods."""
    from mjx_skills.methods import get

    out = []
    for name in names():
        exp = load_experiment(name)
        if exp.kind != "train" or not any(t in ENVS for t in exp.tasks):
            continue
        for cell in exp.cells():
            where = cells.stored(cell, cells.STORE)
            label = f"{name}: {get(cell.method).label}" if len(exp.methods) > 1 else name
            if where is not None:
                out.append((label, cell, cells.read_stored_metrics(where)))
    return out


def stored_cells(found=None) -> list[tuple[str, str, int, np.ndarray]]:
    """(experiment, task, env steps per epoch, (seeds, epochs) success) of every stored cell
    of an experiment on a Fetch task, in experiment order (of `found`, `_stored()`'s list)."""
    return [
        (name, cell.task, _per_epoch(rows), stats.scores_from_rows(rows))
        for name, cell, rows in (_stored() if found is None else found)
    ]


def _per_epoch(rows: list[dict]) -> int:
    return rows[0]["env_steps"] // rows[0]["epoch"]


def clock(rows: list[dict]) -> np.ndarray:
    """(epochs,) wall seconds from the start of a run to the end of each epoch, compile
    included; `wall_s` starts again in a resumed process, so each stretch adds to the last."""
    by_epoch = sorted({r["epoch"]: r["wall_s"] for r in rows}.items())
    out, offset, last = [], 0.0, 0.0
    for _, wall in by_epoch:
        offset += last if wall < last else 0.0
        out.append(offset + wall)
        last = wall
    return np.asarray(out)


def wall_table(found, peers) -> list[list[str]]:
    """Rows (task, run, seeds at once, wall to LEVEL, with the library's build) for each of
    our cells (`_stored()`'s list) and each peer group (`_peer_groups()`'s) that reaches
    LEVEL: the seconds on this machine's 2 cores until the epoch at which the rolling mean
    first reaches it (ours: all the cell's seeds in one program; a peer: one seed at a time,
    the mean over its seeds)."""
    rows = []
    for name, cell, metrics in found:
        hit = stats.first_reaching(stats.scores_from_rows(metrics).mean(axis=0), LEVEL)
        if hit is not None:
            seeds = len({r["seed"] for r in metrics})
            wall, build = clock(metrics)[hit - 1], build_seconds(name)
            total = "-" if build is None else _minutes(wall + build)
            rows.append([ENVS[cell.task], name, f"{seeds} at once", _minutes(wall), total])
    for label, task, _, s, walls in peers:
        hit = stats.first_reaching(s.mean(axis=0), LEVEL)
        if hit is not None:
            wall = _minutes(float(np.mean(walls[:, hit - 1])))
            rows.append([ENVS[task], label, "1 at a time", wall, "-"])
    return rows


REBUILDS = Path(__file__).parents[1] / "experiments" / "results" / "rebuilds"
"""Manifests of committed skill libraries built again (`DIR.json` for `experiments/DIR`)."""


def build_seconds(name: str) -> float | None:
    """Wall seconds the build of the skill library that the cell labelled `name` searches
    with took: each skill's training run, all its stretches (`train_wall_s`, reused from the
    build's work directory or not), then data collection and model fits (`timings_s`). From
    the library's manifest, or, where that predates `train_wall_s` (its timings_s count a
    reused skill's load only), from a rebuild's manifest in `REBUILDS` with the same digest
    (the same arrays). None: no library, none built, or no such record."""
    used = library_used(name)
    if used is None or not used[1].exists():
        return None
    manifest = json.loads(used[1].read_text())
    if "train_wall_s" not in manifest:
        again = REBUILDS / f"{used[1].parent.name}.json"
        if not again.exists():
            return None
        rebuilt = json.loads(again.read_text())
        if rebuilt.get("digest") != manifest.get("digest") or "train_wall_s" not in rebuilt:
            return None
        manifest = rebuilt
    timings = manifest["timings_s"]
    return sum(manifest["train_wall_s"].values()) + timings["collect_s"] + timings["fit_s"]


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min"


def peer_cells(path: Path = PEERS) -> list[tuple[str, str, int, np.ndarray]]:
    """(label, task, env steps per epoch, (seeds, epochs) success) of each group of rows of
    the same settings in benchmarks/results/peer_sb3_fetch.jsonl (a seed's row: its curve)."""
    return [group[:4] for group in _peer_groups(path)]


SAME_STARTS = "the same eval starts"
"""The label's note on a peer group evaluated on one fixed set of starts (rows without
`eval_starts`, from before benchmarks/peer_sb3_fetch.py drew them afresh); such a group is
left out once the same settings have as many seeds on fresh starts."""


def _peer_groups(path: Path = PEERS) -> list[tuple[str, str, int, np.ndarray, np.ndarray]]:
    """`peer_cells` with each group's (seeds, epochs) wall seconds since its seed started.
    Rows are grouped by settings (task, algo, networks, batch, env steps), then by eval
    starts (fresh per epoch, or one fixed set); a seed run twice counts once (its last row).
    A fixed-start group is left out once its settings have as many distinct seeds on fresh
    starts."""
    if not path.exists():
        return []
    groups: dict[tuple, dict[object, dict[int, dict]]] = {}
    for row in read_jsonl(path, whole=True):
        settings = (
            row["task"],
            row["algo"],
            tuple(row["net_arch"]),
            row["batch_size"],
            row["steps"],
        )
        by_starts = groups.setdefault(settings, {})
        by_starts.setdefault(row.get("eval_starts"), {})[row["seed"]] = row
    out = []
    for (task, algo, net, batch, _), by_starts in groups.items():
        fresh_seeds = len({s for starts, rows in by_starts.items() if starts for s in rows})
        for starts, by_seed in by_starts.items():
            if not starts and fresh_seeds >= len(by_seed):
                continue  # superseded: as many seeds of the same settings on fresh starts
            rows = [by_seed[s] for s in sorted(by_seed)]
            curves = [[p["eval_success"] for p in r["curve"]] for r in rows]
            walls = [[p["wall_s"] for p in r["curve"]] for r in rows]
            per_epoch = rows[0]["curve"][0]["env_steps"]
            name = algo.removeprefix("sb3_").removesuffix("_her").upper()
            label = f"SB3 {name}+HER ({len(net)} x {net[0]}, batch {batch}"
            label += ")" if starts else f", {SAME_STARTS})"
            out.append(
                (label, task, per_epoch, np.asarray(curves, float), np.asarray(walls, float))
            )
    return out


def peer_comparison(ours, peers, keep=fresh) -> list[str]:
    """For each peer group, each of our cells on its task that `keep(name)` admits (by
    default the fresh-seed cells: headlines and their baselines) beside it, both over the
    last 5 epochs up to the shorter run's end (the same env steps): last-5 mean [95 %
    interval]."""
    out = []
    for label, task, per, theirs in peers:
        mine = [(n, s) for n, t, p, s in ours if t == task and p == per and keep(n)]
        if not mine:
            continue
        text = "; ".join(
            f"{n} {_last(s[:, :k])} ({seeds(len(s))}) against "
            f"{_last(theirs[:, :k])}, up to {k * per:,} env steps"
            for n, s in mine
            for k in [min(s.shape[1], theirs.shape[1])]
        )
        out.append(
            f"- {ENVS[task]}, {label} ({seeds(len(theirs))}) beside our fresh-seed cells, "
            f"each pair over the last 5 epochs up to the shorter run's end: {text}."
        )
    return out


def _reach(scores: np.ndarray, per_epoch: int) -> str:
    hit = stats.first_reaching(scores.mean(axis=0), LEVEL)
    budget = scores.shape[1] * per_epoch
    return f"never (budget {budget:,})" if hit is None else f"{hit * per_epoch:,}"


def _last(scores: np.ndarray) -> str:
    """The last-5 mean [95 % interval] of (seeds, epochs) scores; one seed has no interval."""
    mean, low, high = stats.summarize(scores).last
    return (
        f"{mean:.2f} (1 seed, no interval)"
        if len(scores) == 1
        else f"{mean:.2f} [{low:.2f}, {high:.2f}]"
    )


def section(figure_path: Path, draw: bool = True) -> list[str]:
    """The markdown (and, with `draw`, the figure at `figure_path`)."""
    found, groups = _stored(), _peer_groups()
    ours = stored_cells(found)
    used, serves = [], {}
    for name, task, *_ in ours:
        if (library := library_used(name)) is not None:
            used.append(library)
            tasks = serves.setdefault(library[1].resolve(), [])
            tasks += [ENVS[task]] if ENVS[task] not in tasks else []
    rows = [
        [
            ENVS[task],
            name,
            f"{len(s)}",
            _reach(s, per),
            _last(s),
        ]
        for name, task, per, s in ours
    ]
    theirs = [
        [
            f["env"],
            f"{f['method']} ({f['source']}, [plot]({f['url']}) at {f['commit']})",
            f["setting"],
            f"{f['env_steps']:,}",
        ]
        for f in published()
    ]
    lines = [
        *library_tables(used, serves),
        "",
        "Our runs on gymnasium-robotics' Fetch tasks (the JAX envs on native MuJoCo physics, "
        "equal to the originals step for step): env steps until the 5-epoch rolling mean of the seeds' mean eval success "
        f"first reaches {LEVEL} (evaluation episodes not counted), and the last-5 mean [95 % "
        "interval]. Each experiment's file says its settings.",
        "",
        *table(
            ["task", "experiment", "seeds", f"env steps to {LEVEL}", "last 5 epochs, mean [95 %]"],
            rows,
        ),
        "",
        f"Published DDPG+HER figures: env steps until the mean success first reaches {LEVEL}, "
        "read from the sources' plots (how: the data file's header).",
        "",
        *table(["env", "method (source)", "setting", f"env steps to {LEVEL}"], theirs),
    ]
    peers = [group[:4] for group in groups]
    if peers:
        lines += [
            "",
            "What a user would run instead: Stable-Baselines3's DDPG+HER on "
            "gymnasium-robotics' own envs (`benchmarks/peer_sb3_fetch.py`; `--algo tqc` runs "
            "TQC+HER), with the HER and learner settings of rl-zoo3's tuned FetchPush recipe "
            "(a TQC recipe: gamma, learning rate, tau, 4 'future' goals, one gradient step "
            "per env step) and its networks and batch sized down to these 2 cores; the "
            "settings are in each row of `benchmarks/results/peer_sb3_fetch.jsonl`. "
            "Evaluated as ours (20 episodes of the deterministic policy every 800 env steps)"
            + (
                f"; runs marked '{SAME_STARTS}' met the same 20 starts at every epoch and "
                "seed (ours draw fresh ones), so their seeds' curves are not independent "
                "samples of the start distribution and their intervals understate the spread."
                if any(SAME_STARTS in label for label, *_ in peers)
                else "."
            ),
            "",
            *table(
                ["task", "run", "seeds", f"env steps to {LEVEL}", "last 5 epochs, mean [95 %]"],
                [
                    [ENVS[task], label, f"{len(s)}", _reach(s, per), _last(s)]
                    for label, task, per, s in peers
                ],
            ),
            "",
            *peer_comparison(ours, peers),
        ]
    walls = wall_table(found, groups)
    if walls:
        lines += [
            "",
            f"Wall time to {LEVEL} on these 2 cores, compile included, for the runs above that "
            "reach it (ours train all of a cell's seeds in one program, its evaluation "
            "included, so a cell of more seeds takes longer; SB3 trains one seed at a time, "
            "its evaluation off the clock), and for a library method with its library's build added (the wall its "
            "manifest records: skill training, data collection and model fits; a one-time "
            "cost, as its env steps; for a manifest that predates that record, a rebuild's "
            "with the same digest, experiments/results/rebuilds/; '-' where neither has it).",
            "",
            *table(
                ["task", "run", "seeds", f"wall time to {LEVEL}", "with the library's build"],
                walls,
            ),
        ]
    methods = [(label, cell.method) for label, cell, _ in found]
    ranked = [(*named, per, s) for named, (_, _, per, s) in zip(methods, ours, strict=True)]
    lines += fetch_ranking.section(fetch_ranking.scores(ranked))
    lines += shortfalls(ours)
    lines += fetch_explorer.paragraph(found)
    if ours and figure([*ours, *peers], figure_path, draw) is not None:
        lines += ["", "![The Fetch runs over env steps](figures/fetch.png)"]
    return lines


def figure(ours, out: Path, draw: bool = True) -> Path | None:
    """Each cell's mean success over env steps (one panel per task, range over seeds shaded),
    the published figures marked at (env steps, 0.9)."""
    if not draw:
        return out
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    tasks = list(dict.fromkeys(task for _, task, _, _ in ours))
    rows = max(sum(t == task for _, t, _, _ in ours) for task in tasks) // 2 + 1
    # The legends stand below the panels (two columns), so the figure grows with the cells.
    height = 3.4 + 0.14 * rows
    fig, axes = plt.subplots(1, len(tasks), figsize=(4.6 * len(tasks), height), squeeze=False)
    colours = plt.get_cmap("tab20").colors  # 20 distinct colours: a panel has up to ~25
    for ax, task in zip(axes[0], tasks, strict=True):
        mine = [cell for cell in ours if cell[1] == task]
        for i, (name, _, per, s) in enumerate(mine):
            x = np.arange(1, s.shape[1] + 1) * per
            style = "--" if name.startswith("SB3") else "-"  # a peer's run (`peer_cells`)
            if i >= len(colours) and style == "-":  # past 20 a colour comes back, dotted
                style = ":"
            colour = colours[i % len(colours)]
            ax.plot(x, s.mean(axis=0), style, lw=1.3, color=colour, label=name)
            ax.fill_between(x, s.min(axis=0), s.max(axis=0), color=colour, alpha=0.12, lw=0)
        theirs = [f for f in published() if f["env"].startswith(ENVS[task] + "-")]
        for k, f in enumerate(sorted(theirs, key=lambda f: f["env_steps"])):
            ax.plot(f["env_steps"], LEVEL, "k^", ms=6)
            ax.annotate(  # labels stacked downwards: close points do not overprint
                f["method"],
                (f["env_steps"], LEVEL),
                fontsize=6,
                xytext=(3, -10 - 8 * k),
                textcoords="offset points",
            )
        ax.set(title=ENVS[task], xlabel="env steps", ylim=(-0.02, 1.02))
        ax.set_xlim(0, ax.get_xlim()[1] * 1.12)  # room for the published points' labels
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v / 1000:g}k"))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.2))
    axes[0][0].set_ylabel("eval success (20 episodes)")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
