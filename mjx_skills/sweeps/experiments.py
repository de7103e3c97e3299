"""The thesis's experiments as data: experiments/NAME.toml -> cells of training runs.

A file holds a description, `tasks`, `methods`, optional `libraries` (SL1 / SL2 / SL3, for
the library methods), `seeds`, `epochs`, optional `[train]` overrides (TrainConfig fields)
and `[options.METHOD.GROUP]` overrides (e.g. `[options.mpas.pas] critic = "joint"`), applied
over the optional `preset` (`mjx_skills.methods.PRESETS`, e.g. `preset = "thesis"`), optional
`[env]` overrides (EnvConfig fields) and a `label` that the cells' names end with (cells
that change a setting keep apart from the default's, which the store would otherwise refuse):

    description = "Fig. 6.5: container with a wall"
    tasks = ["container_wall"]
    methods = ["ddpg_her", "ddpg_her_sl"]
    seeds = 3
    epochs = 50

`seed` (default 0) is the cells' first seed, and `role` says what they are for (`tuning`, the
default, or `headline`: reported as a result, so its seeds must not meet the tuning seeds 0-4;
`sweeps.seeds`):

    role = "headline"
    seed = 100
    seeds = 10

`kind = "library"` (Table 5.1) builds skill libraries instead, one cell per entry of
`samples`, with optional `[library]` overrides (LibraryConfig fields, e.g. `anchor =
"goal"`); they share one work directory, so the skills are trained once.

A variant states only what it changes: `extends = "PARENT"` merges PARENT's keys under its
own (`sweeps.experiment_file`). Every name is checked when the file is read, so a typo
fails before any training.
"""

from __future__ import annotations

import dataclasses
import itertools
import typing
from typing import Any

from mjx_skills.sweeps.cell import Cell
from mjx_skills.sweeps.experiment_file import GROUPS, read
from mjx_skills.sweeps.seeds import ROLES, check_headline_seeds, seed_range


