"""The skill library L = {(pi, Q, p, T_coarse, memory)} as one pytree (thesis ch. 3).

Every skill's parameters are stacked along a leading skill axis, so a batch of envs can
each run a different skill in one call: the functions below take a skill-index array and
gather each env's parameters by index (never `lax.switch`, which under vmap runs every
branch). All skills share the observation (25) and goal (3) layout; their goal parameters
(transit 3, grasp 1, transfer 3) are padded to 3.

Saved as an orbax directory plus `manifest.json` (written last: a directory without it is
a half-written library and is refused).
"""

from __future__ import annotations

import dataclasses
import logging
import shutil
import time
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import orbax.checkpoint as ocp
from flax import struct

from mjx_skills.agents import ddpg
from mjx_skills.config import DDPGConfig, LibraryConfig
from mjx_skills.core import paths
from mjx_skills.core.config_io import from_dict
from mjx_skills.core.files import read_json, tree_sha256, write_json_atomic
from mjx_skills.core.grouped import apply_per_row, select
from mjx_skills.core.nets import CoarseDynamics, SuccessClassifier
from mjx_skills.core.paths import check_writable_path, in_checkout
from mjx_skills.core.types import ObsLayout, SkillEnv
from mjx_skills.envs.registry import make
from mjx_skills.skills.provenance import (
    check_definition,
    check_digest,
    definition_sha256,
    provenance,
    stale_reasons,
)
from mjx_skills.skills.provenance import scene_files as scene_files  # re-exported
from mjx_skills.skills.provenance import scenes_digest as scenes_digest  # re-exported
from mjx_skills.skills.registry import DEFAULT_DIR as DEFAULT_DIR  # re-exported
from mjx_skills.skills.registry import LIBRARIES as LIBRARIES  # re-exported
from mjx_skills.skills.registry import UNRECORDED_ROBOT as UNRECORDED_ROBOT  # re-exported
from mjx_skills.skills.registry import default_dir as default_dir  # re-exported
from mjx_skills.skills.registry import get as get_skill
from mjx_skills.skills.registry import library_skills as library_skills  # re-exported

FORMAT = 1
"""Version of the on-disk layout; a library of another format is refused."""
log = logging.getLogger(__name__)


@struct.dataclass
class Norm:
    """Per-skill statistics (K, d) that normalise a model's inputs or outputs."""

    mean: jax.Array
    std: jax.Array


