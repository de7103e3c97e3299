"""The method registry: what each learning method supplies to the one generic trainer.

A method is a `Learner` (a few pure functions closed over the env and its options) and the
option groups it adds to the command line. The trainer (`training/epoch.py`) owns the epoch:
collect episodes with `explore` -> `store` them -> `update` -> evaluate with `evaluate`.
Read-only inputs a method needs (the skill library) arrive as `aux`, a non-donated
argument of the jitted epoch, never as constants baked into the program.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from mjx_skills.config import DDPGConfig, EnvConfig, PASConfig, SearchConfig, TrainConfig
from mjx_skills.core.learner import Learner
from mjx_skills.methods.ddpg_her import make_ddpg_her
from mjx_skills.methods.ddpg_her_sl import make_ddpg_her_sl
from mjx_skills.methods.ddpg_her_sl_bc import BCConfig, make_ddpg_her_sl_bc
from mjx_skills.methods.ddpg_her_sl_fast import (
    FAST_DDPG,
    FAST_SEARCH,
    FastConfig,
    make_ddpg_her_sl_fast,
)
from mjx_skills.methods.library_robot import check_robot
from mjx_skills.methods.pas import make_pas


@dataclasses.dataclass(frozen=True)
class Method:
    name: str
    label: str
    """The method's name in tables and figures (e.g. "DDPG+HER+SL")."""
    description: str
    options: dict[str, Any]
    """Option groups of this method by CLI prefix, with their defaults (frozen dataclasses)."""
    make_learner: Callable[..., Learner]
    """make_learner(env, train: TrainConfig, **options) -> Learner."""
    unread: dict[str, str] = dataclasses.field(default_factory=dict)
    """Options on this method's command line that it does not read ("group.field", "train"
    for the un-prefixed ones) -> the option it reads instead. Setting one is an error."""
    unread_unless: dict[str, str] = dataclasses.field(default_factory=dict)
    """Options it reads only while a switch of the same group is on ("group.field" ->
    "switch"); setting one with the switch off is an error."""
    flat_policy: bool = False
    """Whether its evaluation behaviour is the flat DDPG actor alone (an observation and goal
    in, an action out), so that another env implementation can replay it
    (`evaluate --physics gym`)."""

    @property
    def library_group(self) -> str | None:
        """The option group that names the method's skill library (None: it has none)."""
        return next((g for g, opt in self.options.items() if hasattr(opt, "library")), None)

    def load_aux(self, options: dict[str, Any]) -> Any:
        """The read-only input of the jitted epoch: the skill library its option group names
        (None for a method without one)."""
        group = self.library_group
        if group is None:
            return None
        try:
            return load_library(options[group])
        except FileNotFoundError as err:  # name the option that points there
            flag = f"--{group}.library-dir"
            raise FileNotFoundError(
                f"{err}; {self.name} reads its library from {flag} "
                f"(now {options[group].library_dir!r}; a relative path is looked up in the "
                "working directory, then in the source checkout)"
            ) from None

    def unread_now(self, options: dict[str, Any]) -> dict[str, str]:
        """The options this method does not read with these option groups -> why."""
        off = {
            path: f"--{path.split('.')[0]}.{switch.replace('_', '-')}, which is off"
            for path, switch in self.unread_unless.items()
            if not getattr(options[path.split(".")[0]], switch)
        }
        instead = {
            path: f"it reads {why} instead" if why.startswith("--") else why
            for path, why in self.unread.items()
        }
        return {**instead, **off}


def load_library(group: SearchConfig | PASConfig) -> Any:
    """The library an option group names (`library`: SL1, SL2, SL3; `library_dir`)."""
    from mjx_skills.skills import library

    full, _ = library.load(group.library_dir)
    library.skill_envs(full.names)  # built now, not first inside a traced function
    return library.subset(full, group.library)


