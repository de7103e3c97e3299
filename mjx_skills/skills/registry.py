"""Every skill the library can hold, by name: one `Skill` definition each (its env, when it may
start, whether it travels to its goal, how the search proposes its goals), and the libraries
(named sets of skills) the methods read.

The library (`skills.library`), the look-ahead search (`skills.lookahead`), PAS / MPAS
(`methods.pas`), the stall memory (`skills.stalls`) and `build_library` read the skills
from here, never from names in their code, so a skill of your own is one definition:

    from mjx_skills.skills.registry import Skill, register_library, register_skill

    register_skill(Skill(name="push", env=Push, start="empty", moves=True, propose=...))
    register_library("SL_push", ("transit", "grasp", "transfer", "push"))

in a module passed to the commands with `--import` (docs/extending.md, "Adding a skill";
examples/push_skill/).
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Literal, NamedTuple

import jax
import jax.numpy as jnp

from mjx_skills.config import LIBRARIES as THESIS_LIBRARIES
from mjx_skills.config import LibraryConfig, SearchConfig
from mjx_skills.envs import fetch_push_skills as push
from mjx_skills.envs import registry as envs

Start = Literal["empty", "held", "any"]
STARTS: tuple[str, ...] = ("empty", "held", "any")


class Edges(NamedTuple):
    """What a skill's goal proposer sees: N search states, b edges each, and each edge's
    random draws (shared by every skill, so a proposer adds no randomness of its own)."""

    obs: jax.Array
    """(N, obs_dim) the states the edges start from."""
    task_goal: jax.Array
    """(N, 3) the task's goal."""
    noise: jax.Array
    """(N, b, 3) uniform in [-1, 1]."""
    height: jax.Array
    """(N, b) uniform in [0, 1]."""
    lift: jax.Array
    """(N, b, 1) uniform in [-1, 1]."""
    way: jax.Array
    """(N, b, 1) uniform in [0, 1] (the waypoint coin)."""
    where: jax.Array
    """(N, b, 3) uniform in [0, 1] (a position share of a box)."""


Proposer = Callable[..., jax.Array]
"""propose(env, cfg: SearchConfig, edges: Edges) -> goals (N, b, 3), `env` the skill's env."""


@dataclasses.dataclass(frozen=True)
class Skill:
    """One skill of the library. ValueError from `register_skill` for a bad field."""

    name: str
    """A Python identifier; also the name of its env in `envs.registry` (`--task NAME`
    trains the skill alone)."""
    env: type
    """Its skill env: an `envs.baxter.BaxterEnv` subclass declaring `param_dim` (<= 3),
    `goal_from_param`, `terminated`, `state_dims` and `memory_dims` (envs/skills.py)."""
    propose: Proposer
    """The search's candidate goals for it (`Proposer`)."""
    start: Start = "empty"
    """When it may start: with an empty gripper, with the object in hand ('held': it also
    stops once the object leaves the gripper, `methods.pas`), or 'any'."""
    moves: bool = False
    """It travels in a straight line to its goal (the stall memory prunes such edges
    through remembered obstacles, `skills.stalls`)."""
    near_object: bool = False
    """It may start only within `--search.grasp-reach` of the object (when that is > 0)."""
    held_training_starts: bool = False
    """`build_library` trains it with `LibraryConfig.grasp_held_start_prob` of its episodes
    starting with the object held (the thesis's grasp)."""
    epochs: int | str = 100
    """DDPG+HER epochs `build_library` trains it for: a number, or the name of the
    `LibraryConfig` field that holds it (the thesis's skills: `transit_epochs`, ...)."""
    thesis_cm: tuple[float, float] | None = None
    """Table 5.1 of the thesis, (memory, neural network) terminal error in cm, if it has one."""


def _above_object(env, cfg: SearchConfig, e: Edges) -> jax.Array:
    """Transit: just above the object, xy within `object_goal_noise`, z in `transit_height`."""
    obj = e.obs[:, None, env.layout["object"]]
    lo, hi = cfg.transit_height
    height = lo + (hi - lo) * e.height
    return obj + jnp.concatenate([cfg.object_goal_noise * e.noise[..., :2], height[..., None]], -1)


def _lift(env, cfg: SearchConfig, e: Edges) -> jax.Array:
    """Grasp: its lift height (the lift draw through the env's goal parameters)."""
    obs = jnp.broadcast_to(e.obs[:, None], (*e.lift.shape[:2], e.obs.shape[-1]))
    return env.goal_from_param(e.lift, obs)