@struct.dataclass
class SkillLibrary:
    policy: ddpg.DDPGState
    """Each skill's DDPG actor and critic with their normalisers, stacked (K, ...)."""
    dynamics: Any
    """Coarse dynamics model parameters, stacked (K, ...)."""
    classifier: Any
    """Success classifier parameters, stacked (K, ...)."""
    input_norm: Norm
    """(K, obs_dim + goal_dim) statistics of the models' inputs (start state, goal)."""
    delta_norm: Norm
    """(K, obs_dim) statistics of the terminal-minus-start state the model predicts."""
    state_mask: jax.Array
    """(K, obs_dim) bool: the dimensions a skill changes; the others stay as they were."""
    memory_key_mask: jax.Array
    """(K, obs_dim + goal_dim) bool: the dimensions memory retrieval compares."""
    memory_keys: jax.Array
    """(K, M, obs_dim + goal_dim) stored (start state, goal) of successful runs."""
    memory_next: jax.Array
    """(K, M, obs_dim) their terminal states."""
    memory_valid: jax.Array
    """(K, M) bool: slots that hold a memory."""
    names: tuple[str, ...] = struct.field(pytree_node=False)
    ddpg_config: DDPGConfig = struct.field(pytree_node=False)
    config: LibraryConfig = struct.field(pytree_node=False)

    @property
    def envs(self) -> tuple[SkillEnv, ...]:
        return skill_envs(self.names)

    @property
    def layout(self) -> ObsLayout:
        """The observation layout the skills were trained on (`core.types.ObsLayout`)."""
        return self.envs[0].layout

    # ------------------------------------------------------------------ batched skills
    def index(self, name: str) -> int:
        if name not in self.names:
            raise ValueError(f"unknown skill {name!r}; this library has: {', '.join(self.names)}")
        return self.names.index(name)

    def policy_action(self, skill: jax.Array, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """skill (B,) int, obs (B, obs_dim), goal (B, 3) -> deterministic actions (B, 4)."""
        act = lambda p, o, g: ddpg.act(p, o, g, self.ddpg_config)
        return apply_per_row(act, self.policy, skill, obs, goal)

    def q(self, skill: jax.Array, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """Q^i(s, g, pi^i(s, g)) per row: (B,)."""
        cfg = self.ddpg_config
        value = lambda p, o, g: ddpg.q_value(p, o, g, ddpg.act(p, o, g, cfg), cfg)
        return apply_per_row(value, self.policy, skill, obs, goal)

    def _model(self, net: Any, params: Any, skill: jax.Array, obs: jax.Array, goal: jax.Array):
        """A skill model's output per row from its normalised inputs (start state, goal)."""

        def apply(p, o, g):
            params, norm = p
            x = (jnp.concatenate([o, g], axis=-1) - norm.mean) / norm.std
            d = o.shape[-1]
            return net.apply(params, x[..., :d], x[..., d:])

        return apply_per_row(apply, (params, self.input_norm), skill, obs, goal)

    def success_prob(self, skill: jax.Array, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """Classifier's probability that the skill reaches `goal` from `obs`: (B,)."""
        net = SuccessClassifier(tuple(self.config.classifier_hidden))
        logits = self._model(net, self.classifier, skill, obs, goal)
        # Clipped: a sigmoid of a very negative logit is a subnormal float, and subnormals
        # slow a CPU's arithmetic down by orders of magnitude.
        return jax.nn.sigmoid(jnp.clip(logits, -30.0, 30.0))

    def next_state(self, skill: jax.Array, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """Coarse model's terminal observation (B, obs_dim): a full observation any skill
        accepts; dimensions the skill does not change are copied from `obs`."""
        net = CoarseDynamics(obs.shape[-1], tuple(self.config.model_hidden))
        delta_n = self._model(net, self.dynamics, skill, obs, goal)
        delta = delta_n * self.delta_norm.std[skill] + self.delta_norm.mean[skill]
        base = anchor_point(self.layout, self.config.anchor, obs, goal)
        return consistent(self.layout, jnp.where(self.state_mask[skill], base + delta, obs))

    def at_goal(self, skill: jax.Array, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """The terminal observation (B, obs_dim) of a run that ends exactly at its goal: the
        positions the skill moves (the grip; the cube too for grasp and transfer) at the
        goal, everything else as it was. No network: the search's cheap leaf state."""
        positions = np.zeros(obs.shape[-1], bool)
        positions[self.layout["grip"]] = positions[self.layout["object"]] = True
        moved = self.state_mask[skill] & positions
        at_goal = anchor_point(self.layout, "goal", obs, goal)
        return consistent(self.layout, jnp.where(moved, at_goal, obs))

    def recall(self, skill: jax.Array, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """Memory-based terminal observation (B, obs_dim): the terminal state of the nearest
        stored (start, goal) over the skill's own dimensions; other dimensions copied."""
        query = jnp.concatenate([obs, goal], axis=-1)

        def nearest(keys, valid, mask):
            # |q - k|^2 = |q|^2 - 2 q.k + |k|^2: one matmul, no (B, M, D) difference tensor.
            q, k = query * mask, keys * mask
            d = jnp.sum(q * q, -1)[:, None] - 2.0 * q @ k.T + jnp.sum(k * k, -1)[None]
            return jnp.argmin(jnp.where(valid[None], d, jnp.inf), axis=1)

        idx = select(
            jax.vmap(nearest)(self.memory_keys, self.memory_valid, self.memory_key_mask), skill
        )
        found = self.memory_next[skill, idx]
        if self.config.anchor == "goal":  # carry the neighbour's offset from its own goal over
            key, d = self.memory_keys[skill, idx], obs.shape[-1]
            found = (
                found
                - anchor_point(self.layout, "goal", key[:, :d], key[:, d:])
                + anchor_point(self.layout, "goal", obs, goal)
            )
        return consistent(self.layout, jnp.where(self.state_mask[skill], found, obs))

    def goal_from_param(self, skill: jax.Array, param: jax.Array, obs: jax.Array) -> jax.Array:
        """param (B, 3) in [-1, 1] (only the skill's first param_dim used) -> goal (B, 3)."""
        goals = jnp.stack(
            [env.goal_from_param(param[..., : env.param_dim], obs) for env in self.envs]
        )
        return select(goals, skill)

    def terminated(self, skill: jax.Array, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """Whether each env's running skill has stopped: (B,) bool."""
        done = jnp.stack([env.terminated(obs, goal) for env in self.envs])
        return select(done, skill)

    def reached(self, skill: jax.Array, obs: jax.Array, goal: jax.Array) -> jax.Array:
        """Whether each env's skill is at its goal (its own success predicate): (B,) bool."""
        at = jnp.stack([env.is_success(env.achieved_from_obs(obs), goal) for env in self.envs])
        return select(at, skill)

    def allowed(self, obs: jax.Array, grasp_reach: float = 0.0) -> jax.Array:
        """(..., K) bool: the skills that may start here, by their start conditions
        (`registry.Skill.start`: transfer needs the cube in hand, transit and grasp an empty
        gripper); with `grasp_reach` > 0 (m) the skills that start near the object (grasp)
        also need the gripper that near it (`SearchConfig.grasp_reach`)."""
        allowed = allowed_skills(self.names, self.envs[0].grasped(obs))
        gated = [k for k, name in enumerate(self.names) if get_skill(name).near_object]
        if grasp_reach <= 0 or not gated:
            return allowed
        near = jnp.linalg.norm(obs[..., self.layout["rel"]], axis=-1) <= grasp_reach
        for k in gated:
            allowed = allowed.at[..., k].set(allowed[..., k] & near)
        return allowed


def allowed_skills(names: tuple[str, ...], held: jax.Array) -> jax.Array:
    """held (...,) bool -> (..., K) bool: each skill's start condition (`Skill.start`): the
    'held' skills with the cube in hand, the 'empty' ones without, the 'any' ones always."""
    start = [get_skill(name).start for name in names]
    if_held = jnp.array([s in ("held", "any") for s in start])
    if_empty = jnp.array([s in ("empty", "any") for s in start])
    return jnp.where(held[..., None], if_held, if_empty)


def carries_object(names: tuple[str, ...]) -> jax.Array:
    """(K,) bool: the skills that start with the object in hand (`Skill.start` 'held')."""
    return jnp.array([get_skill(name).start == "held" for name in names])


def anchor_point(layout: ObsLayout, anchor: str, obs: jax.Array, goal: jax.Array) -> jax.Array:
    """(..., obs_dim): what a terminal state is measured from (LibraryConfig.anchor): the
    start state, or ('goal') the start state with its grip and cube positions at the goal."""
    if anchor == "start":
        return obs
    return jnp.asarray(obs).at[..., layout["grip"]].set(goal).at[..., layout["object"]].set(goal)


def consistent(layout: ObsLayout, predicted: jax.Array) -> jax.Array:
    """Recompute the derived part of a predicted observation (object minus grip)."""
    rel = predicted[..., layout["object"]] - predicted[..., layout["grip"]]
    return predicted.at[..., layout["rel"]].set(rel)


def skill_envs(names: tuple[str, ...]) -> tuple[SkillEnv, ...]:
    return tuple(_skill_env(n) for n in names)


_ENV_CACHE: dict[str, SkillEnv] = {}


def _skill_env(name: str) -> SkillEnv:
    get_skill(name)  # ValueError naming the registered skills
    if name not in _ENV_CACHE:
        # Possibly first asked for inside a jitted function: build the env's constants eagerly.
        with jax.ensure_compile_time_eval():
            _ENV_CACHE[name] = make(name)
    return _ENV_CACHE[name]


def subset(lib: SkillLibrary, name: str) -> SkillLibrary:
    """The reduced library `name` (SL1, SL2, SL3) of a full library."""
    idx = np.array([lib.index(s) for s in library_skills(name)])
    arrays = jax.tree.map(lambda x: x[idx], lib)
    return arrays.replace(names=tuple(lib.names[i] for i in idx))


# ---------------------------------------------------------------------- artifact on disk
def save(
    lib: SkillLibrary,
    directory: Path,
    manifest: dict[str, Any],
    made_by: dict[str, str] | None = None,
) -> Path:
    """Write the library to `directory` (which must not exist): arrays through orbax into a
    temporary sibling, then manifest.json (with the arrays' `digest`, checked by `load`),
    then one rename, so a reader never sees half. `made_by`: the `provenance()` of the code
    that built it, taken when the build started (default: now)."""
    directory = check_writable_path(directory, "the library directory")
    if directory.exists():
        raise FileExistsError(f"{directory} exists; a library is never overwritten")
    tmp = directory.with_name(f".{directory.name}.partial-{int(time.time())}")
    with ocp.StandardCheckpointer() as ckpt:
        ckpt.save(tmp / "arrays", lib)
    full = {
        **manifest,
        "format": FORMAT,
        **(made_by or provenance()),
        "skills": list(lib.names),
        "ddpg": dataclasses.asdict(lib.ddpg_config),
        "library": dataclasses.asdict(lib.config),
        "complete": True,
    }
    full["robot"] = lib.envs[0].robot_name
    full["digest"] = tree_sha256(lib)
    full["definition"] = definition_sha256(full)
    write_json_atomic(tmp / "manifest.json", full, indent=2)
    tmp.rename(directory)
    return directory


def library_robot(manifest: dict[str, Any]) -> str:
    """The robot a library was built for: its manifest's `robot` ('baxter' where it records
    none, `UNRECORDED_ROBOT`)."""
    return manifest.get("robot", UNRECORDED_ROBOT)


def read_manifest(directory: Path) -> dict[str, Any]:
    directory = in_checkout(directory)
    path = directory / "manifest.json"
    if not directory.exists():
        where = (
            ""
            if directory.is_absolute()
            else f" (looked up in the working directory, then "
            f"{', '.join(map(str, paths.roots()))}; set ${paths.HOME} to a checkout's root to "
            "use its committed libraries)"
        )
        build = "`make skills` or " if paths.is_checkout() else ""
        raise FileNotFoundError(
            f"no skill library at {directory}{where}; build it with {build}`python -m "
            f"mjx_skills.build_library --out {directory}` (hours on a CPU)"
        )
    if not path.exists():
        raise ValueError(f"{directory} is a half-written skill library (no manifest.json)")
    manifest = read_json(path)
    if not manifest.get("complete") or manifest.get("format") != FORMAT:
        raise ValueError(
            f"{directory} holds a library of format {manifest.get('format')} (version "
            f"{manifest.get('version')}); this code reads format {FORMAT}: rebuild it"
        )
    reasons = stale_reasons(manifest)
    if reasons:
        log.warning(
            "skill library %s may be stale: %s; rebuild it with `python -m "
            "mjx_skills.build_library --out DIR` (and the same options, see its manifest)",
            directory,
            "; ".join(reasons),
        )
    return manifest


def load(directory: Path) -> tuple[SkillLibrary, dict[str, Any]]:
    """-> (library, manifest). Refuses a missing, half-written or incompatible library.
    A relative `directory` missing from the working directory is read from the checkout
    (`paths.in_checkout`)."""
    directory = in_checkout(directory)
    manifest = read_manifest(directory)
    check_writable_path(directory, "the library directory")  # orbax would misread it
    check_definition(manifest, directory)  # before its fields shape what is restored
    config = from_dict(LibraryConfig, manifest["library"])
    ddpg_config = from_dict(DDPGConfig, manifest["ddpg"])
    like = empty_like(tuple(manifest["skills"]), ddpg_config, config, manifest["memory_size"])
    abstract = jax.tree.map(ocp.utils.to_shape_dtype_struct, like)
    try:
        with ocp.StandardCheckpointer() as ckpt:
            lib = ckpt.restore(Path(directory).resolve() / "arrays", abstract)
    except Exception as err:  # noqa: BLE001 - any unreadable array file means a bad library
        raise ValueError(f"{directory}: the library's arrays do not load ({err})") from None
    check_digest(lib, manifest, directory)
    return lib, manifest


def empty_like(
    names: tuple[str, ...], ddpg_config: DDPGConfig, config: LibraryConfig, memory_size: int
) -> SkillLibrary:
    """A library of the right shapes and zeros (the template that loading fills in)."""
    from mjx_skills.skills.fit import init_models

    K, obs_dim, goal_dim = len(names), skill_envs(names)[0].layout.size, 3
    keys = jax.random.split(jax.random.PRNGKey(0), K)
    policy = jax.vmap(lambda k: ddpg.init(k, obs_dim, goal_dim, 4, ddpg_config))(keys)
    dynamics, classifier = init_models(keys, config, obs_dim, goal_dim)
    d_in = obs_dim + goal_dim
    unit = lambda d: Norm(mean=jnp.zeros((K, d)), std=jnp.ones((K, d)))
    return SkillLibrary(
        policy=policy,
        dynamics=dynamics,
        classifier=classifier,
        input_norm=unit(d_in),
        delta_norm=unit(obs_dim),
        state_mask=jnp.zeros((K, obs_dim), bool),
        memory_key_mask=jnp.zeros((K, d_in), bool),
        memory_keys=jnp.zeros((K, memory_size, d_in)),
        memory_next=jnp.zeros((K, memory_size, obs_dim)),
        memory_valid=jnp.zeros((K, memory_size), bool),
        names=names,
        ddpg_config=ddpg_config,
        config=config,
    )


def remove_partials(directory: Path) -> None:
    """Delete half-written siblings an interrupted save left behind."""
    directory = Path(directory).resolve()
    for stale in directory.parent.glob(f".{directory.name}.partial-*"):
        shutil.rmtree(stale, ignore_errors=True)
