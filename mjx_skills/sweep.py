"""Sweeps: the thesis's experiments (and ad-hoc grids) as cells of training runs.

    python -m mjx_skills.sweep --experiment smoke
    python -m mjx_skills.sweep --experiment NAME --seeds 3 --epochs 50  # experiments/NAME.toml
    python -m mjx_skills.sweep --tasks pick_move take_out --methods pas mpas --seeds 3
    python -m mjx_skills.sweep --experiment NAME --jobs 1             # one cell at a time
    python -m mjx_skills.sweep --experiment NAME --estimate           # wall time, no training
    python -m mjx_skills.sweep --experiment NAME --ray local          # cells as Ray tasks
    python -m mjx_skills.sweep --list

An experiment is a small TOML file in experiments/ (`experiments/NAME.toml`, read by
`mjx_skills.sweeps.experiments`): tasks x methods x libraries, a budget and option overrides. A
cell is one (task, method, library) training run with all its seeds in one vmapped
program (`runner.train_run`). Locally `--jobs N` cells run at once, each in its own worker
process (`mjx_skills.core.workers`; default one cell per core, `--pin` to pin each to its own
cores; docs/benchmarks.md "Speed" has the measured gain); results are the same bits whatever N is.
With `--ray ADDRESS` or `--ray local` each cell is a Ray task (the `ray` extra).
`--estimate` prints the expected wall time from the measured epoch costs
(`mjx_skills.sweeps.cost`) without training.

Resumable: a cell runs in SWEEP_DIR/CELL/ (default runs/sweeps/NAME/) and, once finished, its
metrics are kept with its definition in experiments/results/cells/CELL/ (`mjx_skills.sweeps.cells`,
committed): a stored cell of the same definition is taken instead of trained, whichever
experiment asks for it, and an interrupted one resumes from its checkpoint. A stored cell
or a run made by another definition of the cell is refused with the fields that differ.
A cell whose epochs grew trains on from the run of its shorter budget in the same sweep
directory (copied; the shorter run is left as it was) instead of from scratch. When every cell is done the results are aggregated into
experiments/results/NAME.csv (mean and std of eval success over seeds per epoch) and NAME.jsonl
(every seed's metrics); existing results are not overwritten without --overwrite.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import sys
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from mjx_skills.cli_args import positive_int
from mjx_skills.core.files import read_json, write_text_atomic
from mjx_skills.core.paths import check_writable_path, directory
from mjx_skills.sweeps.experiments import Cell, Experiment, adhoc, load_experiment, names
from mjx_skills.sweeps.ray_cells import run_cells_ray
from mjx_skills.training.interrupt import INTERRUPTED

RESULTS = Path("experiments") / "results"
STORE = RESULTS / "cells"
CSV_FIELDS = ("experiment", "task", "method", "library", "epoch", "episodes", "env_steps",
              "eval_success_mean", "eval_success_std", "seeds", "wall_s")  # fmt: skip


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


def run_cell(cell: Cell, cell_dir: str, progress: bool = True, store: str = str(STORE)) -> str:
    """Train (or resume, or take from the store) one cell -> the directory of its results
    (a stored cell, `mjx_skills.sweeps.cells`; a library cell: the library). Runs in this process
    or in a worker: imports JAX only here. A run in `cell_dir` made by another definition
    is refused with the fields that differ."""
    from mjx_skills.core import compile_cache
    from mjx_skills.core.precision import use_float32
    from mjx_skills.sweeps import cells
    from mjx_skills.training.runner import RunArgs, train_run

    compile_cache.enable()
    use_float32()
    run_dir = cell_run_dir(Path(cell_dir))
    if cell.samples:
        if finished(run_dir, cell):
            return str(run_dir)
        return str(build_library(cell, Path(cell_dir), progress))
    hit = cells.stored(cell, Path(store))
    if hit is not None:
        return str(hit)
    run_dir = run_dir or copy_shorter_run(cell, Path(cell_dir))
    # A run of this cell's definition at a shorter budget trains on to the cell's.
    shorter = run_dir is not None and shorter_budget(run_dir, cell) is not None
    diff = [] if run_dir is None or shorter else cells.run_differences(run_dir, cell)
    if diff:
        raise ValueError(f"{run_dir} was run with another definition of {cell.name} "
                         f"({'; '.join(diff[:6])}); delete {cell_dir} or use another "
                         "--sweep-dir")  # fmt: skip
    if not finished(run_dir, cell):
        args = (RunArgs(resume=str(run_dir), extend_to=cell.epochs if shorter else None)
                if run_dir else cell.run_args(cell_dir, progress))  # fmt: skip
        run_dir = train_run(args)
        if not finished(run_dir, cell):  # interrupted: it saved, starting again resumes
            return str(run_dir)
    return str(cells.save(cell, run_dir, Path(store)))


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


def build_library(cell: Cell, cell_dir: Path, progress: bool) -> Path:
    """A library from `cell.samples` runs per skill; the sweep's libraries share one work
    directory (the trained skills), and a library is written whole or not at all."""
    from mjx_skills.build_library import SkillsArgs, build
    from mjx_skills.config import LibraryConfig

    overrides = dict(dict(cell.options).get("library", ()))
    args = SkillsArgs(config=LibraryConfig(samples=cell.samples, **overrides),
                      out=str(cell_dir / "library"), progress=progress)  # fmt: skip
    return build(args, work=cell_dir.parent / "skills.work")


def aggregate(experiment: str, cells: list[Cell], run_dirs: list[Path]) -> tuple[list, list]:
    """-> (CSV rows: mean / std over seeds per epoch and cell, JSONL rows: every seed).
    `run_dirs`: the stored cells, verified as read (ValueError naming a damaged file)."""
    from mjx_skills.sweeps.cells import read_stored_metrics

    rows, per_seed = [], []
    for cell, run_dir in zip(cells, run_dirs, strict=True):
        metrics = read_stored_metrics(run_dir)
        tag = {"experiment": experiment, "task": cell.task, "method": cell.method,
               "library": cell.library or "-"}  # fmt: skip
        per_seed += [{**tag, **m} for m in metrics]
        for epoch in sorted({m["epoch"] for m in metrics}):
            at = [m for m in metrics if m["epoch"] == epoch]
            success = np.array([m["eval_success"] for m in at])
            rows.append({**tag, "epoch": epoch, "episodes": at[0]["episodes"],
                         "env_steps": at[0]["env_steps"],
                         "eval_success_mean": round(float(success.mean()), 4),
                         "eval_success_std": round(float(success.std()), 4),
                         "seeds": len(at), "wall_s": round(max(m["wall_s"] for m in at), 1)})  # fmt: skip
    return rows, per_seed


def write_results(name: str, rows: list, per_seed: list, results: Path) -> tuple[Path, Path]:
    """NAME.csv and NAME.jsonl in `results`, each written whole or not at all."""
    results.mkdir(parents=True, exist_ok=True)
    csv_path, jsonl_path = results / f"{name}.csv", results / f"{name}.jsonl"
    table = io.StringIO(newline="")
    writer = csv.DictWriter(table, fieldnames=CSV_FIELDS)
    writer.writeheader()
    writer.writerows(rows)
    write_text_atomic(csv_path, table.getvalue())
    write_text_atomic(jsonl_path, "".join(json.dumps(r) + "\n" for r in per_seed))
    return csv_path, jsonl_path


def run_cells_local(
    cells: list[Cell], dirs: list[Path], jobs: int, progress: bool, pin: bool = False,
    store: Path = STORE,
) -> list[str]:  # fmt: skip
    """Every cell, `jobs` at a time (in worker processes when jobs > 1; `pin`: each on its
    own cores) -> the directories of their results."""
    todo = [i for i, (c, d) in enumerate(zip(cells, dirs, strict=True))
            if result_dir(c, d, store) is None]  # fmt: skip
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

        with tqdm(total=len(todo), desc=f"cells ({jobs} at once)", unit="cell",
                  disable=not progress) as bar:  # fmt: skip
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


def run_sweep(
    exp: Experiment, sweep_dir: Path, results: Path, overwrite: bool = False,
    ray_address: str | None = None, progress: bool = True, jobs: int = 1, pin: bool = False,
) -> tuple[Path, ...]:  # fmt: skip
    """Run every cell of `exp` (skipping finished ones) and write its results -> their files
    (NAME.csv and NAME.jsonl; a library experiment: NAME.csv)."""
    csv_path = results / f"{exp.name}.csv"
    if csv_path.exists() and not overwrite:
        raise SystemExit(f"error: {csv_path} exists; pass --overwrite to replace it")
    cells = exp.cells()
    dirs = [sweep_dir / c.name for c in cells]
    store = results / "cells"
    if ray_address:
        run_dirs = run_cells_ray(run_cell, cells, dirs, ray_address, store)
    else:
        run_dirs = run_cells_local(cells, dirs, jobs, progress, pin, store)
    if exp.kind == "library":
        from mjx_skills.build_library import write_table

        return (write_table([Path(d) for d in run_dirs], csv_path),)
    rows, per_seed = aggregate(exp.name, cells, [Path(d) for d in run_dirs])
    return write_results(exp.name, rows, per_seed, results)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--experiment", help="an experiment of experiments/*.toml (see --list)")
    p.add_argument("--list", action="store_true", help="list the experiments and exit")
    p.add_argument("--tasks", nargs="+", help="ad-hoc grid: tasks (instead of --experiment)")
    p.add_argument("--methods", nargs="+", help="ad-hoc grid: methods")
    p.add_argument("--libraries", nargs="+", help="ad-hoc grid: SL1 / SL2 / SL3 (library methods)")
    p.add_argument("--name", default="adhoc", help="ad-hoc grid: the results' name")
    p.add_argument("--seeds", type=positive_int, help="seeds per cell (overrides the experiment's)")
    p.add_argument(
        "--epochs", type=positive_int, help="epochs per cell (overrides the experiment's)"
    )
    p.add_argument("--sweep-dir", type=directory, help="where cells run (default runs/sweeps/NAME)")
    p.add_argument("--results", type=directory, default=RESULTS, help="where NAME.csv goes")
    p.add_argument("--overwrite", action="store_true", help="replace existing NAME.csv/.jsonl")
    p.add_argument("--ray", metavar="ADDRESS", help="run cells as Ray tasks: 'local' or HOST:PORT")
    p.add_argument("--ray-address", dest="ray", help=argparse.SUPPRESS)
    p.add_argument("--jobs", type=positive_int, default=None,
                   help="cells at once, each in its own worker process "
                   "(default: one per usable core; library experiments: 1)")  # fmt: skip
    p.add_argument("--pin", action="store_true",
                   help="pin each of the --jobs workers to its own cores (default: unpinned)")  # fmt: skip
    p.add_argument("--estimate", action="store_true",
                   help="print the expected wall time from measured epoch costs; no training")  # fmt: skip
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    args = p.parse_args(argv)
    if args.list:
        for name in names():
            print(f"{name:10s} {load_experiment(name).description}")
        return
    try:
        if args.experiment and args.tasks:
            raise ValueError("give --experiment or --tasks/--methods, not both")
        if args.experiment:
            exp = load_experiment(args.experiment)
        elif args.tasks and args.methods:
            exp = adhoc(args.name, args.tasks, args.methods, args.libraries)
        else:
            raise ValueError("give --experiment NAME (see --list) or --tasks ... --methods ...")
        exp = exp.with_budget(seeds=args.seeds, epochs=args.epochs)
    except ValueError as err:
        raise SystemExit(f"error: {err}") from None
    from mjx_skills.core.workers import usable_cores

    jobs = args.jobs or usable_cores()
    if args.estimate:
        from mjx_skills.sweeps import cost

        print(cost.report(exp, jobs))
        return
    sweep_dir = args.sweep_dir or Path("runs") / "sweeps" / exp.name
    try:
        sweep_dir = check_writable_path(sweep_dir, "--sweep-dir")
    except ValueError as err:
        raise SystemExit(f"error: {err}") from None
    try:
        paths = run_sweep(exp, sweep_dir, args.results, args.overwrite, args.ray,
                          not args.no_progress, jobs, args.pin)  # fmt: skip
    except ValueError as err:  # a stored cell or run of another definition
        raise SystemExit(f"error: {err}") from None
    except KeyboardInterrupt:  # the running cells finished and saved their epochs
        print("interrupted: run the same command again to resume", file=sys.stderr)
        raise SystemExit(INTERRUPTED) from None
    print(f"{len(exp.cells())} cells done; results: {', '.join(map(str, paths))}")


if __name__ == "__main__":
    main()
