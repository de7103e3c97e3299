"""One jitted XLA program per epoch, the same for every method.

One epoch = `cycles` x (collect `envs` episodes with the method's exploring behaviour ->
store -> the method's update), then `eval_episodes` episodes with its deterministic
behaviour. Everything inside `train_epoch` runs on device, including the counters of env
steps, episodes and skill calls that every method's curves share as x-axes. Seeds are a
vmap axis over the whole carry, so N seeds are one program.

The command line is in `mjx_skills.train`; `python -m mjx_skills.train ...` runs it too.
"""

from __future__ import annotations

import dataclasses
from collections import OrderedDict
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from mjx_skills import methods
from mjx_skills.config import EnvConfig, TrainConfig
from mjx_skills.core import replay, rollout
from mjx_skills.core.learner import Learner, Progress, mean_records
from mjx_skills.core.types import GoalEnv

COUNT_BASE = 2**30
"""A counter is (2,) int32 [high, low], worth high * 2**30 + low: up to 2**61, where one int32
wraps negative past 2**31 env steps (epoch 210 at 4096 envs x 50 cycles of 50 steps)."""
COUNTERS = ("env_steps", "episodes", "skill_calls")


def count_add(count: jax.Array, n: jax.Array) -> jax.Array:
    """`count` (2,) int32 plus `n` (a scalar in [0, 2**30): one cycle's steps), carried."""
    low = count[1] + jnp.asarray(n, jnp.int32)  # < 2**31: no wrap
    return jnp.stack([count[0] + low // COUNT_BASE, low % COUNT_BASE])


def count_values(count: Any) -> np.ndarray:
    """Counters (..., 2) [high, low] -> their values (...,) as int64 on the host."""
    count = np.asarray(count, np.int64)
    return count[..., 0] * COUNT_BASE + count[..., 1]


def count_below(count: jax.Array, n: int) -> jax.Array:
    """() bool on device: the (2,) counter's value is below n (0 <= n <= 2**30)."""
    return (count[0] == 0) & (count[1] < n)


def host_metrics(metrics: dict[str, Any]) -> dict[str, np.ndarray]:
    """An epoch's metrics on the host: arrays, the counters as int64 values."""
    out = {k: np.asarray(v) for k, v in metrics.items()}
    return out | {k: count_values(out[k]) for k in COUNTERS if k in out}


@struct.dataclass
class Counters:
    """Training interaction so far, counted on device (evaluation is not counted); each a
    (2,) int32 counter (`count_add`, `count_values`)."""

    env_steps: jax.Array
    episodes: jax.Array
    skill_calls: jax.Array
    """Skills started by the behaviour (0 for methods without skills)."""

    @classmethod
    def zeros(cls) -> Counters:
        zero = jnp.zeros((2,), jnp.int32)
        return cls(env_steps=zero, episodes=zero, skill_calls=zero)


@struct.dataclass
class TrainCarry:
    agent: Any
    replay: replay.ReplayState
    key: jax.Array
    epoch: jax.Array
    counters: Counters
    success: jax.Array
    """() float32: eval success at the end of the previous epoch (`Progress.success`)."""


def make_evaluate(learner: Learner, env: GoalEnv, train: TrainConfig):
    """-> evaluate(agent, aux, key) -> {eval_success, eval_distance}: `eval_episodes`
    episodes with the deterministic behaviour, success read at the last step (as the thesis).
    In a scene of several cubes also `eval_cubes`: the share of cubes at their goals at the
    last step (1/2 where one of two cubes got there), which says which stage fails."""

    def evaluate(agent: Any, aux: Any, key: jax.Array) -> dict[str, jax.Array]:
        behaviour = learner.evaluate(agent, aux)
        _, final, _ = rollout.run_episodes(env, behaviour, key, train.eval_episodes)
        out = {
            "eval_success": final.metrics["success"].mean(),
            "eval_distance": final.metrics["distance"].mean(),
        }
        if env.n_objects > 1:  # a MultiObjectEnv
            out["eval_cubes"] = env.cube_success(final.achieved_goal, final.desired_goal).mean()
        return out

    return evaluate


def make_train_cycles(learner: Learner, env: GoalEnv, train: TrainConfig):
    """-> train_cycles(carry, aux) -> (carry, metrics): an epoch's `cycles` collect-store-update
    cycles without evaluation, pure and jittable."""

    summarize = learner.summarize or mean_records
    if train.envs * env.episode_length >= COUNT_BASE:
        raise ValueError(f"envs: {train.envs} x {env.episode_length} steps per cycle is over 2**30")

    def cycle(aux, carry: TrainCarry, _):
        key, k_roll, k_upd = jax.random.split(carry.key, 3)
        behaviour = learner.explore(carry.agent, aux, Progress(carry.epoch, carry.success))
        if train.random_steps:  # static: without it, the behaviour's keys are as they were
            start = count_below(carry.counters.env_steps, train.random_steps)
            behaviour = rollout.random_actions(behaviour, start)
        episodes, final, records = rollout.run_episodes(env, behaviour, k_roll, train.envs)
        fresh = learner.store(episodes, records)
        buffer = replay.add(carry.replay, fresh)
        agent, losses = learner.update(carry.agent, buffer, fresh, k_upd)
        skill_calls = records.pop("skill_calls", jnp.zeros((), jnp.int32))
        c = carry.counters
        counters = c.replace(
            env_steps=count_add(c.env_steps, train.envs * env.episode_length),
            episodes=count_add(c.episodes, train.envs),
            skill_calls=count_add(c.skill_calls, jnp.sum(skill_calls)),
        )
        carry = carry.replace(agent=agent, replay=buffer, key=key, counters=counters)
        stats = {
            "train_success": final.metrics["success"].mean(),
            "physics_resets": final.metrics["physics_resets"].sum(),
            **jax.tree.map(jnp.mean, losses),
            **{f"explore_{k}": v for k, v in summarize(records).items()},
        }
        return carry, stats

    def train_cycles(carry: TrainCarry, aux: Any = None):
        carry, stats = jax.lax.scan(lambda c, x: cycle(aux, c, x), carry, None, length=train.cycles)
        return carry, jax.tree.map(jnp.mean, stats)

    return train_cycles


def make_train_epoch(
    learner: Learner, env: GoalEnv, train: TrainConfig, eval_env: GoalEnv | None = None
):
    """-> train_epoch(carry, aux) -> (carry, metrics): the cycles, then evaluation (on
    `eval_env`, default `env`: the true start distribution where training uses another);
    pure and jittable. Metrics hold the counters after the epoch ((2,) int32 each:
    `host_metrics` makes them values)."""
    train_cycles = make_train_cycles(learner, env, train)
    evaluate = make_evaluate(learner, env if eval_env is None else eval_env, train)

    def train_epoch(carry: TrainCarry, aux: Any = None):
        carry, metrics = train_cycles(carry, aux)
        key, k_eval = jax.random.split(carry.key)
        c = carry.counters
        evaluated = evaluate(carry.agent, aux, k_eval)
        metrics = {
            **metrics,
            **evaluated,
            "env_steps": c.env_steps,
            "episodes": c.episodes,
            "skill_calls": c.skill_calls,
        }
        return carry.replace(
            key=key, epoch=carry.epoch + 1, success=evaluated["eval_success"]
        ), metrics

    return train_epoch


def init_carry(
    learner: Learner, env: GoalEnv, train: TrainConfig, key: jax.Array, aux: Any = None
) -> TrainCarry:
    """Fresh agent and an empty replay whose layout is what `store` makes of an episode."""
    k_agent, k_run = jax.random.split(key)
    agent = learner.init(k_agent)

    def stored_one(k):
        behaviour = learner.explore(agent, aux, Progress(jnp.zeros((), jnp.int32), jnp.zeros(())))
        episodes, _, records = rollout.run_episodes(env, behaviour, k, 1)
        return learner.store(episodes, records)

    layout = jax.eval_shape(stored_one, jax.random.PRNGKey(0))
    example = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape[1:], x.dtype), layout)
    buffer = replay.init(train.replay_capacity, example, T=env.episode_length)
    return TrainCarry(
        agent=agent,
        replay=buffer,
        key=k_run,
        epoch=jnp.zeros((), jnp.int32),
        counters=Counters.zeros(),
        success=jnp.zeros(()),
    )


