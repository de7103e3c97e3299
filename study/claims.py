"""The thesis's chapter 6 claims (C1-C14, C17) as verdicts on our data.

Each claim reads the summaries of the cells it is about (`results.Results`) and gets
'matched' (our data shows it), 'beaten' (it shows more), 'short' (it does not) or, while
a cell is missing, 'not run yet'. The rules: a method *learns* a task when its last-5
mean is >= LEARNS and its interval lies entirely above DDPG+HER's there; it *fails* when
its last-5 mean is < FAILS; A is *faster* than B when A's interval of the mean over epochs
lies entirely above B's.
"""

from __future__ import annotations

from mjx_skills.analysis.stats import Summary
from mjx_skills.methods import METHODS

FAILS = 0.1
LEARNS = 0.5
LABEL = {name: spec.label for name, spec in METHODS.items()}
"""Each method's label, in the registry's order (the figures' colours follow it)."""
THESIS_METHODS = ("ddpg_her", "pas", "mpas", "ddpg_her_sl")
"""The four methods the thesis compares (Fig. 6.3), in its order."""


def ci(triple) -> str:
    point, low, high = triple
    return f"{point:.2f} [{low:.2f}, {high:.2f}]"


def reach(epoch: int | None) -> str:
    return "never" if epoch is None else str(epoch)


def seeds(n: int) -> str:
    """'1 seed', '3 seeds'."""
    return f"{n} seed" + ("s" if n != 1 else "")


MEASURED = [
    "seeds x epochs",
    "last 5 epochs [95 % CI]",
    "0.9 at epoch",
    "mean over epochs [95 % CI]",
]
"""The headers of `measured`'s columns."""


def measured(s: Summary) -> list[str]:
    """A cell's columns: seeds x epochs, last 5 epochs, 0.9 at epoch, mean over epochs."""
    return [f"{s.seeds} x {s.epochs}", ci(s.last), reach(s.reach_90), ci(s.auc)]


def learns(s: Summary, baseline: Summary | None = None) -> bool:
    """Last-5 mean >= 0.5 and (beside a baseline) its interval entirely above the baseline's."""
    return s.last[0] >= LEARNS and (baseline is None or s.last[1] > baseline.last[2])


def fails(s: Summary) -> bool:
    return s.last[0] < FAILS


def above(a: Summary, b: Summary, field: str = "auc") -> bool:
    """a's interval of `field` lies entirely above b's."""
    return getattr(a, field)[1] > getattr(b, field)[2]


def reaches_one(s) -> bool:
    """The last-5 mean's 95 % interval reaches 1.0: the data cannot tell the policy from
    the optimal one (rounding aside: eval success is a multiple of 1/20 per epoch)."""
    return round(s.last[2], 6) >= 1.0


def compare(a, b, field: str, names: tuple[str, str]) -> str:
    """The name of the one of a, b higher in `field` by the interval rule ('overlap' if
    neither; '' while one is not run)."""
    if a is None or b is None:
        return ""
    return names[0] if above(a, b, field) else names[1] if above(b, a, field) else "overlap"


