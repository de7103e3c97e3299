"""The report's tables: Table 5.1, the thesis preset, an experiment's cells, and a variant's
cells beside the cells they are compared with."""

from __future__ import annotations

from mjx_skills.sweeps.cell import Cell
from study import faster, two_cubes
from study.claims import LABEL, MEASURED, ci, compare, measured, reach
from study.results import Results


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    """A markdown table's lines."""
    return [
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
        *["| " + " | ".join(r) + " |" for r in rows],
    ]


def table5_1() -> list[str]:
    """Table 5.1 from the committed libraries' manifests (the default and the thesis's)."""
    from mjx_skills.core.paths import CHECKOUT
    from mjx_skills.methods import THESIS_LIBRARY
    from mjx_skills.skills.library import read_manifest
    from mjx_skills.skills.registry import DEFAULT_DIR
    from mjx_skills.skills.table import THESIS_CM

    libs = [("default", CHECKOUT / DEFAULT_DIR), ("thesis preset", CHECKOUT / THESIS_LIBRARY)]
    rows, found = [], []
    for label, path in libs:
        if not (path / "manifest.json").exists():
            continue
        m = read_manifest(path)
        found.append((label, m))
        for name, e in m["models"].items():
            if name not in THESIS_CM:  # a skill of the user's: the thesis has no figure
                continue
            rows.append(
                [
                    name,
                    f"{label} ({m['library']['anchor']})",
                    f"{m['samples'][name]['total']:,}",
                    f"{e['memory_error_cm']:.2f}",
                    f"{THESIS_CM[name][0]:.1f}",
                    f"{e['model_error_cm']:.2f}",
                    f"{THESIS_CM[name][1]:.1f}",
                    f"{e['goal_error_cm']:.2f}" if "goal_error_cm" in e else "-",
                    f"{e['classifier_auc']:.3f}",
                    f"{m['skill_success'][name]:.3f}",
                ]
            )
    if not found:
        return ["No skill library built yet (`make skills`)."]
    lines = table(
        [
            "skill",
            "library (anchor)",
            "runs",
            "memory cm",
            "thesis",
            "model cm",
            "thesis",
            "goal cm",
            "classifier AUC",
            "skill success",
        ],
        rows,
    )
    label, m = found[0]
    ours = {
        n: (e["memory_error_cm"], e["model_error_cm"])
        for n, e in m["models"].items()
        if n in THESIS_CM
    }
    beaten = [
        n for n, (mem, mod) in ours.items() if mem < THESIS_CM[n][0] and mod < THESIS_CM[n][1]
    ]
    net = all(mod < mem for mem, mod in ours.values())
    verdict = "beaten" if len(beaten) == len(ours) else "short"
    lines += [
        "",
        f"**C15** (the {label} library): both errors below the thesis's for "
        f"{len(beaten)} of {len(ours)} skills ({', '.join(beaten) or 'none'}): **{verdict}**; "
        f"the network beats memory for every skill: **{'matched' if net else 'short'}**. "
        "Errors are the mean terminal-position error (grip for transit, cube for grasp "
        "and transfer) on the held-out 10 % of successful runs.",
        *trivial_predictor(label, m),
    ]
    return lines


def presets() -> list[str]:
    """The thesis preset field by field, and what it changes (from methods.PRESETS)."""
    from mjx_skills.config import LibraryConfig
    from mjx_skills.methods import PRESETS, preset_options

    rows = [["library", "anchor", f"`{LibraryConfig().anchor}`", "`start`"]]
    for method, groups in PRESETS["thesis"].items():
        default = preset_options(method)
        for group, fields in groups.items():
            for field, value in fields.items():
                rows.append(
                    [
                        LABEL[method],
                        f"`--{group}.{field.replace('_', '-')}`",
                        f"`{getattr(default[group], field)}`",
                        f"`{value}`",
                    ]
                )
    return table(["method", "option", "default", "`--preset thesis`"], rows)


def cell_rows(r: Results, experiment: str) -> list[list[str]]:
    rows = []
    for cell, s in r.cells[experiment]:
        name = LABEL[cell.method] + (f" {cell.library}" if experiment == "fig6_4" else "")
        if s is None:
            rows.append([cell.task, name, "not run yet", "", "", "", ""])
            continue
        rows.append([cell.task, name, *measured(s), f"{s.wall_s / 60:.0f}"])
    return rows


CELL_HEADER = ["task", "method", *MEASURED, "min"]


VARIANTS = {
    "thesis_preset": ("thesis preset", None),
    "pas_single_goal": ("single goal", None),
    "take_out_held": ("held starts", None),
    "oracle": ("oracle explorer", None),
    "random_explorer": ("random skill explorer", None),
    "bc": ("", "ddpg_her_sl"),
    "bc_weight": ("weight 10", "ddpg_her_sl"),
    "fast": ("second default", "ddpg_her_sl"),
    **{e: (f"without {why}", base) for e, _, base, why in faster.ABLATION_CELLS},
}
"""Experiments compared cell by cell with another's: (their cells' tag, what they are
compared with: Fig. 6.3's (Fig. 6.5's) cell of that method (None: the same method), or an
experiment's name: its cell of the same task and method)."""