def _near_task_goal(env, cfg: SearchConfig, e: Edges) -> jax.Array:
    """Transfer: near the task goal, or (`waypoint_share`) a waypoint anywhere in the
    object's goal box; clipped into that box."""
    goal = e.task_goal[:, None] + cfg.transfer_goal_noise * e.noise
    low, high = env.object_goal_box()
    if cfg.waypoint_share > 0:
        anywhere = jnp.asarray(low) + (jnp.asarray(high) - jnp.asarray(low)) * e.where
        goal = jnp.where(e.way < cfg.waypoint_share, anywhere, goal)
    return jnp.clip(goal, low, high)


_BUILT_IN = (
    Skill(
        "transit",
        envs.ENVS["transit"],
        _above_object,
        moves=True,
        epochs="transit_epochs",
        thesis_cm=(1.9, 1.6),
    ),
    Skill(
        "grasp",
        envs.ENVS["grasp"],
        _lift,
        near_object=True,
        held_training_starts=True,
        epochs="grasp_epochs",
        thesis_cm=(2.8, 1.2),
    ),
    Skill(
        "transfer",
        envs.ENVS["transfer"],
        _near_task_goal,
        start="held",
        moves=True,
        epochs="transfer_epochs",
        thesis_cm=(4.6, 2.0),
    ),
)
_FETCH = tuple(
    dataclasses.replace(
        skill, name=f"fetch_{skill.name}", env=envs.ENVS[f"fetch_{skill.name}"], thesis_cm=None
    )
    for skill in _BUILT_IN
)
"""The same three skills on Fetch (`envs/fetch_skills.py`): the same proposers, starts and
budgets; the thesis has no Table 5.1 figures for them."""


def _behind_object(env, cfg: SearchConfig, e: Edges) -> jax.Array:
    """Approach: where a push towards the task's goal starts (`envs.fetch_push_skills`),
    BEHIND behind the object opposite the goal, PUSH_HEIGHT's top above its centre (the
    floor of approach's box), xy within `object_goal_noise`; clipped into the box."""
    obj = e.obs[:, None, env.layout["object"]]  # (N, 1, 3)
    way = (e.task_goal[:, None] - obj) * jnp.array([1.0, 1.0, 0.0])
    way = way / jnp.maximum(jnp.linalg.norm(way, axis=-1, keepdims=True), 1e-6)
    goal = obj - push.BEHIND * way + jnp.array([0.0, 0.0, push.PUSH_HEIGHT[1]])
    grip = e.obs[:, None, env.layout["grip"]]
    far = jnp.linalg.norm((goal - grip)[..., :2], axis=-1, keepdims=True) > push.LINE_UP
    goal = goal + jnp.where(far, jnp.array([0.0, 0.0, push.RAISE]), 0.0)
    goal = goal + push.APPROACH_NOISE * cfg.object_goal_noise * e.noise * jnp.array([1, 1, 0])
    return jnp.clip(goal, env.box_low, env.box_high)


def _toward_task_goal(env, cfg: SearchConfig, e: Edges) -> jax.Array:
    """Push: from the object towards the task's goal along the table, as far as a push trains
    for (uniform in PUSH_RANGE, through the waypoint coin) or to the goal if nearer, with
    `transfer_goal_noise` in x and y. Short pushes are likelier to succeed, and a push leaves
    the grip behind the block for the next one."""
    obj = e.obs[:, None, env.layout["object"]]
    flat = jnp.array([1.0, 1.0, 0.0])
    way = (e.task_goal[:, None] - obj) * flat
    distance = jnp.linalg.norm(way, axis=-1, keepdims=True)
    low, high = push.PUSH_RANGE
    length = jnp.minimum(distance, low + (high - low) * e.way)
    step = way * length / jnp.maximum(distance, 1e-6)
    return obj + step + cfg.transfer_goal_noise * e.noise * flat