@dataclasses.dataclass(frozen=True)
class Experiment:
    name: str
    description: str
    tasks: tuple[str, ...] = ()
    methods: tuple[str, ...] = ()
    kind: str = "train"
    """'train': tasks x methods x libraries; 'library': one skill library per `samples`."""
    samples: tuple[int, ...] = ()
    libraries: tuple[str, ...] = ("SL1",)
    seeds: int = 3
    epochs: int = 50
    train: dict[str, Any] = dataclasses.field(default_factory=dict)
    options: dict[str, dict[str, dict[str, Any]]] = dataclasses.field(default_factory=dict)
    library: dict[str, Any] = dataclasses.field(default_factory=dict)
    """A library experiment's LibraryConfig overrides (besides `samples`)."""
    preset: str = "default"
    """Option preset of every method (`methods.PRESETS`); `options` apply over it."""
    env: dict[str, Any] = dataclasses.field(default_factory=dict)
    """EnvConfig overrides of every cell."""
    label: str = ""
    """Ends every cell's name (a variant of the default cells)."""
    seed: int = 0
    """The first seed of every cell (seeds `seed` ... `seed + seeds - 1`)."""
    role: str = "tuning"
    """`sweeps.seeds.ROLES`: 'headline' cells must not run on a tuning seed."""
    group: str = "adhoc"
    """What the experiment is for (`GROUPS`; `sweep --list` groups by it)."""
    baseline: str = ""
    """A headline's matched baseline: the experiment (file name) whose cells it is set
    against, run on the same seeds."""
    target: dict[str, Any] = dataclasses.field(default_factory=dict)
    """A headline's target, `{level = 0.9, epoch = 30}`: the 5-epoch rolling mean of eval
    success over its seeds reaches `level` by `epoch`."""

    def __post_init__(self) -> None:
        from mjx_skills import methods
        from mjx_skills.config import EnvConfig, TrainConfig
        from mjx_skills.envs.registry import check_name
        from mjx_skills.skills.library import library_skills

        self._check_types()
        self._check_lists()
        if self.kind not in ("train", "library"):
            raise ValueError(
                f"experiment {self.name}: unknown kind {self.kind!r}; valid: train, library"
            )
        if self.kind == "library" and (not self.samples or min(self.samples) < 100):
            raise ValueError(f"experiment {self.name}: a library experiment needs samples >= 100")
        if self.library:
            from mjx_skills.config import LibraryConfig

            if self.kind != "library":
                raise ValueError(f'experiment {self.name}: [library] needs kind = "library"')
            self._check_fields("[library]", self.library, LibraryConfig, {"samples"})
        for task in self.tasks:
            check_name(task)
        for method in self.methods:
            methods.preset_options(method, self.preset)  # unknown method or preset fails here
        for lib in self.libraries:
            try:
                library_skills(lib)
            except ValueError as err:
                raise ValueError(f"experiment {self.name}: {err}") from None
        if self.seeds < 1 or self.epochs < 1:
            raise ValueError(f"experiment {self.name}: seeds and epochs must be >= 1")
        self._check_seeds()
        self._check_target()
        if self.group not in GROUPS:
            raise ValueError(
                f"experiment {self.name}: unknown group {self.group!r}; valid: {', '.join(GROUPS)}"
            )
        self._check_fields("[env]", self.env, EnvConfig)
        if self.label and not self.label.replace("_", "").isalnum():
            raise ValueError(f"experiment {self.name}: label {self.label!r}: letters, digits, _")
        self._check_fields(
            "[train]",
            self.train,
            TrainConfig,
            {"task", "epochs", "seed", "seeds", "out", "progress"},
        )
        for method, groups in self.options.items():
            if method not in self.methods:
                raise ValueError(
                    f"experiment {self.name}: [options.{method}] sets options of a method it "
                    f"does not run (methods: {', '.join(self.methods)}); they would be dropped"
                )
            spec = methods.get(method)
            for group, fields in groups.items():
                if group not in spec.options:
                    raise ValueError(
                        f"experiment {self.name}: {method} has no option group {group!r}; "
                        f"valid: {sorted(spec.options)}"
                    )
                if group == spec.library_group and "library" in fields:
                    raise ValueError(
                        f"experiment {self.name}: [options.{method}.{group}] library: the "
                        "cells' libraries come from `libraries = [...]`; set it there"
                    )
                default = methods.preset_options(method, self.preset)[group]
                self._check_fields(f"[options.{method}.{group}]", fields, type(default))
        if self.kind == "train":
            self._check_cells()

    def _check_seeds(self) -> None:
        """`role` is one of `ROLES`; `seed` is >= 0; a headline's seeds are not tuning seeds."""
        if self.role not in ROLES:
            raise ValueError(
                f"experiment {self.name}: unknown role {self.role!r}; valid: {', '.join(ROLES)}"
            )
        if self.seed < 0:
            raise ValueError(f"experiment {self.name}: seed must be >= 0, got {self.seed}")
        if self.role == "headline":
            check_headline_seeds(f"experiment {self.name}", seed_range(self.seed, self.seeds))

    def _check_target(self) -> None:
        """`target` holds exactly a level in (0, 1] and an epoch within the budget."""
        if not self.target:
            return
        where = f"experiment {self.name}: target"
        if set(self.target) != {"level", "epoch"}:
            raise ValueError(f"{where}: give level and epoch, got {sorted(self.target)}")
        level, epoch = self.target["level"], self.target["epoch"]
        if not isinstance(level, int | float) or not 0 < level <= 1:
            raise ValueError(f"{where}: level must be in (0, 1], got {level!r}")
        if not isinstance(epoch, int) or not 1 <= epoch <= self.epochs:
            raise ValueError(f"{where}: epoch must be 1 .. {self.epochs}, got {epoch!r}")

    def _check_types(self) -> None:
        """Every top-level value has its field's type (`config.checked_value`): `seeds = 3.0`
        or `tasks = "pick_move"` fail here, naming the key."""
        from mjx_skills.config import checked_value

        hints = typing.get_type_hints(Experiment)
        for field in dataclasses.fields(self):
            value, hint = getattr(self, field.name), hints[field.name]
            where = f"experiment {self.name}: {field.name}"
            if typing.get_origin(hint) is dict:
                if not isinstance(value, dict):
                    raise ValueError(f"{where}: must be a table, got {value!r}")
                if field.name == "options":
                    self._check_option_tables(value)
                continue
            try:
                object.__setattr__(self, field.name, checked_value(field.name, value, hint))
            except ValueError as err:
                raise ValueError(f"experiment {self.name}: {err}") from None

    def _check_option_tables(self, options: dict) -> None:
        """`[options.METHOD.GROUP]` are tables of tables: a value elsewhere names its key."""
        for method, groups in options.items():
            if not isinstance(groups, dict):
                raise ValueError(
                    f"experiment {self.name}: options.{method} must be a table of option "
                    f"groups ([options.{method}.GROUP]), got {groups!r}"
                )
            for group, fields in groups.items():
                if not isinstance(fields, dict):
                    raise ValueError(
                        f"experiment {self.name}: options.{method}.{group} must be a table of "
                        f"fields ([options.{method}.{group}] name = value), got {fields!r}"
                    )

    def _check_lists(self) -> None:
        """tasks, methods and libraries name each entry once, and are non-empty in a training
        experiment (a repeated
        one would run two workers into one cell directory)."""
        for key in ("tasks", "methods", "libraries"):
            values = getattr(self, key)
            if not values and self.kind == "train":
                raise ValueError(f"experiment {self.name}: {key} is empty; give at least one")
            repeated = sorted({v for v in values if values.count(v) > 1})
            if repeated:
                raise ValueError(
                    f"experiment {self.name}: {key} lists {repeated} more than once; each "
                    "cell runs once"
                )

    def _check_fields(self, where: str, fields: dict, cls: type, fixed: set = frozenset()) -> None:
        """Every key of a table names a field of `cls` (not one of `fixed`, set elsewhere),
        and `cls` takes the values: else ValueError naming the table and the valid fields."""
        valid = {f.name for f in dataclasses.fields(cls)} - set(fixed)
        if set(fields) & set(fixed):
            raise ValueError(
                f"experiment {self.name}: {where} {sorted(set(fields) & set(fixed))}: set by "
                "the experiment's own keys or by the sweep (--sweep-dir, --no-progress), not "
                "in this table"
            )
        unknown = sorted(set(fields) - valid)
        if unknown:
            raise ValueError(
                f"experiment {self.name}: unknown {where} field(s) {unknown}; "
                f"valid: {sorted(valid)}"
            )
        try:
            cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()})
        except ValueError as err:
            raise ValueError(f"experiment {self.name}: {where}: {err}") from None

    def _check_cells(self) -> None:
        """Each cell's run would read every option the file sets and can run its task
        (`methods.check_read`, `methods.check_task`), so no override is dropped silently."""
        from mjx_skills import methods

        uses_library = any(methods.get(m).library_group for m in self.methods)
        if self.libraries != ("SL1",) and not uses_library:
            raise ValueError(
                f"experiment {self.name}: libraries {list(self.libraries)} but none of "
                f"{', '.join(self.methods)} uses a skill library"
            )
        for cell in self.cells():
            args = cell.run_args(out="", progress=False)
            try:
                methods.check_read(cell.method, args.train, dict(args.options))
                methods.check_task(cell.method, cell.task, dict(args.options), args.env)
            except ValueError as err:
                raise ValueError(f"experiment {self.name}, cell {cell.name}: {err}") from None

    def with_budget(self, seeds: int | None = None, epochs: int | None = None) -> Experiment:
        """This experiment with another budget where one is given (None: its own); a
        value below 1 is refused (ValueError), never taken as "not given"."""
        seeds = self.seeds if seeds is None else seeds
        return dataclasses.replace(
            self, seeds=seeds, epochs=self.epochs if epochs is None else epochs
        )

    def cells(self) -> list[Cell]:
        if self.kind == "library":
            opts = (("library", tuple(sorted(self.library.items()))),) if self.library else ()
            return [Cell("-", "library", None, 1, 1, options=opts, samples=n) for n in self.samples]
        from mjx_skills import methods

        out = []
        # Method by method, so an interrupted sweep has whole methods' results first.
        for method, task in itertools.product(self.methods, self.tasks):
            libs = self.libraries if methods.get(method).library_group else (None,)
            for lib in libs:
                # TOML arrays become tuples: the config fields they set are tuples (hidden).
                opts = tuple(
                    (
                        g,
                        tuple(
                            sorted(
                                (k, tuple(v) if isinstance(v, list) else v) for k, v in f.items()
                            )
                        ),
                    )
                    for g, f in sorted(self.options.get(method, {}).items())
                )
                cell = Cell(
                    task,
                    method,
                    lib,
                    self.seeds,
                    self.epochs,
                    tuple(sorted(self.train.items())),
                    opts,
                    preset=self.preset,
                    env=tuple(sorted(self.env.items())),
                    label=self.label,
                    seed=self.seed,
                )
                out.append(cell)
        return out


def load_experiment(name: str) -> Experiment:
    """experiments/NAME.toml, its `extends` chain merged (`experiment_file.read`), checked
    whole (ValueError naming the file and key)."""
    known = {f.name for f in dataclasses.fields(Experiment)} - {"name"}
    return Experiment(name=name, **read(name, known))


def adhoc(
    name: str,
    tasks,
    methods,
    libraries=None,
    preset: str = "default",
    seeds: int | None = None,
    epochs: int | None = None,
) -> Experiment:
    """The grid `tasks` x `methods` (x `libraries`, default SL1) with option preset `preset`,
    at `seeds` and `epochs` where given (else the Experiment's defaults), checked as built
    (ValueError naming the cell at the budget asked for)."""
    budget = {k: v for k, v in {"seeds": seeds, "epochs": epochs}.items() if v is not None}
    return Experiment(
        name=name,
        description="ad-hoc grid",
        tasks=tuple(tasks),
        methods=tuple(methods),
        libraries=tuple(libraries or ("SL1",)),
        preset=preset,
        **budget,
    )
