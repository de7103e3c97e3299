"""Orbax checkpoints of the whole run state (params, optimisers, normalisers, replay, keys).

Orbax writes each step to a temporary directory and renames it when complete, so a
half-written checkpoint is never taken for a good one; a checkpoint that fails to restore
is reported and the previous good one is used.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

import jax
import orbax.checkpoint as ocp

log = logging.getLogger(__name__)


def _signature(tree: Any) -> list[tuple]:
    """Sorted (shape, dtype) of every leaf: equal for the same run whatever the container types."""
    return sorted((tuple(x.shape), str(x.dtype)) for x in jax.tree.leaves(tree))


class Checkpoints:
    def __init__(self, directory: Path, max_to_keep: int = 3):
        options = ocp.CheckpointManagerOptions(max_to_keep=max_to_keep, create=True)
        self.directory = Path(directory).resolve()
        self.manager = ocp.CheckpointManager(self.directory, options=options)

    def save(self, epoch: int, carry: Any) -> None:
        self.manager.save(epoch, args=ocp.args.StandardSave(carry), force=True)
        self.manager.wait_until_finished()

    def latest_epoch(self) -> int | None:
        return self.manager.latest_step()

    def restore(self, like: Any) -> tuple[int, Any]:
        """Newest restorable checkpoint -> (epoch, carry shaped like `like`).

        An unreadable checkpoint is reported and skipped for the one before it; one that
        reads but holds other shapes than `like` raises ValueError (a different run)."""
        abstract = jax.tree.map(ocp.utils.to_shape_dtype_struct, like)
        errors = []
        for epoch in sorted(self.manager.all_steps(), reverse=True):
            try:
                saved = self.manager.restore(epoch, args=ocp.args.StandardRestore())
            except Exception as err:  # noqa: BLE001 - any unreadable file means a bad checkpoint
                log.warning(
                    "checkpoint at epoch %d is unreadable (%s); trying an older one", epoch, err
                )
                errors.append(f"epoch {epoch}: {err}")
                self._set_aside(epoch)
                continue
            if _signature(saved) != _signature(abstract):
                raise ValueError(
                    f"checkpoint at epoch {epoch} does not match this run: it holds other "
                    "array shapes (task, method or sizes differ from config.json)"
                )
            restored = self.manager.restore(epoch, args=ocp.args.StandardRestore(abstract))
            return epoch, restored
        raise FileNotFoundError(
            "no restorable checkpoint" + (": " + "; ".join(errors) if errors else "")
        )

    def _set_aside(self, epoch: int) -> None:
        """Rename a bad checkpoint to <epoch>.corrupt (kept for inspection, out of the way of
        the epoch's next save)."""
        path = self.directory / str(epoch)
        if path.exists():
            path.rename(path.with_name(f"{epoch}.corrupt-{int(time.time())}"))
        self.manager.reload()

    def close(self) -> None:
        self.manager.close()
