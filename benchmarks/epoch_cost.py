"""Seconds per training epoch of every method on one task, at several seed counts, with a
breakdown of where the time goes, against DDPG+HER's epoch measured in the same run.

    python benchmarks/epoch_cost.py [--task pick_move] [--seeds 1 3 5] [--breakdown-seeds 3]
    python benchmarks/epoch_cost.py --cores 1     # pinned to one core: a cell of `--jobs 2`

Variants: ddpg_her, pas, mpas, DDPG+HER+SL with eps held at 1 (`sl_eps1`: every decision
searches) and at 0.001 (`sl_eps0`: the late epochs, almost no search), and the scripted
oracle explorer at eps 1 (`oracle`); `sl_eps1_whole` searches every env's tree whenever one
env searches (`--search.search-chunk 1`), against the default chunks. The default budget (4 envs x 4 cycles + 20 evaluation
episodes per epoch). Each epoch program is compiled first (`compile_s`, with the persistent
cache off so that it is a real compile) and run once to warm up; then the variants' epochs
are timed round-robin, `--epochs` of each: `epoch_s` is their median (this machine is a VM
whose speed drifts by 10-40 % within minutes; round-robin timing keeps the ratios fair).

Breakdown (at `--breakdown-seeds`), from separately compiled pieces of the same epoch, all
vmapped over seeds as the trainer does:
- `physics_s`: the epoch's episodes (training and evaluation) stepped with zero actions;
- `behaviour_s`: the training rollouts with the method's behaviour minus their physics (the
  search, the policies, the stall memory);
- `updates_s`: the cycles (rollouts, replay insertion, updates) minus the rollouts;
- `eval_s`: the evaluation episodes;
- `host_s`: the epoch minus cycles and evaluation (dispatch, the epoch's own glue; each
  piece is timed on its own, so this is zero within noise and may come out negative).

One JSON row per (variant, seeds); the last line is the summary the issue asks for:
{"seeds": 3, "ddpg_her_s", "sl_eps1_s", "sl_eps0_s", "ratio_sl_eps0", "ratio_sl_eps1", ...}.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import sys
import time

os.environ.setdefault("MJX_SKILLS_CACHE_DIR", "off")  # compile_s is a real compile
if "--cores" in sys.argv:  # pinned before JAX starts its threads, as a sweep worker is
    os.sched_setaffinity(0, range(int(sys.argv[sys.argv.index("--cores") + 1])))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from mjx_skills import methods
from mjx_skills.config import EnvConfig, SearchConfig, TrainConfig  # noqa: E402
from mjx_skills.core import rollout
from mjx_skills.core.learner import Progress
from mjx_skills.core.workers import usable_cores  # noqa: E402
from mjx_skills.training.epoch import build, make_evaluate, make_train_cycles, over_seeds  # noqa: E402

VARIANTS = ("ddpg_her", "pas", "mpas", "sl_eps1", "sl_eps0", "sl_eps1_whole", "oracle")


def options_of(variant: str) -> tuple[str, dict]:
    """-> (method, its option groups) of a variant."""
    if not variant.startswith(("sl_", "oracle")):
        return variant, dict(methods.get(variant).options)
    eps = 0.001 if variant == "sl_eps0" else 1.0
    search = dataclasses.replace(
        SearchConfig(),
        eps_start=eps,
        eps_end=eps,
        explorer="scripted" if variant == "oracle" else "search",
    )
    if variant == "sl_eps1_whole":  # every env's tree whenever one env searches
        search = dataclasses.replace(search, search_chunk=1.0)
    return "ddpg_her_sl", {**methods.get("ddpg_her_sl").options, "search": search}


def timed(fn, *args, repeats: int) -> tuple[float, float, object]:
    """-> (compile s, best of `repeats` calls s, last output) of a jitted fn (args not donated)."""
    t0 = time.perf_counter()
    compiled = fn.lower(*args).compile()
    compile_s = time.perf_counter() - t0
    out = jax.block_until_ready(compiled(*args))
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = jax.block_until_ready(compiled(*args))
        best = min(best, time.perf_counter() - t0)
    return compile_s, best, out


@dataclasses.dataclass
class Run:
    """One variant's compiled epoch and its carry, after a warm-up epoch."""

    learner: object
    env: object
    cfg: TrainConfig
    compiled: object
    carry: object
    aux: object
    compile_s: float
    metrics: dict = dataclasses.field(default_factory=dict)
    times: list = dataclasses.field(default_factory=list)

    def epoch(self) -> None:
        t0 = time.perf_counter()
        self.carry, self.metrics = self.compiled(self.carry, self.aux)
        jax.block_until_ready(self.metrics)
        self.times.append(time.perf_counter() - t0)


