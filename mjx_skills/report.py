"""The results report, generated from the committed data: docs/results.md and its figures.

    python -m mjx_skills.report            # writes docs/results.md and docs/figures/*.png
    python -m mjx_skills.report --check    # fails if docs/results.md is not what the data gives

Reads the finished cells of the thesis's experiments from the cell store
(`experiments/results/cells/`, `mjx_skills.cells`; a cell counts only if today's definition
made it) and the skill libraries' manifests (Table 5.1). Every number in the report is
computed here (`mjx_skills.stats`), and every claim of the thesis's chapter 6 and Table 5.1
gets a verdict by the rule stated beside it. Cells not run yet are listed as such.
"""

from __future__ import annotations

import argparse
import difflib
import sys
from pathlib import Path

import numpy as np

from mjx_skills import cells, stats
from mjx_skills.experiments import Cell, load_experiment
from mjx_skills.logging import read_metrics

DOC = Path("docs") / "results.md"
FIGURES = Path("docs") / "figures"
EXPERIMENTS = ("fig6_3", "fig6_4", "fig6_5", "thesis_preset")
LABEL = {"ddpg_her": "DDPG+HER", "pas": "PAS", "mpas": "MPAS", "ddpg_her_sl": "DDPG+HER+SL"}
FAILS = 0.1
LEARNS = 0.5


class Results:
    """Every stored cell of the report's experiments, summarised, by (experiment, key)."""

    def __init__(self, store: Path = cells.STORE):
        self.cells: dict[str, list[tuple[Cell, stats.Summary | None]]] = {}
        for name in EXPERIMENTS:
            rows = []
            for cell in load_experiment(name).cells():
                where = cells.stored(cell, store)
                summary = None
                if where is not None:
                    metrics = read_metrics(where)
                    summary = stats.summarize(
                        stats.scores_from_rows(metrics), wall_s=max(m["wall_s"] for m in metrics)
                    )
                rows.append((cell, summary))
            self.cells[name] = rows

    def get(self, experiment: str, task: str, method: str, library: str = "SL1"):
        for cell, summary in self.cells[experiment]:
            if cell.task == task and cell.method == method and cell.library in (library, None):
                return summary
        raise KeyError((experiment, task, method, library))


# ------------------------------------------------------------------------------ formatting
def ci(triple) -> str:
    point, low, high = triple
    return f"{point:.2f} [{low:.2f}, {high:.2f}]"


def reach(epoch: int | None) -> str:
    return "never" if epoch is None else str(epoch)


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *["| " + " | ".join(r) + " |" for r in rows]]  # fmt: skip


# --------------------------------------------------------------------------------- verdicts
def learns(s, baseline=None) -> bool:
    """Last-5 mean >= 0.5 and (beside a baseline) its interval entirely above the baseline's."""
    return s.last[0] >= LEARNS and (baseline is None or s.last[1] > baseline.last[2])


def fails(s) -> bool:
    return s.last[0] < FAILS


def above(a, b, field: str = "auc") -> bool:
    """a's interval of `field` lies entirely above b's."""
    return getattr(a, field)[1] > getattr(b, field)[2]


