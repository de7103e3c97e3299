"""Sweeps: the thesis's experiments (and ad-hoc grids) as cells of training runs.

    python -m mjx_skills.sweep --experiment smoke
    python -m mjx_skills.sweep --experiment NAME --seeds 3 --epochs 50  # experiments/NAME.toml
    python -m mjx_skills.sweep --tasks pick_move take_out --methods pas mpas --seeds 3
    python -m mjx_skills.sweep --tasks fetch_push --methods ddpg_her_sl --libraries SL_fetch_push --preset fetch_push
    python -m mjx_skills.sweep --experiment NAME --jobs 1             # one cell at a time
    python -m mjx_skills.sweep --experiment NAME --estimate           # wall time, no training
    python -m mjx_skills.sweep --experiment NAME --ray local          # cells as Ray tasks
    python -m mjx_skills.sweep --list                                 # by group, stored cells
    python -m mjx_skills.sweep --experiment NAME --results /tmp/out   # its CSV from the store

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
metrics are kept with its definition in STORE/CELL/ (`mjx_skills.sweeps.cells`; by default the
committed experiments/results/cells/ of the checkout the package runs from, whatever the working
directory and `--results`; `--store` for another): a stored cell of the same definition is taken instead of trained, whichever
experiment asks for it, and an interrupted one resumes from its checkpoint. A stored cell
or a run made by another definition of the cell is refused with the fields that differ.
A cell whose epochs grew trains on from the run of its shorter budget in the same sweep
directory (copied; the shorter run is left as it was) instead of from scratch. When every cell is done the results are aggregated into
RESULTS/NAME.csv (`--results`, default the checkout's experiments/results/) (mean and std of eval success over seeds per epoch) and NAME.jsonl
(every seed's metrics). Existing results elsewhere are not overwritten without --overwrite;
a training experiment's NAME.csv/.jsonl in the checkout's experiments/results/ are derived
files (git-ignored: every cell they come from is in the store), replaced without asking.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mjx_skills.cli_args import positive_int
from mjx_skills.core import plugins
from mjx_skills.core.paths import CHECKOUT, check_writable_path, directory
from mjx_skills.sweeps.aggregate import aggregate, write_results
from mjx_skills.sweeps.cell import Cell
from mjx_skills.sweeps.cells import STORE
from mjx_skills.sweeps.experiments import Experiment, adhoc, load_experiment
from mjx_skills.sweeps.local import (
    cell_run_dir,
    copy_shorter_run,
    finished,
    run_cells_local,
    shorter_budget,
)
from mjx_skills.sweeps.ray_cells import run_cells_ray
from mjx_skills.training.interrupt import INTERRUPTED

RESULTS = CHECKOUT / "experiments" / "results"
"""Where NAME.csv / NAME.jsonl go by default: the checkout's, whatever the working directory."""


def run_cell(cell: Cell, cell_dir: str, progress: bool, store: str) -> str:
    """Train (or resume, or take from the store) one cell -> the directory of its results
    (a stored cell, `mjx_skills.sweeps.cells`; a library cell: the library). Runs in this process
    or in a worker: imports JAX only here. A run in `cell_dir` made by another definition
    is refused with the fields that differ."""
    from mjx_skills.core import compile_cache
    from mjx_skills.core.precision import use_float32
    from mjx_skills.sweeps import cells
    from mjx_skills.training.runner import RunArgs, train_run

    plugins.load_all()  # a worker process: the user's modules, as its parent had them
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
        raise ValueError(
            f"{run_dir} was run with another definition of {cell.name} "
            f"({'; '.join(diff[:6])}); delete {cell_dir} or use another "
            "--sweep-dir"
        )
    if not finished(run_dir, cell):
        args = (
            RunArgs(resume=str(run_dir), extend_to=cell.epochs if shorter else None)
            if run_dir
            else cell.run_args(cell_dir, progress)
        )
        run_dir = train_run(args)
        if not finished(run_dir, cell):  # interrupted: it saved, starting again resumes
            return str(run_dir)
    return str(cells.save(cell, run_dir, Path(store)))


def build_library(cell: Cell, cell_dir: Path, progress: bool) -> Path:
    """A library from `cell.samples` runs per skill; the sweep's libraries share one work
    directory (the trained skills), and a library is written whole or not at all."""
    from mjx_skills.build_library import SkillsArgs, build
    from mjx_skills.config import LibraryConfig
    from mjx_skills.skills.registry import library_skills

    overrides = dict(dict(cell.options).get("library", ()))
    args = SkillsArgs(
        skills=library_skills("SL1"),  # the thesis's skills, whatever else is registered
        config=LibraryConfig(samples=cell.samples, **overrides),
        out=str(cell_dir / "library"),
        progress=progress,
    )
    return build(args, work=cell_dir.parent / "skills.work")


