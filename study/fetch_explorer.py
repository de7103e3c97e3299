"""What a Fetch headline's explorer showed its learner, from the headline cell's own metrics:
how often its training episodes reached the goal while the look-ahead search explored (eps
decaying over `--search.eps-decay-epochs`), how far the frozen policy had come when the
exploration ended, and when it reached the target's level on its own afterwards."""

from __future__ import annotations

from mjx_skills.analysis import stats
from mjx_skills.sweeps.experiment_file import names, raw
from mjx_skills.sweeps.experiments import load_experiment
from mjx_skills.sweeps.seeds import describe, seed_range
from study.fetch_claims import fresh
from study.headlines import experiments


def fast_sentence(task: str, end: int, level: float, found) -> str:
    """What DDPG+HER+SL+Fast (a learner that takes more from each episode) showed on `task`:
    its stored cell's (a fresh-seed one if there is one; never a matched baseline's) 5-epoch
    mean over the same epochs as the DDPG+HER+SL sentence's, those up to `end` (its last
    epochs if it stops before, said as such), when it reaches `level`, and how else it
    differs (its explorer's schedule, its gradient steps, an evaluated policy that also acts
    with the skills); or the experiment that measures it while none is stored; '' if no
    experiment runs it."""
    runs = [
        run
        for run in found
        if _is_fast(run[1].method, run[1].task, task)
        and load_experiment(run[0]).group != "baseline"  # a matched baseline has no library
    ]
    if runs:  # a headline's cell (fresh seeds) before a tuning cell
        label, cell, rows = min(runs, key=lambda run: not fresh(run[0]))
        evals = stats.scores_from_rows(rows).mean(axis=0)
        stop = min(end, len(evals))  # a cell that stops before: its last epochs
        window = slice(max(0, stop - stats.WINDOW), stop)
        hit = stats.first_reaching(evals, level)
        reached = f"reaches {level} at epoch {hit}" if hit else f"never reaches {level}"
        seeds = describe(seed_range(cell.seed, cell.seeds))
        epochs = f"{window.start + 1}-{stop}"
        which = (
            f"the same epochs {epochs}"
            if stop == end
            else f"its last epochs {epochs} (it stops at epoch {stop})"
        )
        options = cell.run_args(out="", progress=False).full_options()
        search, fast = options["search"], options["fast"]
        return (
            f" A learner that takes more from each episode, DDPG+HER+SL+Fast ({label}, seeds "
            f"{seeds}), succeeds on {evals[window].mean():.2f} over {which} and {reached}; it differs in more than its learner: "
            f"its explorer's eps decays over {search.eps_decay_epochs} epochs to a floor of "
            f"{search.eps_end:g}, it takes {fast.updates_per_cycle} gradient steps a cycle"
            + (
                ", and its evaluated policy also acts with the library's skills (the critic "
                "picks among their actions)."
                if fast.pick
                else "."
            )
        )
    files = [n for n in names() if _is_fast(*_method_task(raw(n)), task)]
    if not files:
        return ""
    return (
        " Whether a learner that takes more from each episode (DDPG+HER+SL+Fast) absorbs "
        f"more of it before the explorer stops is what {files[0]} measures (not run yet)."
    )


def _is_fast(method: str, task: str, wanted: str) -> bool:
    return method == "ddpg_her_sl_fast" and task == wanted


def _method_task(experiment: dict) -> tuple[str, str]:
    """(method, task) of an experiment file with one of each; ('', '') otherwise."""
    methods, tasks = experiment.get("methods", []), experiment.get("tasks", [])
    return (methods[0], tasks[0]) if len(methods) == 1 and len(tasks) == 1 else ("", "")


def paragraph(found) -> list[str]:
    """One sentence per DDPG+HER+SL headline on a Fetch task among `found` ((label, cell,
    metrics rows) of the section's stored cells), with what DDPG+HER+SL+Fast showed there."""
    headlines = {exp.name: exp for exp in experiments()}
    out = []
    for label, cell, rows in found:
        if label not in headlines or cell.method != "ddpg_her_sl":
            continue
        level, target = headlines[label].target["level"], headlines[label].target["epoch"]
        args = cell.run_args(out="", progress=False)
        end = min(args.full_options()["search"].eps_decay_epochs, cell.epochs)
        if end < 1:  # no exploration schedule to speak of
            continue
        updates = args.train.updates_per_cycle
        train = stats.scores_from_rows(rows, "train_success").mean(axis=0)
        evals = stats.scores_from_rows(rows).mean(axis=0)
        window = slice(max(0, end - stats.WINDOW), end)
        hit = stats.first_reaching(evals, level)
        after = f"reached {level} at epoch {hit}" if hit else f"never reached {level}"
        out.append(
            f"What {label}'s explorer showed its learner: while the search explored (eps "
            f"decaying over epochs 1-{end}), {train[:end].mean():.2f} of its training "
            f"episodes reached the goal, but its frozen policy succeeded on "
            f"{evals[window].mean():.2f} of its evaluations over epochs "
            f"{window.start + 1}-{end}; on its own after that, the policy {after} (the "
            f"target: epoch {target}; {updates} gradient steps a cycle)."
            + fast_sentence(cell.task, end, level, found)
        )
    return ["", *out] if out else []
