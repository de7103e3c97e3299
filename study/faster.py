"""The targets of "learn faster than the oracle explorer" against the stored cells: the
report's section on DDPG+HER+SL+Fast, computed from the data."""

from __future__ import annotations

import numpy as np

from mjx_skills.analysis import stats
from study.claims import ci, compare, reach

FIRST = "eps over 10 epochs to 0.001"
"""The explorer of DDPG+HER+SL+Fast's first default (today's: `FAST_SEARCH`)."""
ABLATIONS = {
    "wide": "wide networks (3 x 64 units instead)",
    "updates": "extra updates (100 per cycle instead of 400)",
    "eps": "short explorer (eps decayed over 30 epochs instead of 10)",
    "pick": "the critic's pick (the actor alone acts)",
}
"""The first default's ingredients, each removed in turn by experiments/fast_no_NAME.toml."""
FLOOR = "the eps floor (eps decayed over 5 epochs to 0.001 instead of 0.1)"
"""The second default's floor (experiments/fast_wall.toml), removed."""
ABLATION_CELLS = (
    *((f"fast_no_{x}", "pick_move", "fast_first", why) for x, why in ABLATIONS.items()),
    ("fast_wall_no_pick", "container_wall", "fast_wall_first", ABLATIONS["pick"]),
    ("fast_wall_no_floor", "container_wall", "fast_wall", FLOOR),
    (
        "fast_avg_no_pick",
        "pick_move",
        "fast_eval_pick_low_floor_avg",
        "the critic's pick in evaluation (the averaged actor alone acts)",
    ),
    (
        "fast_eval_pick_low_floor",
        "pick_move",
        "fast_eval_pick_low_floor_avg",
        "the averaged networks (the online ones evaluated; the same training)",
    ),
)
"""(experiment, task, the full method's experiment, what is removed): the first default's
ablations on pick_move and its pick's also on container_wall (where seeds can stay stuck);
the second default's floor on container_wall, where it is what keeps seeds from staying
stuck; today's default's pick and averaging on pick_move (both act in evaluation only, so
each ablation trains as the default does)."""
EVAL_PICK = "the pick in evaluation only (the actor acts in training)"
LOW_FLOOR = f"{EVAL_PICK}, eps over 10 epochs to a floor of 0.03"
SUCCESS_FLOOR = (
    f"{EVAL_PICK}, eps over 10 epochs to a floor of 0.1 x (1 - the previous epoch's eval success)"
)
AVERAGED = (
    "the evaluated networks Polyak-averaged (`--fast.eval-average 0.8`, folded in after each cycle)"
)
TWIN = "twin critics (`--ddpg.critics 2`: TD3's clipped double Q, also in the pick)"
SECOND = "the second default (eps over 5 epochs to 0.1, the pick also in training)"
TODAY = ("fast_eval_pick_low_floor_avg", "fast_wall_eval_pick_low_floor_avg")
"""Today's default's experiments (`FastConfig`, `FAST_SEARCH`): the one-cube targets' and
container_wall's; the second default's are `fast` and `fast_wall`."""
CANDIDATES = (
    ("fast_eval_pick_first", "fast_wall_eval_pick_first", f"the first default, {EVAL_PICK}"),
    ("fast_eval_pick_low_floor", "fast_wall_eval_pick_low_floor", LOW_FLOOR),
    ("fast_eval_pick_success_floor", "fast_wall_eval_pick_success_floor", SUCCESS_FLOOR),
    ("fast", "fast_wall", SECOND),
)
"""The other configurations in the targets table, before today's default: (experiment on
the one-cube targets, experiment on container_wall, what it is)."""
ADDITION_CELLS = (
    ("fast_u800", "pick_move", "fast", "more updates (800 per cycle instead of 400)"),
    ("fast_held", "pick_move", "fast", "held starts (half the training starts with the cube held)"),
    ("fast_quiet", "pick_move", "fast", "no random actions (random_eps 0 instead of 0.2)"),
    ("fast_eval_pick", "pick_move", "fast", EVAL_PICK),
    ("fast_twin", "pick_move", "fast", TWIN),
    ("fast_eval_pick_first", "pick_move", "fast_first", EVAL_PICK),
    ("fast_wall_eval_pick_first", "container_wall", "fast_wall_first", EVAL_PICK),
    ("fast_eval_pick_low_floor", "pick_move", "fast", LOW_FLOOR),
    ("fast_wall_eval_pick_low_floor", "container_wall", "fast_wall", LOW_FLOOR),
    ("fast_eval_pick_success_floor", "pick_move", "fast", SUCCESS_FLOOR),
    ("fast_wall_eval_pick_success_floor", "container_wall", "fast_wall", SUCCESS_FLOOR),
    ("fast_eval_pick_low_floor_twin", "pick_move", "fast_eval_pick_low_floor", TWIN),
    (
        "fast_eval_pick_low_floor_tau",
        "pick_move",
        "fast_eval_pick_low_floor",
        "slower targets (tau 0.0125 per update instead of 0.05)",
    ),
    (
        "fast_eval_pick_low_floor_n3",
        "pick_move",
        "fast_eval_pick_low_floor",
        "3-step returns (`--ddpg.n-step 3`, uncorrected)",
    ),
    ("fast_eval_pick_low_floor_avg", "pick_move", "fast_eval_pick_low_floor", AVERAGED),
    (
        "fast_wall_eval_pick_low_floor_avg",
        "container_wall",
        "fast_wall_eval_pick_low_floor",
        AVERAGED,
    ),
)
"""(experiment, task, the default's experiment, what is added or changed): candidates for
pick_move's target, each measured against the default it is added to, over the same epochs;
the one that meets it also on container_wall, where the other targets' seeds can stay stuck."""
ADDITIONS = (
    "Candidates for pick_move's target, each added in turn to the default named in "
    "the nearest '(none: ...)' row above it, and the one that meets it also on "
    "container_wall "
    f"(`experiments/{'.toml`, `'.join(row[0] for row in ADDITION_CELLS)}.toml`):"
)
DEFAULTS = {
    "fast": SECOND,
    "fast_wall": SECOND,
    "fast_first": f"the first default ({FIRST})",
    "fast_wall_first": f"the first default ({FIRST})",
    "fast_eval_pick_low_floor": f"the low-floor candidate ({LOW_FLOOR})",
    "fast_eval_pick_low_floor_avg": "today's default",
    "fast_wall_eval_pick_low_floor": f"the low-floor candidate ({LOW_FLOOR})",
}
"""The full method's experiments and which default each holds."""
EXPERIMENTS = (*DEFAULTS, *(row[0] for row in (*ABLATION_CELLS, *ADDITION_CELLS)))
METHOD = "ddpg_her_sl_fast"
TITLES = {"fast": "Beyond the thesis: DDPG+HER+SL+Fast, learning faster than the oracle explorer"}