PAS_UNREAD = {
    "train.updates_per_cycle": "--pas.updates-per-cycle",
    "ddpg.relabel_prob": "--pas.relabel-prob",
    "ddpg.her_strategy": "--pas.hindsight",
    "ddpg.n_step": "--pas.skill-steps",
    "ddpg.future_warm_up": "--pas.relabel-prob",
    "ddpg.relabel_actual": "--pas.relabel-prob",
    "ddpg.goal_stats": "its meta-controller's normaliser sees desired and achieved goals",
    "ddpg.warm_up": "its meta-controller updates from the first cycle",
}
"""PAS / MPAS train the meta-controller with their own update count and hindsight; a meta
transition already spans its skill's env steps (no n-step returns). A value is the flag read
instead, or why the option is not read."""


SEVERAL_CUBES = {
    "search": ("in_order", "goal_clearance"),
    "env": ("object_reward", "goal_start_prob"),
}
"""Options that act only where a scene has several cubes: refused, when set, on one cube."""


def check_task(
    method: str, task: str, options: dict[str, Any] | None = None, env: Any = None
) -> None:
    """ValueError if `method` cannot run `task`. Every method runs every task (the library's
    skills act on any cube through the scene's projection onto (gripper, that cube)) except
    PAS / MPAS with the thesis's joint critic, which runs the one-cube tasks only
    (`options`: the method's option groups). Also refused: DDPG+HER+SL+BC with the scripted
    explorer, which drives no library skill, so that nothing would be cloned. A task of
    another robot than the library's is refused (`check_library_robot`); a Fetch task runs
    with an env config it can honour."""
    from mjx_skills.envs.registry import ENVS, check_name

    check_name(task)
    check_library_robot(method, task, options)
    if hasattr(ENVS[task], "check_config"):  # a task of another robot than Baxter's scenes
        ENVS[task].check_config(env or EnvConfig())
        return
    cubes = ENVS[task].n_objects
    options = options or {}
    pas = options.get("pas")
    if pas is not None and pas.critic == "joint" and cubes != 1:
        raise ValueError(
            f"--pas.critic joint (the thesis's critic) runs on one-cube tasks; "
            f"{task} has {cubes} cubes: use --pas.critic per_skill"
        )
    if cubes == 1:
        given = {**options, "env": env or EnvConfig()}
        defaults = {**get(method).options, "env": EnvConfig()}
        for group, fields in SEVERAL_CUBES.items():
            for field in fields:
                if group in given and getattr(given[group], field) != getattr(
                    defaults[group], field
                ):
                    raise ValueError(
                        f"--{group}.{field.replace('_', '-')} acts only where a scene has several "
                        f"cubes; {task} has one: leave it at its default"
                    )
    search = options.get("search")
    if method == "ddpg_her_sl_bc" and search is not None and search.explorer != "search":
        raise ValueError(
            f"ddpg_her_sl_bc clones the skills the look-ahead search drives; "
            f"--search.explorer {search.explorer} drives none, so nothing would be "
            f"cloned: use ddpg_her_sl for the {search.explorer} explorer"
        )


def check_library_robot(method: str, task: str, options: dict[str, Any] | None = None) -> None:
    """ValueError if `method` reads a skill library built for another robot than `task`'s
    (the library its option group's `library_dir` names: its manifest's robot; a library
    not built yet would be of the robot of the skills `library` names). The message
    names the library's robot and how to build one for the task's robot, or says that no
    command builds one yet. Also a ValueError for an unregistered library name, or a built
    library without a skill the named library needs. Reads only the manifest: nothing is
    loaded or written (`library_robot.check_robot`)."""
    spec = get(method)
    group = spec.library_group
    if group is None:
        return
    chosen = (options or {}).get(group, spec.options[group])
    flat = [m for m, s in METHODS.items() if s.library_group is None]
    check_robot(method, group, chosen, task, set(PRESETS), flat)


def option_flag(group: str, field: str) -> str:
    """The command-line flag of option `field` of `group` ('train': un-prefixed), e.g.
    ('ddpg', 'batch_size') -> '--ddpg.batch-size'."""
    return ("--" if group == "train" else f"--{group}.") + field.replace("_", "-")