def claims(r: Results) -> list[list[str]]:
    """Chapter 6's claims (C1-C14) -> rows of (id, claim, ours, verdict)."""
    g3 = lambda task, method: r.get("fig6_3", task, method)  # noqa: E731
    out = []

    def claim(cid, text, needs, evidence, verdict):
        if any(s is None for s in needs):
            out.append([cid, text, "not run yet", "-"])
        else:
            out.append([cid, text, evidence(), verdict()])

    for cid, task in (("C1", "pick_move"), ("C2", "put_in_container"), ("C3", "put_on")):
        s = g3(task, "ddpg_her")
        claim(cid, f"DDPG+HER fails {task}", [s], lambda s=s: f"last 5: {ci(s.last)}",
              lambda s=s: "matched" if fails(s) else "short")  # fmt: skip
    d, others = (
        g3("take_out", "ddpg_her"),
        [g3("take_out", m) for m in ("pas", "mpas", "ddpg_her_sl")],
    )
    claim("C4", "DDPG+HER learns take_out, slower than every other method", [d, *others],
          lambda: f"last 5: {ci(d.last)}; mean over epochs {ci(d.auc)} vs "
                  + ", ".join(f"{LABEL[m]} {ci(o.auc)}" for m, o in zip(("pas", "mpas", "ddpg_her_sl"), others, strict=True)),
          lambda: "matched" if learns(d) and all(above(o, d) for o in others) else "short")  # fmt: skip
    for task in ("pick_move", "put_in_container"):
        p, d = g3(task, "pas"), g3(task, "ddpg_her")
        claim("C5", f"PAS learns {task}", [p, d], lambda p=p: f"last 5: {ci(p.last)}",
              lambda p=p, d=d: "matched" if learns(p, d) else "short")  # fmt: skip
    m, p = g3("take_out", "mpas"), g3("take_out", "pas")
    claim("C6", "MPAS learns faster than PAS (take_out)", [m, p],
          lambda: f"mean over epochs: MPAS {ci(m.auc)}, PAS {ci(p.auc)}",
          lambda: "matched" if above(m, p) else "short")  # fmt: skip
    put_on = {k: g3("put_on", k) for k in LABEL}
    claim("C7", "put_on: every method learns; PAS and MPAS converge to about 0.8",
          list(put_on.values()),
          lambda: ", ".join(f"{LABEL[k]} {ci(s.last)}" for k, s in put_on.items()),
          lambda: ("short" if not all(learns(s) for s in put_on.values()) else
                   "beaten" if min(put_on["pas"].last[0], put_on["mpas"].last[0]) > 0.9 else
                   "matched"))  # fmt: skip
    for task in ("pick_move", "put_in_container"):
        s, d = g3(task, "ddpg_her_sl"), g3(task, "ddpg_her")
        claim("C8", f"DDPG+HER+SL learns {task} and converges to 1.0", [s, d],
              lambda s=s: f"last 5: {ci(s.last)}; 0.9 at epoch {reach(s.reach_90)}",
              lambda s=s, d=d: "matched" if learns(s, d) and s.last[0] >= 0.95 else "short")  # fmt: skip
    s, p, m = g3("put_on", "ddpg_her_sl"), g3("put_on", "pas"), g3("put_on", "mpas")
    claim("C9", "DDPG+HER+SL beats PAS and MPAS on put_on", [s, p, m],
          lambda: f"last 5: SL {ci(s.last)}, PAS {ci(p.last)}, MPAS {ci(m.last)}",
          lambda: "matched" if above(s, p, "last") and above(s, m, "last") else "short")  # fmt: skip
    g4 = lambda task, lib: r.get("fig6_4", task, "ddpg_her_sl", lib)  # noqa: E731
    a, b = g4("pick_move", "SL1"), g4("pick_move", "SL2")
    claim("C10", "SL1 learns pick_move faster than SL2", [a, b],
          lambda: f"mean over epochs: SL1 {ci(a.auc)}, SL2 {ci(b.auc)}",
          lambda: "matched" if above(a, b) else "short")  # fmt: skip
    a, b = g4("put_in_container", "SL1"), g4("put_in_container", "SL2")
    claim("C11", "SL2 is not slower than SL1 on put_in_container", [a, b],
          lambda: f"mean over epochs: SL1 {ci(a.auc)}, SL2 {ci(b.auc)}",
          lambda: "short" if above(a, b) else "matched")  # fmt: skip
    a, c = g4("put_in_container", "SL1"), g4("put_in_container", "SL3")
    claim("C12", "SL3 learns put_in_container slower than SL1", [a, c],
          lambda: f"mean over epochs: SL1 {ci(a.auc)}, SL3 {ci(c.auc)}",
          lambda: "matched" if above(a, c) else "short")  # fmt: skip
    reduced = [(t, lib, g4(t, lib), g3(t, "ddpg_her")) for t in ("pick_move", "put_in_container")
               for lib in ("SL2", "SL3")]  # fmt: skip
    claim("C13", "a reduced library (SL2, SL3) beats DDPG+HER",
          [x for row in reduced for x in row[2:]],
          lambda: ", ".join(f"{t} {lib} {ci(s.last)}" for t, lib, s, _ in reduced),
          lambda: "matched" if all(learns(s, d) for *_, s, d in reduced) else "short")  # fmt: skip
    s, d = (
        r.get("fig6_5", "container_wall", "ddpg_her_sl"),
        r.get("fig6_5", "container_wall", "ddpg_her"),
    )
    claim("C14", "container_wall: DDPG+HER+SL learns, DDPG+HER fails", [s, d],
          lambda: f"last 5: SL {ci(s.last)}, DDPG+HER {ci(d.last)}",
          lambda: "matched" if learns(s, d) and fails(d) else "short")  # fmt: skip
    return out