TARGETS = (("pick_move", 30), ("put_in_container", 40))
"""(task, epoch by which the 5-epoch rolling mean must reach 0.9)."""
WALL = ("container_wall", 0.8, 0.5)
"""container_wall: last-5 mean at least 0.8, no seed below 0.5 over its last 10 epochs."""


def _reach(r, experiment: str, task: str, method: str = "ddpg_her_sl_fast") -> str:
    """The cell's '0.9 at epoch' with its 95 % bootstrap interval over seeds."""
    cell, s = r.find(experiment, task, method)
    if s is None:
        return "not run yet"
    low, high = stats.reach_interval(stats.scores_from_rows(r.metrics[cell.name]))
    return f"{reach(s.reach_90)} [{reach(low)}, {reach(high)}]"


def seed_minimum(rows: list[dict], last: int = 10, upto: int | None = None) -> float:
    """The lowest seed's mean eval success over its last `last` epochs (of its first `upto`)."""
    end = upto or max(m["epoch"] for m in rows)
    by_seed: dict[int, list[float]] = {}
    for m in rows:
        if end - last < m["epoch"] <= end:
            by_seed.setdefault(m["seed"], []).append(m["eval_success"])
    return min(float(np.mean(v)) for v in by_seed.values())


def _wall(r, experiment: str) -> tuple[str, bool | None]:
    """container_wall's cell of `experiment` against `WALL`: (text, met; None: not run)."""
    task, level, floor = WALL
    cell, fast = r.find(experiment, task, "ddpg_her_sl_fast")
    if fast is None:
        return "not run yet", None
    low = seed_minimum(r.metrics[cell.name])
    text = (
        f"last 5: {ci(fast.last)}; lowest seed over its last 10: {low:.2f} "
        f"({fast.seeds} seeds x {fast.epochs} epochs)"
    )
    return text, bool(fast.last[0] >= level and low >= floor)


