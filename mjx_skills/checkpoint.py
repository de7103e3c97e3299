"""Orbax checkpoints of the whole run state (params, optimisers, normalisers, replay, keys).

Orbax writes each step to a temporary directory and renames it when complete, so a
half-written checkpoint is never taken for a good one; a checkpoint that fails to restore
is reported and the previous good one is used.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import jax
import orbax.checkpoint as ocp

log = logging.getLogger(__name__)


class Checkpoints:
    def __init__(self, directory: Path, max_to_keep: int = 3):
        options = ocp.CheckpointManagerOptions(max_to_keep=max_to_keep, create=True)
        self.manager = ocp.CheckpointManager(Path(directory).resolve(), options=options)

    def save(self, epoch: int, carry: Any) -> None:
        self.manager.save(epoch, args=ocp.args.StandardSave(carry), force=True)
        self.manager.wait_until_finished()

    def latest_epoch(self) -> int | None:
        return self.manager.latest_step()

    def restore(self, like: Any) -> tuple[int, Any]:
        """Newest restorable checkpoint -> (epoch, carry shaped like `like`).

        Raises ValueError when shapes differ from `like` and FileNotFoundError when none
        can be restored."""
        abstract = jax.tree.map(ocp.utils.to_shape_dtype_struct, like)
        errors = []
        for epoch in sorted(self.manager.all_steps(), reverse=True):
            try:
                return epoch, self.manager.restore(epoch, args=ocp.args.StandardRestore(abstract))
            except ValueError as err:  # shape or structure mismatch: not a corruption
                raise ValueError(
                    f"checkpoint at epoch {epoch} does not match this run: {err}"
                ) from err
            except Exception as err:  # noqa: BLE001 - any unreadable file means a bad checkpoint
                log.warning(
                    "checkpoint at epoch %d is unreadable (%s); trying an older one", epoch, err
                )
                errors.append(f"epoch {epoch}: {err}")
        raise FileNotFoundError(
            "no restorable checkpoint" + (": " + "; ".join(errors) if errors else "")
        )

    def close(self) -> None:
        self.manager.close()