def baseline(r: Results, experiment: str, cell: Cell):
    """(The cell a variant cell is compared with, its summary or None)."""
    against = VARIANTS[experiment][1]
    if against in r.cells:
        return r.find(against, cell.task, cell.method)
    for figure in ("fig6_3", "fig6_5"):
        try:
            return r.find(figure, cell.task, against or cell.method)
        except KeyError:
            continue
    raise KeyError((experiment, cell.task, against or cell.method))


def variant_rows(r: Results, experiment: str) -> list[list[str]]:
    rows = []
    tag = VARIANTS[experiment][0]
    for cell, variant in r.cells[experiment]:
        base_cell, base = baseline(r, experiment, cell)
        same = base_cell.method == cell.method and not base_cell.label
        names = (
            LABEL[base_cell.method] + (", default" if same else ""),
            LABEL[cell.method] + (f", {tag}" if tag else ""),
        )
        if base and variant and base.epochs > variant.epochs:  # compared over the same epochs
            base = r.first_epochs(base_cell, base, variant.epochs)
            names = (f"{names[0]}, its first {variant.epochs} epochs", names[1])
        for name, s in zip(names, (base, variant), strict=True):
            first = s is base and variant is not None
            rows.append(
                [
                    cell.task,
                    name,
                    *([ci(s.last), reach(s.reach_90), ci(s.auc)] if s else ["not run yet", "", ""]),
                    *(
                        [compare(base, variant, f, names) for f in ("last", "auc")]
                        if first
                        else ["", ""]
                    ),
                ]
            )
    return rows


TITLES = {
    "fig6_3": "Fig. 6.3: four tasks, four methods",
    "fig6_4": "Fig. 6.4: reduced libraries (DDPG+HER+SL)",
    "fig6_5": "Fig. 6.5: a container behind a wall the skills never saw",
    "thesis_preset": "Our defaults against the thesis's formulation (`--preset thesis`)",
    "pas_single_goal": "Why PAS falls short on pick_move: PAS with the thesis's single goal",
    "take_out_held": "Why DDPG+HER falls short on take_out: half the starts with the cube in hand",
    "oracle": "The upper bound of exploration: DDPG+HER with the scripted controllers as its explorer",
    "random_explorer": "The trivial baseline of the search: DDPG+HER+SL exploring with a random "
    "skill and goal",
    "bc": "Beyond the thesis: DDPG+HER+SL+BC, the explorer's skills cloned where the critic agrees",
    "bc_weight": "DDPG+HER+SL+BC with ten times the cloning weight",
    **faster.TITLES,
    two_cubes.EXPERIMENT: two_cubes.TITLE,
}


def trivial_predictor(label: str, manifest: dict) -> list[str]:
    """The trivial baseline of Table 5.1: predict that a successful run ends at its goal
    ("goal cm", computed on the same held-out runs when the library is built), set against
    the thesis's memory errors and our model's."""
    from mjx_skills.skills.table import THESIS_CM

    models = {n: e for n, e in manifest["models"].items() if n in THESIS_CM}
    if not all("goal_error_cm" in e for e in models.values()):
        return []
    goal = {n: e["goal_error_cm"] for n, e in models.items()}
    under_thesis = [n for n in goal if goal[n] < THESIS_CM[n][0]]
    model_wins = [n for n in goal if models[n]["model_error_cm"] < goal[n]]
    memory_wins = [n for n in goal if models[n]["memory_error_cm"] < goal[n]]
    return [
        "",
        f"**The trivial predictor** (the {label} library): predicting that a successful run "
        f"ends exactly at its goal errs by {', '.join(f'{goal[n]:.2f}' for n in goal)} cm "
        f"({', '.join(goal)}), below the thesis's memory error for {len(under_thesis)} of "
        f"{len(goal)} skills: beating the thesis's figures alone shows little. Our model "
        f"beats the trivial predictor for {len(model_wins)} of {len(goal)} skills "
        f"({', '.join(model_wins) or 'none'}), our memory for {len(memory_wins)} "
        f"({', '.join(memory_wins) or 'none'}).",
    ]


def search_worth(r: Results) -> list[str]:
    """What the look-ahead search is worth over the random-skill explorer (the same learner,
    eps schedule and library): P(search > random) over seeds for the mean over epochs and
    the last 5 (rliable's probability of improvement, 95 % interval)."""
    from mjx_skills.analysis import stats

    out = []
    for cell, random in r.cells["random_explorer"]:
        base_cell, search = r.find("fig6_3", cell.task, cell.method)
        if random is None or search is None:
            continue
        a = stats.scores_from_rows(r.metrics[base_cell.name])
        b = stats.scores_from_rows(r.metrics[cell.name])
        p = {
            what: stats.improvement(pick(a), pick(b))
            for what, pick in (
                ("mean over epochs", lambda x: x.mean(axis=1)),
                ("last 5 epochs", lambda x: x[:, -stats.LAST :].mean(axis=1)),
            )
        }
        text = "; ".join(f"{w} {v[0]:.2f} [{v[1]:.2f}, {v[2]:.2f}]" for w, v in p.items())
        better = [w for w, v in p.items() if v[1] > 0.5]
        verdict = f"measurably better in the {' and the '.join(better)}" if better else "none"
        out.append(f"- {cell.task}: P(search > random skill) {text}; gain: {verdict}.")
    if not out:
        return []
    return [
        "",
        "What the search is worth (a seed of the search against a seed of the random-skill "
        "explorer; meaningful when the interval's low end is above 0.5):",
        "",
        *out,
    ]