def _holds(r, experiment: str, task: str) -> bool:
    """Whether `experiment` has a cell on `task`."""
    return any(cell.task == task for cell, _ in r.cells[experiment])


def faster(r) -> list[str]:
    """The targets table: DDPG+HER+SL, the oracle explorer, DDPG+HER+SL+Fast's first default,
    the `CANDIDATES`, and today's default (`TODAY`), from `results.Results` r; 'met' is
    today's."""
    rows = []
    for task, by in TARGETS:
        fast = r.get(TODAY[0], task, "ddpg_her_sl_fast")
        met = "" if fast is None else "yes" if fast.reach_90 and fast.reach_90 <= by else "no"
        oracle = _reach(r, "oracle", task, "ddpg_her_sl") if task == "pick_move" else "-"
        rows.append(
            [
                task,
                f"0.9 (rolling mean) by epoch {by}",
                _reach(r, "fig6_3", task, "ddpg_her_sl"),
                oracle,
                _reach(r, "fast_first", task),
                *(_reach(r, e, task) if _holds(r, e, task) else "-" for e, _, _ in CANDIDATES),
                _reach(r, TODAY[0], task),
                met,
            ]
        )
    task, level, floor = WALL
    sl = r.get("fig6_5", task, "ddpg_her_sl")
    first, _ = _wall(r, "fast_wall_first")
    ours, met = _wall(r, TODAY[1])
    rows.append(
        [
            task,
            f"last 5 >= {level}, no seed < {floor} over its last 10",
            "-" if sl is None else f"last 5: {ci(sl.last)}",
            "-",
            first,
            *(_wall(r, wall)[0] for _, wall, _ in CANDIDATES),
            ours,
            "" if met is None else "yes" if met else "no",
        ]
    )
    return rows


HEADER = [
    "task",
    "target",
    "DDPG+HER+SL (0.9 at epoch)",
    "oracle explorer",
    f"DDPG+HER+SL+Fast, first default ({FIRST})",
    *(c[2] for c in CANDIDATES),
    f"DDPG+HER+SL+Fast, today's default ({LOW_FLOOR}, {AVERAGED})",
    "met",
]


def ablation_rows(r, cells=ABLATION_CELLS, names=("the full method", "the ablation")):
    """One row per ablation (`ABLATION_CELLS`; or per addition, `ADDITION_CELLS`): what it
    reaches, and which is faster (whose interval of the mean over epochs lies entirely above
    the other's, over the ablation's epochs); before them, the full method's row over each
    budget they use. `names`: what the verdict calls the full method and the row (None: the
    default the row's experiment is measured against, `DEFAULTS`)."""
    rows, shown = [], set()
    for experiment, task, base, why in cells:
        full_cell, full = r.find(base, task, "ddpg_her_sl_fast")
        cell, s = r.find(experiment, task, "ddpg_her_sl_fast")
        if full is not None and s is not None:
            full = r.first_epochs(full_cell, full, s.epochs)  # over the ablation's budget
        if full is not None and (base, task, full.epochs) not in shown:
            shown.add((base, task, full.epochs))
            rows.append([task, f"(none: {DEFAULTS[base]})", *_cells(r, full_cell, full, None)])
        verdict = compare(full, s, "auc", (names[0] or DEFAULTS[base], names[1]))
        rows.append([task, why, *_cells(r, cell, s, verdict)])
    return rows


def _cells(r, cell, s, verdict: str | None) -> list[str]:
    if s is None:
        return ["not run yet", "", "", "", "", ""]
    low = seed_minimum(r.metrics[cell.name], upto=s.epochs)
    return [
        f"{s.seeds} x {s.epochs}",
        ci(s.last),
        f"{low:.2f}",
        reach(s.reach_90),
        ci(s.auc),
        verdict or "",
    ]


