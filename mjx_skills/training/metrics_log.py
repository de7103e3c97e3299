"""Metrics as JSONL (one line per epoch per seed) and CSV; TensorBoard and W&B through
`trackers`; progress bar.

The metrics.jsonl line is the product; metrics.csv holds the same rows as a table (written
whole when the writer closes, so it always matches the JSONL). TensorBoard, W&B and the
progress bar are optional, and when one fails (no tensorboardX, an unwritable tb/
directory, a full disk, a broken terminal) one warning is logged and the run carries on
without it.
"""

from __future__ import annotations

import csv
import io
import json
import logging
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from mjx_skills.core.files import read_jsonl, read_jsonl_lines, write_text_atomic

log = logging.getLogger(__name__)


class MetricsWriter:
    """Appends to RUN_DIR/metrics.jsonl; on resume, drops lines past the restored epoch (and
    a half-written last line a crash left) so that the file reads as one uninterrupted run."""

    def __init__(
        self,
        run_dir: Path,
        resume_from_epoch: int = 0,
        track: str | None = None,
        config: dict | None = None,
    ):
        """`track`: a Weights & Biases project to log to as well (`trackers.WandB`; its
        `config`: the run's)."""
        from mjx_skills.training.trackers import Sinks, open_sinks

        self.path = Path(run_dir) / "metrics.jsonl"
        if self.path.exists():
            lines = read_jsonl_lines(self.path)
            kept = [text for text, row in lines if row["epoch"] <= resume_from_epoch]
            write_text_atomic(self.path, "".join(line + "\n" for line in kept))
        self._file = self.path.open("a")
        self._sinks = Sinks(open_sinks(Path(run_dir), track, config or {}))

    def write(self, epoch: int, metrics: dict[str, np.ndarray], **common) -> None:
        """metrics: name -> (n_seeds,) array; one JSON line per seed. Integer metrics (the
        device's counters: env_steps, episodes, skill_calls) are written as integers."""
        n_seeds = len(next(iter(metrics.values())))
        for seed in range(n_seeds):
            row = {"epoch": epoch, "seed": seed, **common}
            row.update({k: _scalar(v[seed]) for k, v in sorted(metrics.items())})
            self._file.write(json.dumps(row) + "\n")
        self._file.flush()
        self._sinks.log(epoch, metrics)

    def close(self) -> None:
        self._file.close()
        self._sinks.close()
        try:
            write_csv(self.path)
        except (OSError, ValueError) as err:  # the JSONL is the record; the CSV a view of it
            log.warning("metrics.csv was not written (%s); metrics.jsonl holds the rows", err)


def write_csv(jsonl: Path) -> Path:
    """metrics.csv beside metrics.jsonl: its rows, epoch and seed first, then every other
    column in order (a metric a row lacks is empty), written whole."""
    rows = read_jsonl(jsonl)
    keys = sorted({k for row in rows for k in row} - {"epoch", "seed"})
    table = io.StringIO(newline="")
    writer = csv.DictWriter(table, fieldnames=["epoch", "seed", *keys])
    writer.writeheader()
    writer.writerows(rows)
    return write_text_atomic(jsonl.with_suffix(".csv"), table.getvalue())


def _scalar(x: np.ndarray) -> int | float:
    return int(x) if np.issubdtype(np.asarray(x).dtype, np.integer) else float(x)


def progress_bar(total: int, done: int, enabled: bool, desc: str) -> _Bar:
    """A tqdm bar of epochs whose failures (creating, updating, closing) log one warning and
    turn it off instead of stopping the run."""
    options = dict(disable=not enabled, desc=desc, unit="epoch", dynamic_ncols=True)
    return _Bar(lambda: tqdm(total=total, initial=done, **options))


class _Bar:
    """The calls the trainer makes on a tqdm bar, each guarded."""

    def __init__(self, make):
        self._bar = None
        self._guard(lambda: setattr(self, "_bar", make()))

    def _guard(self, call) -> None:
        try:
            call()
        except Exception as err:  # noqa: BLE001 - optional: any failure, the run goes on
            log.warning("the progress bar failed (%s); going on without it", err)
            self._bar = None

    def set_postfix(self, **values) -> None:
        if self._bar is not None:
            self._guard(lambda: self._bar.set_postfix(**values))

    def update(self, n: int = 1) -> None:
        if self._bar is not None:
            self._guard(lambda: self._bar.update(n))

    def set_postfix_str(self, text: str) -> None:
        if self._bar is not None:
            self._guard(lambda: self._bar.set_postfix_str(text))

    def restart_clock(self) -> None:
        """Time the bar's rate and ETA from now on, counting the epochs done so far as
        initial: the first epoch of a process includes the compile (tens of seconds), which
        would otherwise make the ETA many times too long."""
        if self._bar is not None:
            self._guard(self._restart)

    def _restart(self) -> None:
        bar, done, postfix = self._bar, self._bar.n, self._bar.postfix
        bar.reset(total=bar.total)  # the clock and the rate's moving averages start anew
        bar.n = bar.last_print_n = bar.initial = done
        bar.postfix = postfix
        bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._guard(self._bar.close)
        self._bar = None


def read_metrics(run_dir: Path) -> list[dict]:
    """RUN_DIR/metrics.jsonl's rows (`files.read_jsonl`: a half-written last line is
    dropped with a warning; damage elsewhere raises ValueError naming file and line)."""
    return read_jsonl(Path(run_dir) / "metrics.jsonl")


def logged_epochs(run_dir: Path) -> int:
    """The last epoch a run logged (0: none)."""
    return max((row["epoch"] for row in read_metrics(run_dir)), default=0)


def wall_seconds(rows: list[dict]) -> float:
    """A run's training wall time (s) from its metrics rows. `wall_s` counts from the start
    of the process that wrote the row, so a resumed run's clock starts again: the time is
    the sum of each stretch's last `wall_s` (a stretch ends where the next epoch's is lower)."""
    by_epoch = sorted({m["epoch"]: m["wall_s"] for m in rows}.items())
    walls = [w for _, w in by_epoch]
    return float(sum(w for w, nxt in zip(walls, [*walls[1:], 0.0], strict=True) if nxt < w))
