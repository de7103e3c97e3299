"""Optional sinks of a run's per-epoch metrics: TensorBoard (each seed and their mean) and
Weights & Biases (`--track`). metrics.jsonl is the record (`metrics_log`); a sink that fails
to start or to write logs one warning and is dropped, and the run goes on.

TensorBoard: RUN_DIR/tb/seed_0, seed_1, ... and tb/mean, one event directory each, so
TensorBoard draws the seeds as runs over one another with their mean beside them; tags are
namespaced (`tb_tag`: eval/success, loss/critic, counters/env_steps, ...) and the x-axis is
env steps. View with `tensorboard --logdir runs` (`pip install tensorboard`).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

COUNTERS = ("env_steps", "episodes", "skill_calls", "physics_resets")
"""Metrics that count work done: logged under counters/."""
PHASES = ("eval", "train", "explore")


def tb_tag(name: str) -> str:
    """A metric's namespaced tag: eval_success -> eval/success, critic_loss -> loss/critic,
    env_steps -> counters/env_steps, q_mean -> agent/q_mean."""
    if name.endswith("_loss"):
        return f"loss/{name.removesuffix('_loss')}"
    phase, _, rest = name.partition("_")
    if phase in PHASES and rest:
        return f"{phase}/{rest}"
    if name in COUNTERS:
        return f"counters/{name}"
    return f"agent/{name}"


def x_of(epoch: int, metrics: dict[str, np.ndarray]) -> int:
    """The x-axis value of an epoch's metrics: env steps (as the field plots), else the epoch."""
    return int(np.max(metrics["env_steps"])) if "env_steps" in metrics else epoch


class TensorBoard:
    """tb/seed_N and tb/mean writers (tensorboardX), made on the first epoch logged."""

    def __init__(self, directory: Path):
        from tensorboardX import SummaryWriter  # ImportError: the caller goes without

        directory.mkdir(parents=True, exist_ok=True)  # OSError: the caller warns
        self._make = SummaryWriter
        self.directory = directory
        self._writers: dict[str, Any] = {}

    def _writer(self, name: str):
        if name not in self._writers:
            self._writers[name] = self._make(str(self.directory / name))
        return self._writers[name]

    def log(self, epoch: int, metrics: dict[str, np.ndarray]) -> None:
        x = x_of(epoch, metrics)
        n_seeds = len(next(iter(metrics.values())))
        for name, values in metrics.items():
            tag = tb_tag(name)
            self._writer("mean").add_scalar(tag, float(np.mean(values)), x)
            for seed in range(n_seeds):
                self._writer(f"seed_{seed}").add_scalar(tag, float(values[seed]), x)
        for writer in self._writers.values():
            writer.flush()

    def close(self) -> None:
        for writer in self._writers.values():
            writer.close()


WANDB_MISSING = (
    "track: logging to Weights & Biases needs wandb: pip install wandb "
    "(or pip install -e '.[track]')"
)


def check_track(track: bool) -> None:
    """ValueError naming `track` when it is on and wandb is not installed (before a run
    directory is made)."""
    if track:
        try:
            import wandb  # noqa: F401
        except ImportError:
            raise ValueError(WANDB_MISSING) from None


class WandB:
    """A Weights & Biases run (`pip install wandb`; `WANDB_MODE=offline` keeps it local):
    the run's config, and per epoch each metric's seed mean (namespaced as TensorBoard's)
    and each seed's value under seed_N/, with env steps as the step. A resumed run logs
    into the same W&B run (its id is the run directory's name)."""

    def __init__(self, run_dir: Path, project: str, config: dict):
        check_track(True)
        import wandb

        self._run = wandb.init(
            project=project,
            name=f"{run_dir.parent.parent.name}/{run_dir.parent.name}/{run_dir.name}",
            id=f"{run_dir.parent.name}-{run_dir.name}",
            resume="allow",
            dir=str(run_dir),
            config=config,
        )

    def log(self, epoch: int, metrics: dict[str, np.ndarray]) -> None:
        row: dict[str, float] = {"epoch": epoch}
        for name, values in metrics.items():
            row[tb_tag(name)] = float(np.mean(values))
            row.update({f"seed_{s}/{tb_tag(name)}": float(v) for s, v in enumerate(values)})
        self._run.log(row, step=x_of(epoch, metrics))

    def close(self) -> None:
        self._run.finish()


def open_sinks(run_dir: Path, track: str | None, config: dict) -> list:
    """TensorBoard if tensorboardX is installed (silently none if not: it is optional), and
    W&B project `track` when given (ValueError naming `track` without wandb). A sink that
    cannot start is warned about and left out."""
    sinks: list = []
    directory = Path(run_dir) / "tb"
    try:
        sinks.append(TensorBoard(directory))
    except ImportError:
        pass
    except OSError as err:  # an unwritable tb/ must not stop the run
        log.warning("TensorBoard logging is off: %s cannot be written (%s)", directory, err)
    if track:
        sinks.append(WandB(Path(run_dir), track, config))
    return sinks


class Sinks:
    """Each sink's `log` and `close`, guarded: one that fails warns once and is dropped."""

    def __init__(self, sinks: list):
        self._sinks = list(sinks)

    def log(self, epoch: int, metrics: dict[str, np.ndarray]) -> None:
        for sink in list(self._sinks):
            try:
                sink.log(epoch, metrics)
            except Exception as err:  # noqa: BLE001 - optional: any failure, the run goes on
                log.warning("%s logging failed (%s); going on without it", _name(sink), err)
                self._drop(sink)

    def close(self) -> None:
        for sink in list(self._sinks):
            self._drop(sink)

    def _drop(self, sink) -> None:
        self._sinks.remove(sink)
        try:
            sink.close()
        except Exception:  # noqa: BLE001 - already warned, or closing at the end
            pass


def _name(sink) -> str:
    return {"TensorBoard": "TensorBoard", "WandB": "Weights & Biases"}[type(sink).__name__]