ABLATION_INTRO = (
    "Each ingredient removed in turn: the first default's on pick_move "
    "(`experiments/fast_no_*.toml`) and its pick also on container_wall "
    "(`experiments/fast_wall_no_pick.toml`), against the first default "
    "(`experiments/fast_first.toml`, `fast_wall_first.toml`); the second default's "
    "eps floor on container_wall (`experiments/fast_wall_no_floor.toml`), against "
    "the second default (`experiments/fast_wall.toml`); today's default's pick and "
    "averaged networks on pick_move (`experiments/fast_avg_no_pick.toml`; the "
    "low-floor candidate, `fast_eval_pick_low_floor.toml`, is today's default without "
    "averaging), against today's default "
    "(`experiments/fast_eval_pick_low_floor_avg.toml`):"
)
"""What the ablation table removes, from which default."""
ABLATION_HEADER = [
    "task",
    "removed",
    "seeds x epochs",
    "last 5 epochs [95 % CI]",
    "lowest seed, its last 10",
    "0.9 at epoch",
    "mean over epochs [95 % CI]",
    "faster",
]


def addition_rows(r) -> list[list[str]]:
    """`ablation_rows` of the candidates (`ADDITION_CELLS`), each against the default it is
    added to."""
    return ablation_rows(r, ADDITION_CELLS, (None, "the addition"))


PAIRED = (
    ("pick_move", TODAY[0], "fast_eval_pick_low_floor"),
    ("put_in_container", TODAY[0], "fast_eval_pick_low_floor"),
    ("container_wall", TODAY[1], "fast_wall_eval_pick_low_floor"),
)
"""(task, today's default's experiment, the same without averaging): pairs whose training is
the same, so that seed by seed only the evaluated networks differ."""


PAIRED_INTRO = (
    "Today's default against the same without averaging (the low-floor candidate), "
    "seed by seed: its averaged networks act in evaluation only, so each seed should "
    "train as in the other cell, only the evaluated networks differing (checked per "
    "task: the critic losses). The last-5-epoch mean's difference, its mean over "
    "seeds with a 95 % bootstrap interval:"
)


def _losses(rows: list[dict], upto: int) -> dict[tuple[int, int], float]:
    """(seed, epoch) -> critic loss, over the first `upto` epochs."""
    return {(m["seed"], m["epoch"]): m["critic_loss"] for m in rows if m["epoch"] <= upto}


def paired(r) -> list[str]:
    """Per task of `PAIRED` with both cells in: today's default minus the low-floor candidate,
    seed by seed over the last 5 epochs, the mean of the differences with its 95 % bootstrap
    interval, on how many seeds it is positive, and whether the two trained alike (their
    critic losses equal at every epoch and seed)."""
    lines = []
    for task, averaged, online in PAIRED:
        (a_cell, a), (b_cell, b) = r.find(averaged, task, METHOD), r.find(online, task, METHOD)
        if a is None or b is None:
            continue
        rows_a, rows_b = r.metrics[a_cell.name], r.metrics[b_cell.name]
        if {m["seed"] for m in rows_a} != {m["seed"] for m in rows_b}:
            raise ValueError(f"{a_cell.name} and {b_cell.name} hold other seeds: not paired")
        epochs = min(a.epochs, b.epochs)
        same = _losses(rows_a, epochs) == _losses(rows_b, epochs)
        sa, sb = (
            stats.scores_from_rows(rows_a)[:, :epochs],
            stats.scores_from_rows(rows_b)[:, :epochs],
        )
        diff = sa[:, -stats.LAST :].mean(axis=1) - sb[:, -stats.LAST :].mean(axis=1)
        mean, low, high = (float(x[0]) for x in stats.interval(diff[:, None]))
        trained = (
            "the same training: critic losses equal at every epoch and seed"
            if same
            else "not the same training: their critic losses differ"
        )
        lines.append(
            f"- {task} ({trained}): over epochs {epochs - stats.LAST + 1}-{epochs}, "
            f"averaged minus online {mean:+.3f} [{low:+.3f}, {high:+.3f}], higher on "
            f"{int((diff > 0).sum())} of {len(diff)} seeds, lower on "
            f"{int((diff < 0).sum())}."
        )
    return lines


def dashed(r, task: str) -> list[tuple]:
    """The curves drawn beside the second default's (dashed) in the section's figure, as
    (cell, summary, tag, dashed): the oracle explorer's (the target to beat), dashed, and
    today's default's, solid."""
    return [
        (c, s, tag, dashed)
        for experiment, tag, dashed in (
            ("oracle", "oracle explorer", True),
            (TODAY[0], "today's", False),
        )
        for c, s in r.cells[experiment]
        if c.task == task
    ]