def prepare(variant: str, task: str, seeds: int) -> Run:
    method, options = options_of(variant)
    spec = methods.get(method)
    cfg = TrainConfig(task=task, seeds=seeds, progress=False)
    aux = spec.load_aux(options)
    env, learner, epoch_fn, carry = build(method, cfg, EnvConfig(), options, aux)
    t0 = time.perf_counter()
    compiled = epoch_fn.lower(carry, aux).compile()
    run = Run(learner, env, cfg, compiled, carry, aux, time.perf_counter() - t0)
    run.epoch()  # warm-up: the first epoch
    run.times.clear()
    return run


def measure(variants: list[str], task: str, seeds: int, epochs: int, breakdown: bool):
    """-> a row per variant. The variants' epochs are timed round-robin (one epoch of each
    in turn), so a drift of the machine's speed reaches every variant alike."""
    runs = {v: prepare(v, task, seeds) for v in variants}
    for _ in range(epochs):
        for run in runs.values():
            run.epoch()
    for variant, run in runs.items():
        epoch_s = statistics.median(run.times)
        share = float(jnp.mean(run.metrics.get("explore_searches", 0.0)))
        row = {
            "variant": variant,
            "task": task,
            "seeds": seeds,
            "epoch_s": round(epoch_s, 3),
            "compile_s": round(run.compile_s, 1),
            "cores": usable_cores(),
            "searches_share": round(share, 4),
        }
        if breakdown:
            row.update(pieces(run.learner, run.env, run.cfg, run.carry, run.aux, epoch_s))
        yield row


def pieces(learner, env, cfg: TrainConfig, carry, aux, epoch_s: float) -> dict:
    """The breakdown: separately compiled parts of the epoch, vmapped over seeds."""
    n_train = cfg.envs

    def explore(c, aux):
        def one(c, k):
            behaviour = learner.explore(c.agent, aux, Progress(c.epoch, c.success))
            return c, rollout.run_episodes(env, behaviour, k, n_train)[1].metrics["success"]

        return jax.lax.scan(one, c, jax.random.split(c.key, cfg.cycles))[1]

    zero = rollout.stateless(lambda k, o, g: jnp.zeros((o.shape[0], env.action_dim)))

    def physics(key):
        keys = jax.random.split(key, cfg.cycles + 1)
        train = jax.lax.map(
            lambda k: rollout.run_episodes(env, zero, k, n_train)[1].reward, keys[1:]
        )
        return train, rollout.run_episodes(env, zero, keys[0], cfg.eval_episodes)[1].reward

    evaluate = make_evaluate(learner, env, cfg)
    cycles = make_train_cycles(learner, env, cfg)
    jit = lambda f, axes: jax.jit(over_seeds(f, in_axes=axes))
    keys = jax.vmap(lambda k: k)(carry.key)
    times = {}
    _, times["physics"], _ = timed(jit(physics, 0), keys, repeats=2)
    _, times["explore"], _ = timed(jit(explore, (0, None)), carry, aux, repeats=2)
    _, times["cycles"], _ = timed(
        jit(lambda c, a: cycles(c, a)[1], (0, None)), carry, aux, repeats=2
    )
    _, times["eval"], _ = timed(jit(evaluate, (0, None, 0)), carry.agent, aux, keys, repeats=2)
    eval_physics = times["physics"] * cfg.eval_episodes / (cfg.eval_episodes + n_train * cfg.cycles)
    train_physics = times["physics"] - eval_physics
    return {
        "physics_s": round(times["physics"], 3),
        "behaviour_s": round(times["explore"] - train_physics, 3),
        "updates_s": round(times["cycles"] - times["explore"], 3),
        "eval_s": round(times["eval"], 3),
        "host_s": round(epoch_s - times["cycles"] - times["eval"], 3),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--task", default="pick_move")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 3, 5])
    parser.add_argument("--breakdown-seeds", type=int, default=3)
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    parser.add_argument("--epochs", type=int, default=3, help="timed epochs after the warm-up")
    parser.add_argument("--cores", type=int, help="run on this many cores only (pinned)")
    args = parser.parse_args()
    rows = {}
    for seeds in args.seeds:
        breakdown = seeds == args.breakdown_seeds
        for row in measure(args.variants, args.task, seeds, args.epochs, breakdown):
            rows[row["variant"], seeds] = row
            print(json.dumps(row), flush=True)
    s = args.breakdown_seeds if ("ddpg_her", args.breakdown_seeds) in rows else args.seeds[0]
    summary = {"task": args.task, "seeds": s, "jax": jax.__version__, "cores": usable_cores()}
    ref = rows.get(("ddpg_her", s))
    for variant in args.variants:
        if (variant, s) in rows:
            summary[f"{variant}_s"] = rows[variant, s]["epoch_s"]
            if ref and variant != "ddpg_her":
                summary[f"ratio_{variant}"] = round(rows[variant, s]["epoch_s"] / ref["epoch_s"], 3)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