def seed_keys(train: TrainConfig) -> jax.Array:
    return jnp.stack([jax.random.PRNGKey(train.seed + i) for i in range(train.seeds)])


PROGRAMS_KEPT = 4
"""Built programs kept per process (least recently used dropped first)."""
_programs: OrderedDict = OrderedDict()


def build(
    method: str,
    train: TrainConfig,
    env_cfg: EnvConfig,
    options: dict[str, Any] | None = None,
    aux: Any = None,
) -> tuple[Any, Learner, Any, TrainCarry]:
    """-> (env, learner, jitted train_epoch(carry, aux) vmapped over seeds, initial carry with
    a leading seed axis). `options`: the method's option groups (defaults where missing).

    Compiled once per process: runs that differ only in what the program does not depend
    on (epochs, first seed, output directory, progress, checkpoints) get the same jitted
    epoch, so a sweep's second such cell does not compile again. (JAX's persistent cache
    cannot help here: it does not store programs with host callbacks, and the native
    physics is one.)"""
    spec = methods.get(method)
    options = {**spec.options, **(options or {})}
    same = dataclasses.replace(train, epochs=1, seed=0, out="", progress=False, checkpoint_every=1)
    key = (method, same, env_cfg, tuple(sorted(options.items())))
    if key not in _programs:
        _programs[key] = _build_program(spec, train, env_cfg, options)
        while len(_programs) > PROGRAMS_KEPT:
            _programs.popitem(last=False)
    _programs.move_to_end(key)
    env, learner, epoch_fn, init = _programs[key]
    return env, learner, epoch_fn, committed(init(seed_keys(train), aux))