def run_sweep(
    exp: Experiment,
    sweep_dir: Path,
    results: Path,
    store: Path,
    overwrite: bool = False,
    ray_address: str | None = None,
    progress: bool = True,
    jobs: int = 1,
    pin: bool = False,
) -> tuple[Path, ...]:
    """Run every cell of `exp` (taking the ones in `store`, skipping finished ones) and
    write its results into `results` -> their files (NAME.csv and NAME.jsonl; a library
    experiment: NAME.csv). SystemExit if NAME.csv exists and not `overwrite`, unless it is
    a training experiment's derived file in the checkout's RESULTS (its cells in STORE)."""
    csv_path = results / f"{exp.name}.csv"
    here = [Path(p).resolve() for p in (results, store, RESULTS, STORE)]
    derived = exp.kind == "train" and here[:2] == here[2:]
    if csv_path.exists() and not (overwrite or derived):
        raise SystemExit(f"error: {csv_path} exists; pass --overwrite to replace it")
    cells = exp.cells()
    dirs = [sweep_dir / c.name for c in cells]
    if ray_address:
        run_dirs = run_cells_ray(run_cell, cells, dirs, ray_address, store)
    else:
        run_dirs = run_cells_local(run_cell, cells, dirs, jobs, progress, store, pin)
    if exp.kind == "library":
        from mjx_skills.skills.table import write_table

        return (write_table([Path(d) for d in run_dirs], csv_path),)
    rows, per_seed = aggregate(exp.name, cells, [Path(d) for d in run_dirs])
    return write_results(exp.name, rows, per_seed, results)


def main(argv: list[str] | None = None) -> None:
    argv = plugins.take_imports(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(plugins.FLAG, metavar="MODULE", help=plugins.HELP)  # taken above
    p.add_argument("--experiment", help="an experiment of experiments/*.toml (see --list)")
    p.add_argument("--list", action="store_true", help="list the experiments and exit")
    p.add_argument("--tasks", nargs="+", help="ad-hoc grid: tasks (instead of --experiment)")
    p.add_argument("--methods", nargs="+", help="ad-hoc grid: methods")
    p.add_argument("--libraries", nargs="+", help="ad-hoc grid: SL1 / SL2 / SL3 (library methods)")
    p.add_argument("--name", default="adhoc", help="ad-hoc grid: the results' name")
    p.add_argument(
        "--preset",
        help="ad-hoc grid: the methods' option preset (default, thesis, fetch, fetch_push; "
        "an experiment file states its own)",
    )
    p.add_argument("--seeds", type=positive_int, help="seeds per cell (overrides the experiment's)")
    p.add_argument(
        "--epochs", type=positive_int, help="epochs per cell (overrides the experiment's)"
    )
    p.add_argument("--sweep-dir", type=directory, help="where cells run (default runs/sweeps/NAME)")
    p.add_argument(
        "--results",
        type=directory,
        default=RESULTS,
        help="where NAME.csv/.jsonl go (default: the checkout's experiments/results)",
    )
    p.add_argument(
        "--store",
        type=directory,
        default=STORE,
        help="where finished cells are kept and taken from (default: the "
        "checkout's experiments/results/cells, committed)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace existing NAME.csv/.jsonl")
    p.add_argument("--ray", metavar="ADDRESS", help="run cells as Ray tasks: 'local' or HOST:PORT")
    p.add_argument("--ray-address", dest="ray", help=argparse.SUPPRESS)
    p.add_argument(
        "--jobs",
        type=positive_int,
        default=None,
        help="cells at once, each in its own worker process "
        "(default: one per usable core; library experiments: 1)",
    )
    p.add_argument(
        "--pin",
        action="store_true",
        help="pin each of the --jobs workers to its own cores (default: unpinned)",
    )
    p.add_argument(
        "--estimate",
        action="store_true",
        help="print the expected wall time from measured epoch costs; no training",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    args = p.parse_args(argv)
    from mjx_skills.core.workers import usable_cores

    jobs = args.jobs or usable_cores()
    if args.store.exists() and not args.store.is_dir():
        raise SystemExit(f"error: --store {args.store} is a file, not a directory of cells")
    if args.list:
        from mjx_skills.sweeps.listing import listing

        print(listing(jobs, args.store))
        return
    try:
        if args.experiment and args.tasks:
            raise ValueError("give --experiment or --tasks/--methods, not both")
        if args.experiment and args.preset:
            raise ValueError("--preset is for an ad-hoc grid; an experiment file states its own")
        if args.experiment:
            exp = load_experiment(args.experiment)
        elif args.tasks and args.methods:
            preset = "default" if args.preset is None else args.preset
            exp = adhoc(
                args.name, args.tasks, args.methods, args.libraries, preset, args.seeds, args.epochs
            )
        else:
            raise ValueError("give --experiment NAME (see --list) or --tasks ... --methods ...")
        exp = exp.with_budget(seeds=args.seeds, epochs=args.epochs)
    except ValueError as err:
        raise SystemExit(f"error: {err}") from None
    if args.estimate:
        from mjx_skills.sweeps import cost

        print(cost.report(exp, jobs, args.store))
        return
    sweep_dir = args.sweep_dir or Path("runs") / "sweeps" / exp.name
    try:
        sweep_dir = check_writable_path(sweep_dir, "--sweep-dir")
    except ValueError as err:
        raise SystemExit(f"error: {err}") from None
    try:
        paths = run_sweep(
            exp,
            sweep_dir,
            args.results,
            args.store,
            args.overwrite,
            args.ray,
            not args.no_progress,
            jobs,
            args.pin,
        )
    except ValueError as err:  # a stored cell or run of another definition
        raise SystemExit(f"error: {err}") from None
    except KeyboardInterrupt:  # the running cells finished and saved their epochs
        print("interrupted: run the same command again to resume", file=sys.stderr)
        raise SystemExit(INTERRUPTED) from None
    print(f"{len(exp.cells())} cells done; results: {', '.join(map(str, paths))}")


if __name__ == "__main__":
    main()