_FETCH_PUSH = (
    Skill(
        "fetch_approach",
        envs.ENVS["fetch_approach"],
        _behind_object,
        moves=True,
        epochs="transit_epochs",
    ),
    Skill("fetch_push_block", envs.ENVS["fetch_push_block"], _toward_task_goal, moves=True),
)
"""The push library's skills on Fetch (`envs/fetch_push_skills.py`): approach (transit's
env, its goals behind the block) and push, for FetchPush, whose fingers are blocked."""
SKILLS: dict[str, Skill] = {skill.name: skill for skill in (*_BUILT_IN, *_FETCH, *_FETCH_PUSH)}
"""Skill name -> its definition, in the order `build_library` builds them."""
LIBRARIES: dict[str, tuple[str, ...]] = dict(
    zip(
        THESIS_LIBRARIES,
        (("transit", "grasp", "transfer"), ("grasp", "transfer"), ("transit", "transfer")),
        strict=True,
    )
)
LIBRARIES["SL1_fetch"] = tuple(skill.name for skill in _FETCH)
LIBRARIES["SL_fetch_push"] = tuple(skill.name for skill in _FETCH_PUSH)
"""Library name -> its skills: the thesis's (Fig. 6.4; SL1 the full one), SL1's skills on
Fetch (SL1_fetch), the push library of Fetch (SL_fetch_push, for FetchPush) and yours
(`register_library`)."""


UNRECORDED_ROBOT = "baxter"
"""The robot of a library whose manifest records none: built before robots were recorded,
when Baxter was the only robot with skills (`library_robot`)."""
DEFAULT_DIR = Path("experiments") / "skill_library"
"""The default library: Baxter's (the thesis's robot)."""


def default_dir(robot: str, library: str | None = None) -> Path:
    """Where `build_library --robot ROBOT [--library LIBRARY]` writes by default: DEFAULT_DIR
    for Baxter, experiments/skill_library_ROBOT for any other robot, and
    experiments/skill_library_LIBRARY for a library other than the robot's first (SL1,
    SL1_fetch), e.g. experiments/skill_library_SL_fetch_push."""
    if library is not None and library != libraries_of(robot)[0]:
        return DEFAULT_DIR.with_name(f"{DEFAULT_DIR.name}_{library}")
    return (
        DEFAULT_DIR
        if robot == UNRECORDED_ROBOT
        else DEFAULT_DIR.with_name(f"{DEFAULT_DIR.name}_{robot}")
    )


def get(name: str) -> Skill:
    """The skill `name`; ValueError naming the registered ones."""
    if name not in SKILLS:
        raise ValueError(
            f"unknown skill {name!r}; valid: {', '.join(SKILLS)} (a skill of your own: pass "
            "the module that registers it with --import MODULE)"
        )
    return SKILLS[name]


def library_robot_name(name: str) -> str:
    """The robot whose skills library `name` holds (a library holds one robot's skills,
    `register_library`); ValueError naming the valid libraries."""
    return get(library_skills(name)[0]).env.robot_name


def libraries_of(robot: str) -> tuple[str, ...]:
    """The registered libraries of robot `robot`'s skills, in registration order."""
    return tuple(n for n in LIBRARIES if library_robot_name(n) == robot)


def skills_of(robot: str) -> tuple[str, ...]:
    """The registered skills of robot `robot`, in registration order (may be empty)."""
    envs.check_robot(robot)
    return tuple(n for n, s in SKILLS.items() if s.env.robot_name == robot)


def robots_with_skills() -> tuple[str, ...]:
    """The robots a skill library can be built for: those with a registered skill."""
    return tuple(dict.fromkeys(s.env.robot_name for s in SKILLS.values()))


def library_skills(name: str) -> tuple[str, ...]:
    """The skills of library `name`; ValueError naming the valid libraries and the options
    that take one."""
    if name not in LIBRARIES:
        raise ValueError(
            f"unknown library {name!r} (--search.library / --pas.library); valid: "
            f"{', '.join(LIBRARIES)} (one of your own: `register_library` in a module passed "
            "with --import MODULE)"
        )
    return LIBRARIES[name]