def claims(r) -> list[list[str]]:
    """Chapter 6's claims (C1-C14; C17: section 6.2's) -> rows of (id, claim, ours, verdict)."""
    g3 = lambda task, method: r.get("fig6_3", task, method)  # noqa: E731
    out = []

    def claim(cid, text, needs, evidence, verdict):
        if any(s is None for s in needs):
            out.append([cid, text, "not run yet", "-"])
        else:
            out.append([cid, text, evidence(), verdict()])

    for cid, task in (("C1", "pick_move"), ("C2", "put_in_container"), ("C3", "put_on")):
        s = g3(task, "ddpg_her")
        claim(
            cid,
            f"DDPG+HER fails {task}",
            [s],
            lambda s=s: f"last 5: {ci(s.last)}",
            lambda s=s: "matched" if fails(s) else "short",
        )
    d, others = (
        g3("take_out", "ddpg_her"),
        [g3("take_out", m) for m in ("pas", "mpas", "ddpg_her_sl")],
    )
    c4 = "DDPG+HER learns take_out, slower than every other method"
    if d is not None and not learns(d):  # short whatever the others do
        out.append(["C4", c4, f"last 5: {ci(d.last)}", "short"])
    else:
        claim(
            "C4",
            c4,
            [d, *others],
            lambda: (
                f"last 5: {ci(d.last)}; mean over epochs {ci(d.auc)} vs "
                + ", ".join(
                    f"{LABEL[m]} {ci(o.auc)}"
                    for m, o in zip(("pas", "mpas", "ddpg_her_sl"), others, strict=True)
                )
            ),
            lambda: "matched" if all(above(o, d) for o in others) else "short",
        )
    for task in ("pick_move", "put_in_container"):
        p, d = g3(task, "pas"), g3(task, "ddpg_her")
        claim(
            "C5",
            f"PAS learns {task}",
            [p, d],
            lambda p=p: f"last 5: {ci(p.last)}",
            lambda p=p, d=d: "matched" if learns(p, d) else "short",
        )
    m, p = g3("take_out", "mpas"), g3("take_out", "pas")
    claim(
        "C6",
        "MPAS learns faster than PAS (take_out)",
        [m, p],
        lambda: f"mean over epochs: MPAS {ci(m.auc)}, PAS {ci(p.auc)}",
        lambda: "matched" if above(m, p) else "short",
    )
    # "all the methods can learn" (6.3c) are the library's: C3 has DDPG+HER fail put_on.
    put_on = {k: g3("put_on", k) for k in THESIS_METHODS if k != "ddpg_her"}
    base = g3("put_on", "ddpg_her")
    claim(
        "C7",
        "put_on: PAS, MPAS and DDPG+HER+SL learn; PAS and MPAS converge to about 0.8",
        [*put_on.values(), base],
        lambda: ", ".join(f"{LABEL[k]} {ci(s.last)}" for k, s in put_on.items()),
        lambda: (
            "short"
            if not all(learns(s, base) for s in put_on.values())
            else "beaten"
            if min(put_on["pas"].last[0], put_on["mpas"].last[0]) > 0.9
            else "matched"
        ),
    )
    for task in ("pick_move", "put_in_container"):
        s, d = g3(task, "ddpg_her_sl"), g3(task, "ddpg_her")
        claim(
            "C8",
            f"DDPG+HER+SL learns {task} and converges to the optimal policy (1.0: here, the "
            "last-5 interval reaches 1.0)",
            [s, d],
            lambda s=s: f"last 5: {ci(s.last)}; 0.9 at epoch {reach(s.reach_90)}",
            lambda s=s, d=d: "matched" if learns(s, d) and reaches_one(s) else "short",
        )
    s, p, m = g3("put_on", "ddpg_her_sl"), g3("put_on", "pas"), g3("put_on", "mpas")
    claim(
        "C9",
        "DDPG+HER+SL beats PAS and MPAS on put_on",
        [s, p, m],
        lambda: f"last 5: SL {ci(s.last)}, PAS {ci(p.last)}, MPAS {ci(m.last)}",
        lambda: "matched" if above(s, p, "last") and above(s, m, "last") else "short",
    )
    g4 = lambda task, lib: r.get("fig6_4", task, "ddpg_her_sl", lib)  # noqa: E731
    a, b = g4("pick_move", "SL1"), g4("pick_move", "SL2")
    claim(
        "C10",
        "SL1 learns pick_move faster than SL2",
        [a, b],
        lambda: f"mean over epochs: SL1 {ci(a.auc)}, SL2 {ci(b.auc)}",
        lambda: "matched" if above(a, b) else "short",
    )
    a, b = g4("put_in_container", "SL1"), g4("put_in_container", "SL2")
    claim(
        "C11",
        "SL2 is not slower than SL1 on put_in_container",
        [a, b],
        lambda: f"mean over epochs: SL1 {ci(a.auc)}, SL2 {ci(b.auc)}",
        lambda: "short" if above(a, b) else "matched",
    )
    a, c = g4("put_in_container", "SL1"), g4("put_in_container", "SL3")
    d = g3("put_in_container", "ddpg_her")
    claim(
        "C12",
        "SL3 learns put_in_container, slower than SL1 (it converges)",
        [a, c, d],
        lambda: f"mean over epochs: SL1 {ci(a.auc)}, SL3 {ci(c.auc)}; SL3 last 5: {ci(c.last)}",
        lambda: "matched" if learns(c, d) and above(a, c) else "short",
    )
    reduced = [
        (t, lib, g4(t, lib), g3(t, "ddpg_her"))
        for t in ("pick_move", "put_in_container")
        for lib in ("SL2", "SL3")
    ]
    claim(
        "C13",
        "a reduced library (SL2, SL3) beats DDPG+HER",
        [x for row in reduced for x in row[2:]],
        lambda: ", ".join(f"{t} {lib} {ci(s.last)}" for t, lib, s, _ in reduced),
        lambda: "matched" if all(learns(s, d) for *_, s, d in reduced) else "short",
    )
    s, d = (
        r.get("fig6_5", "container_wall", "ddpg_her_sl"),
        r.get("fig6_5", "container_wall", "ddpg_her"),
    )
    claim(
        "C14",
        "container_wall: DDPG+HER+SL works better than random exploration (Fig. 6.5b's "
        "caption), DDPG+HER fails",
        [s, d],
        lambda: f"last 5: SL {ci(s.last)}, DDPG+HER {ci(d.last)}",
        lambda: "matched" if above(s, d, "last") and fails(d) else "short",
    )
    claim(
        "C14",
        "container_wall: DDPG+HER+SL learns (the text: it performs the task)",
        [s, d],
        lambda: f"last 5: SL {ci(s.last)}",
        lambda: "matched" if learns(s, d) else "short",
    )
    narrow = r.find("fast_no_wide", "pick_move", "ddpg_her_sl_fast")[1]
    cell, wide = r.find("fast_first", "pick_move", "ddpg_her_sl_fast")
    if narrow is not None and wide is not None:
        wide = r.first_epochs(cell, wide, narrow.epochs)  # over the ablation's epochs
    claim(
        "C17",
        "other network sizes do not learn faster or better (6.2; tested here on "
        "DDPG+HER+SL+Fast's learner: 3 x 64 against its 3 x 256)",
        [narrow, wide],
        lambda: f"mean over epochs: 3 x 256 {ci(wide.auc)}, 3 x 64 {ci(narrow.auc)}",
        lambda: "short" if above(wide, narrow) or above(narrow, wide) else "matched",
    )
    return out
