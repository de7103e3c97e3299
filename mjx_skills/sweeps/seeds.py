"""Tuning seeds and reporting seeds, kept apart by the code.

Every default chosen by measurement is chosen on `TUNING_SEEDS` (0-4; every cell stored
before this split ran on seeds starting at 0). A headline number (a target of a method
beyond the thesis, a claim against a baseline) is reported on seeds that no tuning run used:
by this project's convention `FRESH_SEEDS` (100-109). An experiment file says which kind it
is (`role = "tuning"`, the default, or `role = "headline"` with `seed = 100`): a headline
experiment whose seeds meet the tuning seeds is refused when the file is read, and a report
refuses to read a cell as a headline when its definition ran on a tuning seed
(`check_headline`).

Seeds are the training runs' first PRNG seeds: a run of `seeds` seeds from `seed` trains
seeds `seed, seed + 1, ..., seed + seeds - 1` (`training.epoch.seed_keys`).
"""

from __future__ import annotations

from typing import Any

TUNING_SEEDS = range(0, 5)
"""The seeds every measured default is chosen on."""
FRESH_SEEDS = range(100, 110)
"""The seeds headlines are reported on: no tuning run used them."""
ROLES = ("tuning", "headline")
"""What an experiment's cells are for: choosing settings, or reporting a headline."""


def seed_range(first: int, count: int) -> range:
    """The seeds of a run of `count` seeds from `first`."""
    return range(first, first + count)


def describe(seeds: range) -> str:
    """'100-109' ('3' for one seed)."""
    return str(seeds.start) if len(seeds) == 1 else f"{seeds.start}-{seeds.stop - 1}"


def cell_seeds(definition: dict[str, Any]) -> range:
    """The seeds a stored cell ran (its `definition.json`: config.train.seed, .seeds)."""
    train = definition["config"]["train"]
    return seed_range(int(train.get("seed", 0)), int(train["seeds"]))


def check_headline_seeds(where: str, seeds: range) -> None:
    """ValueError, naming `where`, if `seeds` include a tuning seed."""
    tuned = sorted(set(seeds) & set(TUNING_SEEDS))
    if tuned:
        raise ValueError(
            f"{where}: a headline is reported on seeds no tuning run used, but seeds "
            f"{describe(seeds)} include the tuning seeds {tuned} (TUNING_SEEDS "
            f"{describe(TUNING_SEEDS)}); run it from seed = {FRESH_SEEDS.start} (the fresh seeds "
            f"{describe(FRESH_SEEDS)})"
        )


def check_headline(name: str, definition: dict[str, Any]) -> range:
    """The seeds of stored cell `name` (its definition), if it may be reported as a headline;
    ValueError if they include a tuning seed."""
    seeds = cell_seeds(definition)
    check_headline_seeds(f"cell {name}", seeds)
    return seeds
