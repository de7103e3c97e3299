"""Metrics as JSONL (one line per epoch per seed) and TensorBoard events; progress bar."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm


class MetricsWriter:
    """Appends to RUN_DIR/metrics.jsonl; on resume, drops lines past the restored epoch so
    that the file reads as one uninterrupted run."""

    def __init__(self, run_dir: Path, resume_from_epoch: int = 0):
        self.path = Path(run_dir) / "metrics.jsonl"
        if self.path.exists():
            kept = [
                line for line in self.path.read_text().splitlines()
                if line and json.loads(line)["epoch"] <= resume_from_epoch
            ]  # fmt: skip
            self.path.write_text("".join(line + "\n" for line in kept))
        self._file = self.path.open("a")
        try:
            from tensorboardX import SummaryWriter

            self._tb = SummaryWriter(str(Path(run_dir) / "tb"))
        except ImportError:  # TensorBoard logging is optional
            self._tb = None

    def write(self, epoch: int, metrics: dict[str, np.ndarray], **common) -> None:
        """metrics: name -> (n_seeds,) array; one JSON line per seed. Integer metrics (the
        device's counters: env_steps, episodes, skill_calls) are written as integers."""
        n_seeds = len(next(iter(metrics.values())))
        for seed in range(n_seeds):
            row = {"epoch": epoch, "seed": seed, **common}
            row.update({k: _scalar(v[seed]) for k, v in sorted(metrics.items())})
            self._file.write(json.dumps(row) + "\n")
        self._file.flush()
        if self._tb is not None:
            x = int(np.max(metrics["env_steps"])) if "env_steps" in metrics else epoch
            for name, value in metrics.items():
                self._tb.add_scalar(name, float(np.mean(value)), x)
            self._tb.flush()

    def close(self) -> None:
        self._file.close()
        if self._tb is not None:
            self._tb.close()


def _scalar(x: np.ndarray) -> int | float:
    return int(x) if np.issubdtype(np.asarray(x).dtype, np.integer) else float(x)


def progress_bar(total: int, done: int, enabled: bool, desc: str):
    return tqdm(
        total=total, initial=done, disable=not enabled, desc=desc, unit="epoch", dynamic_ncols=True
    )


def read_metrics(run_dir: Path) -> list[dict]:
    path = Path(run_dir) / "metrics.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines() if line]


def wall_seconds(rows: list[dict]) -> float:
    """A run's training wall time (s) from its metrics rows. `wall_s` counts from the start
    of the process that wrote the row, so a resumed run's clock starts again: the time is
    the sum of each stretch's last `wall_s` (a stretch ends where the next epoch's is lower)."""
    by_epoch = sorted({m["epoch"]: m["wall_s"] for m in rows}.items())
    walls = [w for _, w in by_epoch]
    return float(sum(w for w, nxt in zip(walls, [*walls[1:], 0.0], strict=True) if nxt < w))
