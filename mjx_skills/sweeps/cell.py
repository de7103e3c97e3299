"""A cell of a sweep: one training run (a task, a method, its library, options and budget,
with all its seeds in one vmapped program), named so that its results can be stored and
found again (`sweeps.cells`)."""

from __future__ import annotations

import dataclasses
from typing import Any

from mjx_skills.sweeps.seeds import describe, seed_range


@dataclasses.dataclass(frozen=True)
class Cell:
    """One training run of a sweep: a task, a method, its library and the budget."""

    task: str
    method: str
    library: str | None
    seeds: int
    epochs: int
    train: tuple[tuple[str, Any], ...] = ()
    """TrainConfig overrides as (field, value) pairs (hashable)."""
    options: tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] = ()
    """Option-group overrides: (group, ((field, value), ...))."""
    samples: int | None = None
    """A library cell: build a skill library from this many runs per skill (Table 5.1)."""
    preset: str = "default"
    """The method's option preset (`methods.PRESETS`), under `options`."""
    env: tuple[tuple[str, Any], ...] = ()
    """EnvConfig overrides as (field, value) pairs."""
    label: str = ""
    """Appended to the name: a variant of a cell (e.g. 'single_goal')."""
    seed: int = 0
    """The first seed (`sweeps.seeds`): the name says the seeds when it is not 0."""

    @property
    def name(self) -> str:
        if self.samples:
            fields = dict(self.options).get("library", ())
            return f"library-n{self.samples}" + "".join(f"-{k}-{v}" for k, v in fields)
        lib = f"-{self.library}" if self.library else ""
        preset = "" if self.preset == "default" else f"-{self.preset}"
        label = f"-{self.label}" if self.label else ""
        seeds = f"s{self.seeds}"
        if self.seed:
            seeds = "seeds" + describe(seed_range(self.seed, self.seeds))
        return f"{self.task}-{self.method}{lib}{preset}{label}-{seeds}-e{self.epochs}"

    def run_args(self, out: str, progress: bool = True):
        from mjx_skills import methods
        from mjx_skills.config import EnvConfig
        from mjx_skills.training.runner import RunArgs

        spec = methods.get(self.method)
        groups = {group: dict(fields) for group, fields in self.options}
        if self.library:
            groups.setdefault(methods.get(self.method).library_group, {})["library"] = self.library
        base = methods.preset_options(self.method, self.preset)
        options = {g: dataclasses.replace(base[g], **groups.get(g, {})) for g in spec.options}
        train = dataclasses.replace(
            methods.preset_train(self.method, self.preset),
            task=self.task,
            epochs=self.epochs,
            seed=self.seed,
            seeds=self.seeds,
            out=out,
            progress=progress,
            **dict(self.train),
        )
        return RunArgs(
            train=train, method=self.method, env=EnvConfig(**dict(self.env)), options=options
        )