def check_read(method: str, train: Any, options: dict[str, Any]) -> None:
    """ValueError naming any option `method` does not read that differs from its default."""
    spec = get(method)
    groups = {"train": (train, TrainConfig())} | {
        g: (options[g], spec.options[g]) for g in options if g in spec.options
    }
    full = {g: options.get(g, spec.options[g]) for g in spec.options}
    for path, why in spec.unread_now(full).items():
        group, field = path.split(".")
        given, default = groups[group]
        if getattr(given, field) != getattr(default, field):
            flag = option_flag(group, field)
            raise ValueError(
                f"{method} does not read {flag} ({why}); "
                f"leave {flag} at its default {getattr(default, field)!r}"
            )


def _pas(name: str, label: str, description: str) -> Method:
    """PAS or MPAS: one meta-controller over the skill library, with or without hindsight."""
    return Method(
        name=name,
        label=label,
        description=description,
        options={"ddpg": DDPGConfig(), "pas": PASConfig(hindsight=name == "mpas")},
        make_learner=make_pas,
        unread=PAS_UNREAD,
        unread_unless={"pas.relabel_prob": "hindsight"},
    )


METHODS: dict[str, Method] = {
    "ddpg_her": Method(
        name="ddpg_her",
        flat_policy=True,
        label="DDPG+HER",
        description="flat DDPG + HER from scratch (thesis baseline 1)",
        options={"ddpg": DDPGConfig()},
        make_learner=make_ddpg_her,
    ),
    "pas": _pas(
        "pas",
        "PAS",
        "parameterized-action-space DDPG meta-controller over the skill library, no hindsight "
        "(thesis baseline 2)",
    ),
    "mpas": _pas(
        "mpas",
        "MPAS",
        "multi-goal PAS: the meta-controller with hindsight relabelling at the skill level "
        "(thesis approach 1, ch. 4)",
    ),
    "ddpg_her_sl": Method(
        name="ddpg_her_sl",
        flat_policy=True,
        label="DDPG+HER+SL",
        description="DDPG + HER exploring with a look-ahead search over the skill library "
        "(thesis ch. 5)",
        options={"ddpg": DDPGConfig(), "search": SearchConfig()},
        make_learner=make_ddpg_her_sl,
    ),
    "ddpg_her_sl_bc": Method(
        name="ddpg_her_sl_bc",
        flat_policy=True,
        label="DDPG+HER+SL+BC",
        description="DDPG+HER+SL whose actor also clones the explorer's skills where the "
        "critic agrees (Q-filtered behaviour cloning; beyond the thesis)",
        options={"ddpg": DDPGConfig(), "search": SearchConfig(), "bc": BCConfig()},
        make_learner=make_ddpg_her_sl_bc,
    ),
    "ddpg_her_sl_fast": Method(
        name="ddpg_her_sl_fast",
        label="DDPG+HER+SL+Fast",
        description="DDPG+HER+SL made to learn faster: wider networks, more updates, a "
        "shorter explorer decay, the critic picking among the library's proposals, averaged "
        "networks evaluated (beyond the thesis)",
        options={"ddpg": FAST_DDPG, "search": FAST_SEARCH, "fast": FastConfig()},
        make_learner=make_ddpg_her_sl_fast,
        unread={"train.updates_per_cycle": "--fast.updates-per-cycle"},
        unread_unless={"fast.proposals": "pick", "fast.pick_in_training": "pick"},
    ),
}
"""Every method by name, in the thesis's order (its two baselines, its approach 1 and its
approach 2, Fig. 6.3's order), then those beyond it: tables and figures list them so."""


THESIS_LIBRARY = "experiments/skill_library_thesis"
"""The thesis preset's library: models and memories anchored at the start state
(`python -m mjx_skills.build_library --anchor start --out experiments/skill_library_thesis`)."""