# ----------------------------------------------------------------------------- the sections
def table5_1() -> list[str]:
    """Table 5.1 from the committed libraries' manifests (the default and the thesis's)."""
    from mjx_skills.library import read_manifest
    from mjx_skills.methods import THESIS_LIBRARY
    from mjx_skills.skills import THESIS_CM

    libs = [("default", Path("experiments/skill_library")), ("thesis preset", Path(THESIS_LIBRARY))]
    rows, found = [], []
    for label, path in libs:
        if not (path / "manifest.json").exists():
            continue
        m = read_manifest(path)
        found.append((label, m))
        for name, e in m["models"].items():
            rows.append([name, f"{label} ({m['library']['anchor']})", f"{m['samples'][name]['total']:,}",
                         f"{e['memory_error_cm']:.2f}", f"{THESIS_CM[name][0]:.1f}",
                         f"{e['model_error_cm']:.2f}", f"{THESIS_CM[name][1]:.1f}",
                         f"{e['classifier_auc']:.3f}", f"{m['skill_success'][name]:.3f}"])  # fmt: skip
    if not found:
        return ["No skill library built yet (`make skills`)."]
    lines = table(["skill", "library (anchor)", "runs", "memory cm", "thesis", "model cm", "thesis",
                   "classifier AUC", "skill success"], rows)  # fmt: skip
    label, m = found[0]
    ours = {n: (e["memory_error_cm"], e["model_error_cm"]) for n, e in m["models"].items()}
    beaten = [n for n, (mem, mod) in ours.items()
              if mem < THESIS_CM[n][0] and mod < THESIS_CM[n][1]]  # fmt: skip
    net = all(mod < mem for mem, mod in ours.values())
    verdict = "beaten" if len(beaten) == len(ours) else "short"
    lines += ["", f"**C15** (the {label} library): both errors below the thesis's for "
              f"{len(beaten)} of {len(ours)} skills ({', '.join(beaten) or 'none'}): **{verdict}**; "
              f"the network beats memory for every skill: **{'matched' if net else 'short'}**. "
              "Errors are the mean terminal-position error (grip for transit, cube for grasp "
              "and transfer) on the held-out 10 % of successful runs."]  # fmt: skip
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
                rows.append([LABEL[method], f"`--{group}.{field.replace('_', '-')}`",
                             f"`{getattr(default[group], field)}`", f"`{value}`"])  # fmt: skip
    return table(["method", "option", "default", "`--preset thesis`"], rows)


def cell_rows(r: Results, experiment: str) -> list[list[str]]:
    rows = []
    for cell, s in r.cells[experiment]:
        name = LABEL[cell.method] + (f" {cell.library}" if experiment == "fig6_4" else "")
        if s is None:
            rows.append([cell.task, name, "not run yet", "", "", "", ""])
            continue
        rows.append([cell.task, name, f"{s.seeds} x {s.epochs}", ci(s.last), reach(s.reach_90),
                     ci(s.auc), f"{s.wall_s / 60:.0f}"])  # fmt: skip
    return rows


CELL_HEADER = ["task", "method", "seeds x epochs", "last 5 epochs [95 % CI]", "0.9 at epoch",
               "mean over epochs [95 % CI]", "min"]  # fmt: skip


def preset_rows(r: Results) -> list[list[str]]:
    rows = []
    for cell, thesis in r.cells["thesis_preset"]:
        default = r.get("fig6_3", cell.task, cell.method)
        for label, s in (("default", default), ("thesis preset", thesis)):
            rows.append([cell.task, f"{LABEL[cell.method]}, {label}",
                         *([ci(s.last), reach(s.reach_90), ci(s.auc)] if s else ["not run yet", "", ""])])  # fmt: skip
    return rows


def figure(r: Results, experiment: str, out: Path, draw: bool = True) -> Path | None:
    """Eval success per epoch, mean over seeds with the 95 % interval shaded, one panel per
    task -> `out` (None: no cell finished yet). `draw=False` only says where it would be."""
    done = [(c, s) for c, s in r.cells[experiment] if s is not None]
    if not done or not draw:
        return out if done else None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = list(dict.fromkeys(c.task for c, _ in r.cells[experiment]))
    fig, axes = plt.subplots(1, len(tasks), figsize=(4.2 * len(tasks), 3.4), squeeze=False)
    for ax, task in zip(axes[0], tasks, strict=True):
        pairs = [(c, s) for c, s in done if c.task == task]
        if experiment == "thesis_preset":
            pairs = [x for c, s in pairs for x in (((c, "default"), r.get("fig6_3", task, c.method)),
                                                  ((c, "thesis"), s)) if x[1] is not None]  # fmt: skip
        for key, s in pairs:
            cell, tag = key if isinstance(key, tuple) else (key, "")
            label = LABEL[cell.method] + (f" {cell.library}" if experiment == "fig6_4" else "")
            label += f" ({tag})" if tag else ""
            x = np.arange(1, s.epochs + 1)
            (line,) = ax.plot(x, s.curve, label=label, lw=1.4)
            ax.fill_between(x, s.curve_low, s.curve_high, color=line.get_color(), alpha=0.2, lw=0)
        ax.set(title=task, xlabel="epoch (16 episodes)", ylim=(-0.02, 1.02))
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("eval success (20 episodes)")
    axes[0][-1].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


