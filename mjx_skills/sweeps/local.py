"""Running a sweep's cells on this machine, one at a time or `jobs` at once in worker
processes (`core.workers`), and what a cell's directory holds: its run, whether it finished,
a shorter budget's run it can train on from, where its results are (the store,
`sweeps.cells`)."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

from tqdm.auto import tqdm

from mjx_skills.core.files import read_json
from mjx_skills.sweeps.cell import Cell


def cell_run_dir(cell_dir: Path) -> Path | None:
    """The one run directory under a cell's directory, if it was started."""
    if cell_dir.name.startswith("library-"):
        return cell_dir / "library"
    runs = sorted(cell_dir.glob("*/*/*/config.json"))
    if len(runs) > 1:
        raise RuntimeError(f"{cell_dir} holds {len(runs)} runs; a cell has one")
    return runs[0].parent if runs else None


def finished(run_dir: Path | None, cell: Cell) -> bool:
    """Every seed of the cell logged its last epoch (a library cell: the library is saved)."""
    if cell.samples:
        return run_dir is not None and (run_dir / "manifest.json").exists()
    if run_dir is None or not (run_dir / "metrics.jsonl").exists():
        return False
    from mjx_skills.training.metrics_log import read_metrics

    last = [r for r in read_metrics(run_dir) if r["epoch"] == cell.epochs]
    return len({r["seed"] for r in last}) == cell.seeds


def shorter_budget(run_dir: Path, cell: Cell) -> int | None:
    """The run's budget if it is `cell`'s definition with fewer epochs, else None."""
    import dataclasses

    from mjx_skills.sweeps import cells

    epochs = read_json(run_dir / "config.json")["train"]["epochs"]
    shorter = dataclasses.replace(cell, epochs=epochs)
    return epochs if epochs < cell.epochs and not cells.run_differences(run_dir, shorter) else None


def copy_shorter_run(cell: Cell, cell_dir: Path) -> Path | None:
    """The longest run of `cell` at a shorter budget in this sweep's directory (a sibling
    cell directory named as `cell` but for its epochs), copied into `cell_dir` so that the
    cell trains on from its last checkpoint instead of from scratch (`train --resume RUN
    --epochs N`, which equals a run started with the longer budget); None if there is none.
    The shorter run is left as it was."""
    import shutil

    prefix = cell.name.removesuffix(f"-e{cell.epochs}")
    found = []
    for other in cell_dir.parent.glob(f"{prefix}-e*"):
        run = cell_run_dir(other) if other.name[len(prefix) + 2 :].isdigit() else None
        budget = None if run is None else shorter_budget(run, cell)
        if budget is not None:
            found.append((budget, other, run))
    if not found:
        return None
    _, other, run = max(found, key=lambda x: x[0])
    partial = cell_dir / ".partial"  # copied whole or not at all: a resume never sees half
    shutil.rmtree(partial, ignore_errors=True)
    shutil.copytree(run, partial)
    copy = cell_dir / run.relative_to(other)
    copy.parent.mkdir(parents=True, exist_ok=True)
    return partial.rename(copy)


def result_dir(cell: Cell, cell_dir: Path, store: Path) -> Path | None:
    """Where a finished cell's results are (the store; a library cell: its library)."""
    if cell.samples:
        run_dir = cell_run_dir(cell_dir)
        return run_dir if finished(run_dir, cell) else None
    from mjx_skills.sweeps import cells

    return cells.stored(cell, store)


def run_cells_local(
    run_cell: Callable[[Cell, str, bool, str], str],
    cells: list[Cell],
    dirs: list[Path],
    jobs: int,
    progress: bool,
    store: Path,
    pin: bool = False,
) -> list[str]:
    """`run_cell(cell, cell_dir, progress, store)` of every cell, `jobs` at a time (in worker processes when jobs > 1; `pin`: each on its
    own cores) -> the directories of their results."""
    todo = [
        i
        for i, (c, d) in enumerate(zip(cells, dirs, strict=True))
        if result_dir(c, d, store) is None
    ]
    for i, cell in enumerate(cells):
        state = "running" if i in todo else "done"
        print(f"[cell {i + 1}/{len(cells)}] {cell.name}: {state}", file=sys.stderr)
    jobs = min(jobs, len(todo))
    if jobs <= 1 or cells[0].samples:  # library cells share one work dir: one at a time
        for i in todo:
            run_cell(cells[i], str(dirs[i]), progress, str(store))
            if result_dir(cells[i], dirs[i], store) is None:
                break  # stopped by Ctrl-C or SIGTERM (it saved): the rest wait for a rerun
    else:
        from mjx_skills.core.workers import run_pool

        with tqdm(
            total=len(todo), desc=f"cells ({jobs} at once)", unit="cell", disable=not progress
        ) as bar:
            calls = [(cells[i], str(dirs[i]), False, str(store)) for i in todo]
            for k, _ in run_pool(run_cell, calls, jobs, pin):
                bar.set_postfix_str(cells[todo[k]].name)
                bar.update(1)
    # Read back in the experiment's order.
    found = [result_dir(c, d, store) for c, d in zip(cells, dirs, strict=True)]
    unfinished = [c.name for c, r in zip(cells, found, strict=True) if r is None]
    if unfinished:  # a worker interrupted (Ctrl-C): it saved; starting again resumes
        raise SystemExit(f"error: cells not finished: {', '.join(unfinished)}; run again to resume")
    return [str(r) for r in found]