FETCH_LIBRARY = "experiments/skill_library_fetch"
"""The skills built on Fetch (`python -m mjx_skills.build_library --robot fetch --library
SL1_fetch`)."""
FETCH_PUSH_LIBRARY = "experiments/skill_library_SL_fetch_push"
"""The push library of Fetch, for FetchPush (`python -m mjx_skills.build_library --robot fetch
--library SL_fetch_push`)."""
FETCH_SEARCH = {"transit_height": (0.05, 0.07)}
"""The search's transit goals on Fetch: 5-7 cm above the block, since Fetch's closed fingertips
reach 5 cm below the grip (Baxter's 3-4.5 cm press them into the block; docs/simulation.md)."""

PRESETS: dict[str, dict[str, dict[str, dict[str, Any]]]] = {
    "default": {},
    "thesis": {
        "ddpg_her_sl": {
            "search": {"stall_memory": 0, "waypoint_share": 0.0, "library_dir": THESIS_LIBRARY}
        },
        **{
            name: {
                "pas": {"critic": "joint", "terminal_at_goal": False, "library_dir": THESIS_LIBRARY}
            }
            for name in ("pas", "mpas")
        },
    },
}
FETCH_PUSH_SEARCH = {"skip_reached": True}
"""The search with the push library: no edge of a skill already at its goal (approach, once
behind the block, was picked again and again; `SearchConfig.skip_reached`)."""


def _library_preset(library: str, directory: str, search: dict[str, Any]) -> dict[str, Any]:
    """Every library method pointed at `library` in `directory`, the search with `search`."""
    return {
        name: {
            spec.library_group: {
                "library": library,
                "library_dir": directory,
                **(search if spec.library_group == "search" else {}),
            }
        }
        for name, spec in METHODS.items()
        if spec.library_group is not None
    }


PRESETS["fetch"] = _library_preset("SL1_fetch", FETCH_LIBRARY, FETCH_SEARCH)
PRESETS["fetch_push"] = _library_preset("SL_fetch_push", FETCH_PUSH_LIBRARY, FETCH_PUSH_SEARCH)
FETCH_PUSH_TRAIN = {"updates_per_cycle": 200}
PRESETS["fetch_push"]["ddpg_her_sl"]["search"]["eps_decay_epochs"] = 60
PRESETS["fetch_push"]["ddpg_her_sl"]["train"] = dict(FETCH_PUSH_TRAIN)
PRESETS["fetch_push"]["ddpg_her"] = {"train": dict(FETCH_PUSH_TRAIN)}
"""Named option sets by method and group, applied over the defaults (explicit flags win);
the group 'train' sets `TrainConfig` fields (`preset_train`).
'fetch': the library methods with the skills built on Fetch, for the Fetch tasks;
'fetch_push': with the push library of Fetch (approach and push), for FetchPush, and
DDPG+HER+SL's learner as tuned there on the tuning seeds (eps over 60 epochs, 200 updates
per cycle; docs/results.md, the Fetch section), DDPG+HER given the same updates (its matched
baseline).
'thesis': each method as the thesis formulates it, where our defaults depart from it by
measurement (field by field, with what they change: docs/results.md, "Our defaults against the thesis's formulation"). DDPG+HER
has no departure of formulation (its hyperparameters: `DDPGConfig`)."""


def preset_options(method: str, preset: str = "default") -> dict[str, Any]:
    """The option groups of `method` with preset `preset` applied to their defaults."""
    spec = get(method)
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; valid: {', '.join(PRESETS)}")
    changes = PRESETS[preset].get(method, {})
    return {
        group: dataclasses.replace(default, **changes.get(group, {}))
        for group, default in spec.options.items()
    }


def preset_train(method: str, preset: str = "default") -> TrainConfig:
    """`TrainConfig()` with the 'train' fields of `preset` for `method` applied (the command's
    and an experiment's [train] apply over it). ValueError on an unknown method or preset."""
    preset_options(method, preset)  # names the valid methods and presets
    return dataclasses.replace(TrainConfig(), **PRESETS[preset].get(method, {}).get("train", {}))


def get(name: str) -> Method:
    """The registered method `name`; a clear error naming the valid ones otherwise."""
    if name in METHODS:
        return METHODS[name]
    raise ValueError(f"unknown method {name!r}; valid: {', '.join(METHODS)}")