def register_skill(skill: Skill) -> None:
    """Add `skill` to the registry, and its env to `envs.registry` under the skill's name.
    ValueError, naming the field, for a name already taken or not an identifier, a `start`
    not in STARTS, an env of no registered robot or without what the library reads, or a
    proposer that is not callable."""
    name = skill.name
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"skill name {name!r}: letters, digits and _ (a Python identifier)")
    if name in SKILLS or name in envs.ENVS:
        raise ValueError(
            f"skill {name!r}: the name is registered already; choose another (or is its "
            "module imported twice, e.g. by --import and MJX_SKILLS_IMPORT or an entry point?)"
        )
    if not isinstance(skill.env, type):
        raise ValueError(f"skill {name!r}: env must be a class (its env's), got {skill.env!r}")
    if skill.start not in STARTS:
        raise ValueError(f"skill {name!r}: start {skill.start!r}; valid: {', '.join(STARTS)}")
    if not callable(skill.propose):
        raise ValueError(f"skill {name!r}: propose must be callable (env, cfg, edges) -> goals")
    needs = ("param_dim", "goal_from_param", "terminated", "state_dims", "memory_dims")
    missing = [a for a in needs if not hasattr(skill.env, a)]
    if missing:
        raise ValueError(f"skill {name!r}: its env {skill.env!r} lacks {', '.join(missing)}")
    if not 1 <= skill.env.param_dim <= 3:
        raise ValueError(f"skill {name!r}: param_dim {skill.env.param_dim}; valid: 1 to 3")
    epochs = skill.epochs
    if isinstance(epochs, bool) or not (
        (isinstance(epochs, int) and epochs >= 1)
        or (
            isinstance(epochs, str)
            and epochs in {f.name for f in dataclasses.fields(LibraryConfig)}
        )
    ):
        raise ValueError(
            f"skill {name!r}: epochs {epochs!r}; valid: a whole number >= 1, or a LibraryConfig "
            "field that holds one"
        )
    cm = skill.thesis_cm
    if cm is not None and not (
        isinstance(cm, tuple) and len(cm) == 2 and all(isinstance(x, int | float) for x in cm)
    ):
        raise ValueError(f"skill {name!r}: thesis_cm {cm!r}; valid: None or (memory, model) in cm")
    envs.register_task(name, skill.env)
    SKILLS[name] = skill


def register_library(name: str, skills: tuple[str, ...]) -> None:
    """Name a set of registered skills a library (`--search.library NAME`). ValueError for a
    name already taken, an unknown skill, a repeated one or an empty set."""
    if not isinstance(name, str) or not name.isidentifier() or name in LIBRARIES:
        raise ValueError(f"library {name!r}: taken or not an identifier; taken: {list(LIBRARIES)}")
    skills = tuple(skills)
    robots = {get(skill).env.robot_name for skill in skills}
    if not skills or len(set(skills)) != len(skills):
        raise ValueError(f"library {name!r}: {skills} must name each skill once, at least one")
    if len(robots) > 1:
        raise ValueError(f"library {name!r}: its skills are of several robots ({sorted(robots)})")
    LIBRARIES[name] = skills


def epochs_of(skill: Skill, config: LibraryConfig) -> int:
    """The DDPG+HER epochs `build_library` trains `skill` for (`Skill.epochs`)."""
    return getattr(config, skill.epochs) if isinstance(skill.epochs, str) else skill.epochs


def fingerprint(library: str) -> dict[str, dict[str, str]] | None:
    """What a stored result made with library `library` depends on beyond its config, for a
    library of the user's (None for the thesis's, whose skills are the package's code): each
    skill's settings and a digest of its proposer's and its env's source, so a changed skill
    is never taken for the one a stored cell ran with."""
    if library in THESIS_LIBRARIES:
        return None
    out = {}
    for name in library_skills(library):
        skill = get(name)
        fields = {f.name: repr(getattr(skill, f.name)) for f in dataclasses.fields(skill)}
        fields.update(propose=_source_digest(skill.propose), env=env_digest(name))
        out[name] = fields
    return out


def env_digest(name: str) -> str:
    """A digest of skill `name`'s env's source (as `fingerprint`'s): what its trained policy
    depends on beyond its training config, so a build resumes only a run of the same env."""
    return _source_digest(get(name).env)


def _source_digest(obj) -> str:
    """sha256 of `obj`'s source and, for a class, of its base classes of the user's own code
    (not this package's, whose code no stored result records, nor an installed package's or
    the standard library's), so that an edited base of a user's skill env is a different
    definition; a source that cannot be read counts as its qualified name."""
    bases = [c for c in getattr(obj, "__mro__", (obj,))[1:] if _users_code(c)]
    return hashlib.sha256("\n".join(map(_source, (obj, *bases))).encode()).hexdigest()[:16]


def _source(obj) -> str:
    try:
        return inspect.getsource(obj)
    except (OSError, TypeError):
        return getattr(obj, "__qualname__", repr(obj))


def _users_code(cls: type) -> bool:
    """Whether class `cls` is defined in the user's code: not in this package, nor in a file
    under the interpreter's prefixes (the standard library, installed packages)."""
    if cls.__module__.split(".")[0] in ("mjx_skills", "builtins"):
        return False
    try:
        where = Path(inspect.getfile(cls)).resolve()
    except (OSError, TypeError):
        return False
    prefixes = {Path(p).resolve() for p in (sys.prefix, sys.base_prefix, sys.exec_prefix)}
    return not any(where.is_relative_to(p) for p in prefixes)
