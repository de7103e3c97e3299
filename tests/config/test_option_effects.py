"""Every option changes the program of a method that reads it, on a task where it applies
(several-cube options on a two-cube task), or is declared to act outside it (`OUTSIDE`,
with what it does instead); several-cube options are refused on one cube
(tests/sweeps/test_experiment_files.py and `methods.check_task`).

One epoch of each (method, task) is traced (`jax.make_jaxpr`, nothing compiled or run)
with its defaults and again with one option changed (`changed`); the two programs must
differ: their equations (host callbacks' addresses dropped), captured constants and the
physics model the native backend's callbacks step (its MJB bytes)."""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import re
import typing

import jax
import mujoco
import numpy as np
import pytest

from mjx_skills import methods
from mjx_skills.config import EnvConfig, TrainConfig
from mjx_skills.envs import make
from mjx_skills.skills.library import DEFAULT_DIR
from mjx_skills.training.epoch import init_carry, make_train_epoch, over_seeds

TINY = dict(envs=2, cycles=1, updates_per_cycle=2, eval_episodes=2, replay_capacity=500)
TWO_CUBES = "pick_move_two"
OUTSIDE = {
    "train.task": "chooses the env (each task's program is its own)",
    "train.epochs": "how many times the host calls the program",
    "train.seed": "the keys the program is called with",
    "train.checkpoint_every": "when the host saves",
    "train.out": "where the host writes",
    "train.progress": "the host's progress bar",
    "train.track": "the host's logging",
    "train.wandb_project": "the host's logging",
    "search.library_dir": "which library's arrays the program is given",
    "pas.library_dir": "which library's arrays the program is given",
    "env.physics": "the backend: 'auto' is native on a CPU (tests/envs/test_physics.py)",
    "env.native_threads": "the native backend's host threads",
    "ddpg.weight_init": "the initial parameters, not the epoch (tests/agents/test_network_options.py)",
}
"""Options that act outside the traced epoch -> what they do instead."""
NEEDS = {
    "pas.relabel_prob": {"pas": {"hindsight": True}},
    "env.grasp_settle_substeps": {"env": {"held_start_prob": 0.5}},
    "env.goal_start_prob": {"train": {"task": TWO_CUBES}},
}
"""Options that act only with another option set -> those settings (group -> fields)."""
OTHER = {"search.search_chunk": 1.0}
"""Changes big enough to show at TINY's 2 envs (a quarter and an eighth both make 1)."""


def changed(value, kind):
    """Another valid value of a field of type `kind` (a string annotation)."""
    if isinstance(value, bool):
        return not value
    if kind.startswith("Literal"):
        return next(
            c for c in typing.get_args(eval(kind, {"Literal": typing.Literal})) if c != value
        )
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value / 2 if value else 0.1
    if isinstance(value, tuple):
        return tuple(v / 2 if isinstance(v, float) else v // 2 for v in value)
    if isinstance(value, str) and value.startswith("SL"):
        return "SL2"
    raise AssertionError(f"no other value for {value!r} ({kind})")


def owners() -> dict[str, tuple[str, str, typing.Any]]:
    """'group.field' -> (a method that reads it, the task, its default), every option."""
    out = {}
    for name, spec in methods.METHODS.items():
        groups = {**spec.options, "env": EnvConfig(), "train": TrainConfig()}
        unread = spec.unread_now(spec.options)
        for group, opt in groups.items():
            for f in dataclasses.fields(opt):
                path = f"{group}.{f.name}"
                if path in out or path in unread:
                    continue
                several = f.name in methods.SEVERAL_CUBES.get(group, ())
                out[path] = (name, TWO_CUBES if several else "pick_move", f)
    return out


@functools.cache
def _aux(method: str, options: tuple):
    spec = methods.get(method)
    return spec.load_aux(dict(options))


_PROGRAMS: dict[str, str] = {}


def program(method: str, overrides: dict[str, dict]) -> str:
    """A digest of one traced epoch of `method` with option overrides (group -> fields),
    traced once per (method, overrides): the defaults' program is shared by every option of
    a method that needs no other setting (about half of the traces)."""
    key = repr((method, sorted((g, sorted(f.items())) for g, f in overrides.items() if f)))
    if key not in _PROGRAMS:
        _PROGRAMS[key] = _trace(method, overrides)
    return _PROGRAMS[key]


def _trace(method: str, overrides: dict[str, dict]) -> str:
    spec = methods.get(method)
    given = {g: dataclasses.replace(o, **overrides.get(g, {})) for g, o in spec.options.items()}
    train = TrainConfig(
        **{"task": "pick_move", **TINY, "progress": False, **overrides.get("train", {})}
    )
    env = make(train.task, EnvConfig(**overrides.get("env", {})))
    aux = _aux(method, tuple(sorted(given.items())))
    learner = spec.make_learner(env, train, **given)
    epoch = over_seeds(make_train_epoch(learner, env, train, env), in_axes=(0, None))
    init = jax.vmap(lambda k: init_carry(learner, env, train, k, aux))
    carry = jax.eval_shape(init, jax.random.split(jax.random.PRNGKey(0), train.seeds))
    closed = jax.make_jaxpr(epoch)(carry, aux)
    text = re.sub(r" at 0x[0-9a-f]+", "", str(closed.jaxpr))  # host callbacks' addresses
    digest = hashlib.sha256(text.encode())
    for const in closed.consts:
        digest.update(np.asarray(const).tobytes())
    if isinstance(env.model, mujoco.MjModel):  # what the native backend's callbacks step
        mjb = np.empty(mujoco.mj_sizeModel(env.model), np.uint8)
        mujoco.mj_saveModel(env.model, None, mjb)
        digest.update(mjb.tobytes())
    return digest.hexdigest()


OPTIONS = owners()


@pytest.mark.skipif(not (DEFAULT_DIR / "manifest.json").exists(), reason="no built library")
@pytest.mark.parametrize("path", sorted(set(OPTIONS) - set(OUTSIDE)))
def test_every_option_changes_the_traced_program_where_it_applies(path):
    method, task, field = OPTIONS[path]
    group, name = path.split(".")
    base = {g: dict(v) for g, v in NEEDS.get(path, {}).items()}
    base.setdefault("train", {}).setdefault("task", task)
    default = dataclasses.replace(
        {**methods.get(method).options, "env": EnvConfig(), "train": TrainConfig()}[group],
        **base.get(group, {}),
    )
    other = OTHER.get(path, changed(getattr(default, name), str(field.type)))
    varied = {g: dict(v) for g, v in base.items()}
    varied.setdefault(group, {})[name] = other
    assert program(method, base) != program(method, varied), (
        f"--{group}.{name.replace('_', '-')} {other!r} leaves {method}'s program on "
        f"{base['train']['task']} unchanged"
    )


@pytest.mark.parametrize(
    "path, value",
    [
        ("train.seed", 7),
        ("train.epochs", 3),
        ("train.checkpoint_every", 2),
        ("env.native_threads", 1),
        ("env.physics", "native"),
    ],
)
def test_options_declared_outside_leave_the_program_as_it_is(path, value):
    group, name = path.split(".")
    assert path in OUTSIDE
    assert program("ddpg_her", {}) == program("ddpg_her", {group: {name: value}})
