"""Orbax checkpoints of the whole run state (params, optimisers, normalisers, replay, keys).

Orbax writes each step to a temporary directory and renames it when complete, so a
half-written checkpoint is never taken for a good one; a checkpoint that fails to restore
is reported and the previous good one is used. Each save also records a SHA-256 of the
carry's arrays (checkpoints/digests.json, by epoch): a checkpoint that restores to other
contents than were saved (damaged bytes that still decode) is treated as unreadable too.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

import jax
import orbax.checkpoint as ocp

from mjx_skills.core.files import read_json, tree_sha256, write_json_atomic
from mjx_skills.core.paths import check_writable_path

log = logging.getLogger(__name__)


def _signature(tree: Any) -> list[tuple]:
    """Sorted (shape, dtype) of every leaf: equal for the same run whatever the container types."""
    return sorted((tuple(x.shape), str(x.dtype)) for x in jax.tree.leaves(tree))


class Checkpoints:
    def __init__(self, directory: Path, max_to_keep: int = 3):
        # Refused before orbax touches it: it would save nothing readable there, and set a
        # good checkpoint aside as corrupt when reading one (`core.paths`).
        self.directory = check_writable_path(directory, "the checkpoint directory")
        self._options = ocp.CheckpointManagerOptions(max_to_keep=max_to_keep, create=True)
        self.manager = ocp.CheckpointManager(self.directory, options=self._options)

    def save(self, epoch: int, carry: Any) -> None:
        """Write `carry` as the checkpoint of `epoch`, and its digest. Done with `carry` when
        it returns (the caller may donate its buffers next)."""
        digest = tree_sha256(carry)
        self.manager.save(epoch, args=ocp.args.StandardSave(carry), force=True)
        self.manager.wait_until_finished()
        # After the save: a digest without its checkpoint is harmless, never the reverse.
        kept = {str(e) for e in self.manager.all_steps()}
        digests = {e: d for e, d in self._digests().items() if e in kept}
        write_json_atomic(self._digest_path, {**digests, str(epoch): digest}, indent=1)

    @property
    def _digest_path(self) -> Path:
        return self.directory / "digests.json"

    def _digests(self) -> dict[str, str]:
        """Recorded digests by epoch ({} when none, or when the file is unreadable: then
        every checkpoint restores unverified, with a warning)."""
        if not self._digest_path.exists():
            return {}
        try:
            return dict(read_json(self._digest_path))
        except ValueError as err:
            log.warning("%s; restoring checkpoints without verifying them", err)
            return {}

    def latest_epoch(self) -> int | None:
        return self.manager.latest_step()

    def epochs(self) -> list[int]:
        """The epochs that have a checkpoint, oldest first."""
        return sorted(self.manager.all_steps())

    def restore(self, like: Any, at_most: int | None = None) -> tuple[int, Any]:
        """Newest restorable checkpoint (of an epoch <= `at_most`, if given: newer ones are
        left as they are) -> (epoch, carry shaped like `like`).

        An unreadable checkpoint, or one whose contents differ from the digest recorded at
        its save, is reported, set aside and skipped for the one before it; one without a
        recorded digest (an older run) restores with a warning. One that reads but holds
        other shapes than `like` raises ValueError (a different run); FileNotFoundError
        when none restores."""
        abstract = jax.tree.map(ocp.utils.to_shape_dtype_struct, like)
        errors, digests = [], self._digests()
        for epoch in sorted(self.manager.all_steps(), reverse=True):
            if at_most is not None and epoch > at_most:
                continue
            try:
                saved = self.manager.restore(epoch, args=ocp.args.StandardRestore())
            except Exception as err:  # noqa: BLE001 - any unreadable file means a bad checkpoint
                why = _brief(err)
                log.warning(
                    "checkpoint at epoch %d is unreadable (%s); trying an older one", epoch, why
                )
                errors.append(f"epoch {epoch}: {why}")
                self._set_aside(epoch)
                continue
            if _signature(saved) != _signature(abstract):
                raise ValueError(
                    f"checkpoint at epoch {epoch} does not match this run: it holds other "
                    "array shapes (task, method or sizes differ from config.json, or an earlier "
                    "mjx_skills wrote it, whose counters were one int32 each, not a pair)"
                )
            restored = self.manager.restore(epoch, args=ocp.args.StandardRestore(abstract))
            recorded = digests.get(str(epoch))
            if recorded is None:
                why = "has no recorded digest (an older run); restoring it unverified"
                log.warning("checkpoint at epoch %d %s", epoch, why)
            elif tree_sha256(restored) != recorded:
                why = "restores to other contents than were saved (damaged)"
                log.warning("checkpoint at epoch %d %s; trying an older one", epoch, why)
                errors.append(f"epoch {epoch}: contents differ from the recorded digest")
                self._set_aside(epoch)
                continue
            return epoch, restored
        raise FileNotFoundError(
            "no restorable checkpoint" + (": " + "; ".join(errors) if errors else "")
        )

    def set_aside_after(self, epoch: int) -> None:
        """Rename the checkpoints of epochs after `epoch` to <epoch>.unlogged-<time>: kept, out
        of the way of those epochs' saves when a resume trains them again."""
        for later in [e for e in self.epochs() if e > epoch]:
            self._set_aside(later, "unlogged")

    def _set_aside(self, epoch: int, why: str = "corrupt") -> None:
        """Rename a bad checkpoint to <epoch>.<why>-<time> (kept for inspection, out of the
        way of the epoch's next save)."""
        path = self.directory / str(epoch)
        if path.exists():
            path.rename(path.with_name(f"{epoch}.{why}-{int(time.time())}"))
        # A fresh manager: one that failed on a damaged step can refuse every other step
        # ("Must provide `args` of type `Composite`"), and good ones would be set aside.
        self.manager.close()
        self.manager = ocp.CheckpointManager(self.directory, options=self._options)

    def close(self) -> None:
        self.manager.close()


BRIEF = 300
"""Most characters of a reading error that a message quotes."""


def _brief(err: Exception) -> str:
    """A reading error in one short line: tensorstore appends its whole spec (about 1 kB of
    JSON) to every message, which says nothing about which file is damaged."""
    text = " ".join(str(err).split("[tensorstore_spec=")[0].split()) or type(err).__name__
    return text if len(text) <= BRIEF else text[: BRIEF - 3] + "..."
