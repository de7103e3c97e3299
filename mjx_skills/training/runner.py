"""The host loop: call the jitted epoch, log, draw progress, checkpoint, resume.

A run lives in OUT/<task>/<method>/<timestamp>/ with config.json, library.json (the skill
library it started with, `LIBRARY`), metrics.jsonl (one line per epoch per seed),
TensorBoard events and checkpoints/. A run directory is never reused: `--resume RUN_DIR`
continues that run where its last checkpoint left it.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mjx_skills import __version__, methods
from mjx_skills.config import EnvConfig, TrainConfig
from mjx_skills.core.config_io import from_dict
from mjx_skills.core.files import read_json, write_json_atomic
from mjx_skills.core.paths import check_writable_path
from mjx_skills.core.precision import require_float32
from mjx_skills.envs.registry import check_name
from mjx_skills.skills.run_provenance import library_provenance
from mjx_skills.training.checkpoint import Checkpoints
from mjx_skills.training.epoch import build, committed, host_metrics
from mjx_skills.training.interrupt import deferred_stop
from mjx_skills.training.metrics_log import MetricsWriter, progress_bar, read_metrics
from mjx_skills.training.schema import SCHEMA, migrate
from mjx_skills.training.trackers import check_track


@dataclasses.dataclass(frozen=True)
class RunArgs:
    """Everything that defines a run: what config.json holds."""

    train: TrainConfig = TrainConfig()
    method: str = "ddpg_her"
    env: EnvConfig = EnvConfig()
    options: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    """The method's option groups by name (e.g. {"ddpg": DDPGConfig(...)}); defaults are
    filled in for missing groups."""
    resume: str | None = None
    """Continue the run in this directory from its last checkpoint (its config.json wins)."""
    extend_to: int | None = None
    """With `resume`: train on to this many epochs (at least the run's own), and record the
    new budget in its config.json. Nothing in an epoch reads the total, so the run equals
    one started with that many (tests/training/test_train.py)."""

    def full_options(self) -> dict[str, Any]:
        spec = methods.get(self.method)
        unknown = sorted(set(self.options) - set(spec.options))
        if unknown:
            raise ValueError(
                f"method {self.method!r} has no option group(s) {unknown}; "
                f"valid: {sorted(spec.options)}"
            )
        return {**spec.options, **self.options}


def new_run_dir(args: RunArgs) -> Path:
    """OUT/<task>/<method>/<timestamp>[-N]: a fresh directory, never an existing one."""
    base = Path(args.train.out) / args.train.task / args.method / time.strftime("%Y%m%d-%H%M%S")
    run_dir, n = base, 1
    while True:
        try:
            run_dir.mkdir(parents=True, exist_ok=False)
            return run_dir
        except FileExistsError:
            n += 1
            run_dir = base.with_name(f"{base.name}-{n}")


def config_dict(args: RunArgs) -> dict[str, Any]:
    """What defines a run, as config.json holds it (without the package version), with the
    layout's number (`schema.SCHEMA`)."""
    groups = {name: dataclasses.asdict(opt) for name, opt in args.full_options().items()}
    return {
        "method": args.method,
        "train": dataclasses.asdict(args.train),
        "env": dataclasses.asdict(args.env),
        "options": groups,
        "schema": SCHEMA,
    }


LIBRARY = "library.json"
"""RUN_DIR/LIBRARY: the provenance of the skill library a new run started with
(`run_provenance.library_provenance`), so a sweep never takes a run made with another library
(or other skill code) for its cell; absent when the method reads no library."""


def save_library(run_dir: Path, args: RunArgs) -> None:
    """Record the library a new run starts with in RUN_DIR/LIBRARY (nothing if it reads none)."""
    library = library_provenance(config_dict(args))
    if library is not None:
        write_json_atomic(run_dir / LIBRARY, library, indent=1, sort_keys=True)


def save_config(run_dir: Path, args: RunArgs) -> None:
    """RUN_DIR/config.json, written whole or not at all (a crash leaves the old one)."""
    raw = {**config_dict(args), "version": __version__}
    write_json_atomic(run_dir / "config.json", raw, indent=2)


def load_config(run_dir: Path) -> RunArgs:
    """The run's RunArgs from its config.json. FileNotFoundError: not a run directory;
    ValueError naming the file: damaged, or written by a version without method options."""
    path = run_dir / "config.json"
    if not path.exists():
        raise FileNotFoundError(f"{run_dir} has no config.json: not a run directory")
    raw = read_json(path)
    if "options" not in raw:  # written before the method registry (version 0.1.0 runs)
        raise ValueError(
            f"{path} was written by an earlier version (no method options); start a new run"
        )
    raw = migrate(raw)  # written by earlier code: as that code ran it
    spec = methods.get(raw["method"])
    options = {
        name: from_dict(type(spec.options[name]), group) for name, group in raw["options"].items()
    }
    return RunArgs(
        train=from_dict(TrainConfig, raw["train"]),
        method=raw["method"],
        env=from_dict(EnvConfig, raw["env"]),
        options=options,
        resume=str(run_dir),
    )


def _extended(args: RunArgs, epochs: int) -> RunArgs:
    """A resumed run's args with its budget raised to `epochs` (ValueError below its own)."""
    if epochs < args.train.epochs:
        raise ValueError(
            f"epochs: cannot shorten {args.resume} from {args.train.epochs} to "
            f"{epochs} epochs; extending needs at least its own"
        )
    return dataclasses.replace(args, train=dataclasses.replace(args.train, epochs=epochs))


def check_finite(metrics: dict[str, np.ndarray]) -> None:
    bad = [k for k, v in metrics.items() if not np.all(np.isfinite(v))]
    if bad:
        raise FloatingPointError(f"non-finite {', '.join(bad)}; the last good checkpoint is kept")


def train_run(args: RunArgs, stop_after: int | None = None) -> Path:
    """Train (or resume) a run; returns its directory. `stop_after` ends the run after that
    epoch as Ctrl-C would (checkpoint saved), for tests and for training in pieces."""
    return train_and_keep(args, stop_after)[0]


def train_and_keep(args: RunArgs, stop_after: int | None = None) -> tuple[Path, Any]:
    """`train_run`, also returning the final carry (leading seed axis). Resuming a finished
    run trains nothing and returns its last checkpoint's carry. Ctrl-C or SIGTERM finish the
    epoch in flight, save it and return (`interrupt.deferred_stop`); a second one stops at
    once. Refused before any write: x64 JAX (`precision`), a path orbax cannot write
    (`paths`), unknown or unread options, a task the method cannot run."""
    require_float32()
    run_dir = None if args.resume is None else check_writable_path(args.resume, "--resume")
    extended = False  # a resumed run given a longer budget: saved once its checkpoint loaded
    if run_dir is not None:
        extend_to, args = args.extend_to, load_config(run_dir)
        if extend_to is not None:
            extended, args = extend_to != args.train.epochs, _extended(args, extend_to)
    else:
        out = check_writable_path(args.train.out, "--out")
        if str(args.train.out).startswith("~"):  # written where `~` points, as orbax would
            args = dataclasses.replace(args, train=dataclasses.replace(args.train, out=str(out)))
    check_name(args.train.task)
    options = args.full_options()  # unknown methods and option groups fail before any write
    methods.check_read(args.method, args.train, options)  # so do options it would ignore
    methods.check_task(args.method, args.train.task, options, args.env)
    # Read-only method inputs (the skill library) enter the jitted epoch here, never donated;
    # a missing library fails here too, before a run directory is made.
    spec = methods.get(args.method)
    aux = spec.load_aux(options)
    check_track(args.train.track)  # wandb missing: refused before a run directory is made
    if run_dir is None:
        run_dir = new_run_dir(args)
        save_library(run_dir, args)
        save_config(run_dir, args)
        print(
            f"run directory: {run_dir} (metrics.jsonl grows an epoch at a time; Ctrl-C stops "
            f"after the epoch in flight and saves it; --resume {run_dir} goes on)",
            file=sys.stderr,
        )
    cfg = args.train
    env, _, epoch_fn, carry = build(args.method, cfg, args.env, options, aux)
    checkpoints = Checkpoints(run_dir / "checkpoints")
    start = 0
    if args.resume is not None:
        # Resume from a checkpoint whose epoch the log holds whole: a newer one (its log
        # line cut by a crash) would leave that epoch's row missing for good.
        logged = _logged_through(run_dir, cfg.seeds)
        if any(e <= logged for e in checkpoints.epochs()):
            start, carry = checkpoints.restore(carry, at_most=logged)
            carry = committed(carry)
        checkpoints.set_aside_after(start)  # epochs trained again: their saves come anew
        _say_where_it_resumes(run_dir, start, cfg.epochs)
    if extended:
        save_config(run_dir, args)
    track = cfg.wandb_project if cfg.track else None
    writer = MetricsWriter(run_dir, start, track, config_dict(args) if track else None)
    steps_per_epoch = cfg.envs * cfg.cycles * env.episode_length
    bar = progress_bar(cfg.epochs, start, enabled=cfg.progress, desc=f"{cfg.task}/{args.method}")
    bar.set_postfix_str("compiling the epoch (the first one takes longer)")
    logged, t0 = start, time.time()
    try:
        with deferred_stop() as stop:
            for epoch in range(start + 1, cfg.epochs + 1):
                t_epoch = time.time()
                carry, metrics = epoch_fn(carry, aux)
                metrics = host_metrics(metrics)
                check_finite(metrics)
                writer.write(epoch, metrics, wall_s=time.time() - t0)
                logged = epoch
                sps = steps_per_epoch * cfg.seeds / max(time.time() - t_epoch, 1e-9)
                bar.set_postfix(
                    eval_success=f"{metrics['eval_success'].mean():.2f}",
                    env_steps=str(int(metrics["env_steps"][0])),  # an int: tqdm writes 2e+4
                    steps_per_s=str(round(sps)),
                )
                bar.update(1)
                if epoch == start + 1:  # it held the compile: the ETA counts from here
                    bar.restart_clock()
                last = epoch == cfg.epochs
                if last or epoch % cfg.checkpoint_every == 0 or stop or epoch == stop_after:
                    with stop.shielded():  # a second signal waits for the whole checkpoint
                        checkpoints.save(epoch, carry)
                if not last and (stop or epoch == stop_after):
                    if stop:
                        print(
                            f"interrupted after epoch {epoch} (saved); resume with "
                            f"--resume {run_dir}",
                            file=sys.stderr,
                        )
                    break
    except KeyboardInterrupt:  # a second signal: the epoch in flight is lost
        saved = checkpoints.latest_epoch() or 0
        print(
            f"\ninterrupted during epoch {logged + 1}; the last checkpoint holds epoch "
            f"{saved}; resume with --resume {run_dir}",
            file=sys.stderr,
        )
    finally:
        bar.close()
        writer.close()
        checkpoints.close()
    return run_dir, carry


def _logged_through(run_dir: Path, seeds: int) -> int:
    """The last epoch E such that metrics.jsonl holds every seed's row of epochs 1..E."""
    path = run_dir / "metrics.jsonl"
    rows = read_metrics(run_dir) if path.exists() else []
    seen: dict[int, set] = {}
    for row in rows:
        seen.setdefault(row["epoch"], set()).add(row["seed"])
    epoch = 0
    while len(seen.get(epoch + 1, ())) == seeds:
        epoch += 1
    return epoch


def _say_where_it_resumes(run_dir: Path, start: int, epochs: int) -> None:
    if start:
        print(
            f"resuming {run_dir} from its checkpoint of epoch {start} of {epochs}", file=sys.stderr
        )
    else:
        print(
            f"{run_dir} holds no checkpoint: training it from epoch 0 of {epochs}", file=sys.stderr
        )


def summary(run_dir: Path) -> str:
    """One line: the last epoch's eval success over seeds (from `read_metrics`)."""
    lines = read_metrics(run_dir)
    if not lines:
        return f"{run_dir}: no epochs"
    last = max(x["epoch"] for x in lines)
    final = [x["eval_success"] for x in lines if x["epoch"] == last]
    mean = sum(final) / len(final)
    spread = math.sqrt(sum((f - mean) ** 2 for f in final) / len(final))
    return f"{run_dir}: epoch {last}, eval success {mean:.2f} +- {spread:.2f} over {len(final)} seed(s)"