def _build_program(spec: methods.Method, train: TrainConfig, env_cfg: EnvConfig, options: dict):
    from mjx_skills.envs import make

    env = make(train.task, env_cfg)
    # Training-only start distributions (held, goal starts) never reach the evaluation episodes.
    eval_cfg = env_cfg.for_evaluation()
    eval_env = env if eval_cfg == env_cfg else make(train.task, eval_cfg)
    learner = spec.make_learner(env, train, **options)
    epoch = over_seeds(make_train_epoch(learner, env, train, eval_env), in_axes=(0, None))
    options = compiler_options(env)
    epoch_fn = jax.jit(epoch, donate_argnums=0, compiler_options=options)
    init = jax.jit(
        jax.vmap(lambda k, aux: init_carry(learner, env, train, k, aux), (0, None)),
        compiler_options=options,
    )
    return env, learner, epoch_fn, init


def compiler_options(env) -> dict[str, str] | None:
    """The XLA options the env's physics backend asks its programs to be compiled with
    (`PhysicsBackend.compiler_options`; None for XLA's defaults)."""
    return getattr(getattr(env, "backend", None), "compiler_options", None)


def over_seeds(fn, in_axes=0):
    """`fn` vmapped over a leading seed axis named `rollout.SEED_AXIS`, so that a behaviour's
    costly work can be pooled over seeds (`rollout.gather_seeds`, `search.search_where`)."""
    return jax.vmap(fn, in_axes=in_axes, axis_name=rollout.SEED_AXIS)


def committed(carry: Any) -> Any:
    """The carry placed on the default device explicitly. The epoch's outputs are committed
    whenever one input is (a loaded skill library is), and jit keys its cache on that too:
    an uncommitted first carry made every library method compile its epoch twice."""
    return jax.device_put(carry, jax.devices()[0])