TITLES = {"fig6_3": "Fig. 6.3: four tasks, four methods",
          "fig6_4": "Fig. 6.4: reduced libraries (DDPG+HER+SL)",
          "fig6_5": "Fig. 6.5: a container behind a wall the skills never saw",
          "thesis_preset": "Our defaults against the thesis's formulation (`--preset thesis`)"}  # fmt: skip


def render(r: Results, draw: bool = True) -> str:
    """The report's markdown (and, with `draw`, its figures)."""
    spent = sum(s.wall_s for rows in r.cells.values() for _, s in rows if s is not None)
    done = sum(s is not None for rows in r.cells.values() for _, s in rows)
    total = sum(len(rows) for rows in r.cells.values())
    lines = [
        "# Results: the thesis's chapter 6 and Table 5.1 on this code",
        "",
        "<!-- generated by `python -m mjx_skills.report` from experiments/results/cells and the "
        "skill libraries' manifests; do not edit (`--check` fails on any difference) -->",
        "",
        "How the numbers are computed: eval success is the share of 20 episodes with the frozen "
        "deterministic policy after each epoch (1 epoch = 16 training episodes). For each cell: "
        f"the mean over seeds, with a 95 % stratified bootstrap interval over seeds (rliable, "
        f"{stats.REPS} replications, percentile); **last 5 epochs** = each seed's mean over its "
        "last 5 epochs, averaged over seeds; **0.9 at epoch** = the first epoch at which the "
        "5-epoch rolling mean of the seeds' mean reaches 0.9; **mean over epochs** = the mean "
        "success over all epochs (the area under the curve), the measure of speed. "
        f"{done} of {total} cells are in; together they took {spent / 3600:.1f} h of wall time on "
        "2 CPU cores (cells ran two at a time).",
        "",
        "Verdict rules: a method **learns** a task when its last-5 mean is >= "
        f"{LEARNS} and its interval lies entirely above DDPG+HER's on that task; it **fails** when "
        f"its last-5 mean is < {FAILS}; A is **faster** than B when A's interval of the mean over "
        "epochs lies entirely above B's. **matched**: our data shows the claim; **beaten**: it "
        "shows more than the claim; **short**: it does not show it.",
        "",
        "## The thesis's claims",
        "",
        *table(["id", "claim (thesis ch. 6)", "ours", "verdict"], claims(r)),
        "",
        "## Table 5.1: the skill library's models and memories",
        "",
        *table5_1(),
    ]
    for experiment in EXPERIMENTS:
        lines += ["", f"## {TITLES[experiment]}", ""]
        if figure(r, experiment, FIGURES / f"{experiment}.png", draw) is not None:
            lines += [f"![{TITLES[experiment]}](figures/{experiment}.png)", ""]
        if experiment == "thesis_preset":
            lines += [*presets(), "", *table(["task", "method", "last 5 epochs [95 % CI]",
                                              "0.9 at epoch", "mean over epochs [95 % CI]"],
                                             preset_rows(r))]  # fmt: skip
        else:
            lines += table(CELL_HEADER, cell_rows(r, experiment))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    p.add_argument("--check", action="store_true",
                   help="compare with the committed docs/results.md instead of writing it")  # fmt: skip
    args = p.parse_args(argv)
    try:
        text = render(Results(), draw=not args.check)
    except ValueError as err:  # a stored cell of another definition
        raise SystemExit(f"error: {err}") from None
    if args.check:
        old = DOC.read_text() if DOC.exists() else ""
        if old != text:
            diff = difflib.unified_diff(old.splitlines(), text.splitlines(), str(DOC),
                                        "from the data", lineterm="", n=0)  # fmt: skip
            sys.exit(
                "docs/results.md is not what the data gives; run `python -m "
                "mjx_skills.report`:\n" + "\n".join(list(diff)[:40])
            )
        print(f"{DOC} matches the data")
        return
    DOC.parent.mkdir(parents=True, exist_ok=True)
    DOC.write_text(text)
    print(f"wrote {DOC} and {FIGURES}/")


if __name__ == "__main__":
    main()
