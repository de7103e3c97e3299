"""The layout of a run's config (RUN_DIR/config.json, and the `config` of a stored cell's
definition) and the one migration that brings an older config up to it.

`SCHEMA` numbers the layout. A config records the number it was written at (`schema`); one
written before the number was stamped is schema 1. `migrate` upgrades a config of any
earlier schema to SCHEMA, one step at a time (`STEPS`). A step says what the code did before
a change that today's defaults would read otherwise: a field added after runs had been made
without it, at a default that differs from what those runs did. A field added at the
default that keeps the earlier behaviour needs no step: a config that lacks it reads at its
default (`sweeps.cells.differences`).

Every reader of an older config goes through `migrate`: resuming a run (`runner.load_config`)
and comparing a run directory or a stored cell with a definition (`sweeps.cells`).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

SCHEMA = 2
"""The layout this code writes."""


def _fast_defaults_changed(config: dict[str, Any]) -> None:
    """1 -> 2: DDPG+HER+SL+Fast's `fast.pick_in_training` and `fast.eval_average` were added
    after runs had trained with the pick also in training and the online networks evaluated;
    their defaults are now off and 0.8."""
    fast = config.get("options", {}).get("fast")
    if config.get("method") == "ddpg_her_sl_fast" and fast is not None:
        fast.setdefault("pick_in_training", True)
        fast.setdefault("eval_average", 0.0)


STEPS: dict[int, Callable[[dict[str, Any]], None]] = {1: _fast_defaults_changed}
"""Schema n -> the step that upgrades a config of schema n to n + 1, in place."""


def migrate(config: dict[str, Any]) -> dict[str, Any]:
    """A copy of `config` (a run config as JSON reads back) upgraded to SCHEMA. ValueError
    for a schema this code does not know (written by newer code, or not a number)."""
    found = config.get("schema", 1)
    if not isinstance(found, int) or isinstance(found, bool) or not 1 <= found <= SCHEMA:
        raise ValueError(
            f"config schema {found!r}: this code reads 1 to {SCHEMA} (a run or cell written by "
            "newer code? update the package)"
        )
    out = copy.deepcopy(config)
    for n in range(found, SCHEMA):
        STEPS[n](out)
    out["schema"] = SCHEMA
    return out
