"""Build the skill library: train each skill, collect its data, fit its models, save.

    python -m mjx_skills.build_library                      # or `make skills`
    python -m mjx_skills.build_library --robot fetch --library SL1_fetch  # make skills ROBOT=fetch
    python -m mjx_skills.build_library --out DIR --samples 100000
    python -m mjx_skills.build_library --table              # Table 5.1 of the library at --out
    python -m mjx_skills.build_library --import my_skills.py --out DIR  # with your skills

--import MODULE (your module registering skills, tasks or robots: a dotted name or a .py
path; repeatable) is read before the other options.

Phases, each with its progress bar and its time in the manifest: (1) DDPG+HER per skill on
its skill env (grasp with held starts in training), its success measured on fresh episodes
of its true start distribution; (2) collection; (3) the vmapped fits; (4) the artifact.
The skills' training runs live in a work directory beside the library, so an interrupted
build resumes them; the library itself is written once, atomically, and never overwritten.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Annotated

import jax
import jax.numpy as jnp
import numpy as np
import tyro
from tqdm.auto import tqdm

from mjx_skills.config import (
    SEED_LIMIT,
    DDPGConfig,
    EnvConfig,
    LibraryConfig,
    TrainConfig,
    build_config,
)
from mjx_skills.core import compile_cache, plugins, rollout
from mjx_skills.core.paths import check_writable_path
from mjx_skills.core.precision import use_float32
from mjx_skills.methods.ddpg_her import make_ddpg_her
from mjx_skills.skills import fit, library, registry, work_runs
from mjx_skills.skills.table import evaluate_models, write_table
from mjx_skills.training.interrupt import INTERRUPTED
from mjx_skills.training.metrics_log import logged_epochs, read_metrics, wall_seconds
from mjx_skills.training.runner import RunArgs, train_and_keep


@dataclasses.dataclass(frozen=True)
class SkillsArgs:
    config: Annotated[LibraryConfig, tyro.conf.OmitArgPrefixes] = LibraryConfig()
    out: str | None = None
    """Directory of the library (must not exist yet, unless with --table; default:
    experiments/skill_library, experiments/skill_library_ROBOT for another --robot)."""
    table: bool = False
    """Only write Table 5.1 (experiments/results/table_5_1.csv) from the library at --out."""
    progress: bool = True
    """Draw progress bars."""
    work: str | None = None
    """Directory of the skills' training runs (default: .OUT.work beside the library).
    Libraries built with the same one share their trained skills, e.g. the thesis preset's
    `--anchor start` library beside the default one."""
    robot: str = "baxter"
    """The robot whose skills are built (its registered skills, `skills.registry`)."""
    skills: tuple[str, ...] = ()
    """The skills to build, in order (default: every registered skill of --robot, yours
    included when --import registers one)."""
    library: str | None = None
    """Build the skills of this registered library of --robot's (e.g. SL1_fetch, or
    SL_fetch_push for FetchPush), instead of --skills."""

    def directory(self) -> Path:
        """--out, or the default library directory (`registry.default_dir`): the robot's, or
        for a --library other than the robot's first, experiments/skill_library_LIBRARY."""
        return Path(self.out) if self.out else registry.default_dir(self.robot, self.library)

    def names(self) -> tuple[str, ...]:
        """The skills this build trains; ValueError naming the valid ones."""
        own = registry.skills_of(self.robot)
        if not own:
            raise ValueError(
                f"--robot {self.robot}: no skill is registered for it; robots with skills: "
                f"{', '.join(registry.robots_with_skills())}"
            )
        if self.library is not None:
            if self.skills:
                raise ValueError("--library and --skills both choose the skills: give one")
            mine = registry.libraries_of(self.robot)
            if self.library not in mine:
                raise ValueError(
                    f"--library {self.library}: not a library of the {self.robot} skills; "
                    f"valid: {', '.join(mine)}"
                )
        names = self.skills or (registry.library_skills(self.library) if self.library else own)
        wrong = [n for n in names if n not in own]
        if wrong or len(set(names)) != len(names):
            raise ValueError(
                f"--skills {' '.join(names)}: each once, from the {self.robot} skills "
                f"{', '.join(own)} (a skill of your own: --import the module that registers it)"
            )
        scenes = {registry.get(n).env.scene for n in names}
        if len(scenes) > 1:  # collection starts each skill from the others' starts
            raise ValueError(
                f"the skills {', '.join(names)} are of several scenes ({', '.join(sorted(scenes))})"
                "; a library's skills share one: build one library at a time, --library "
                f"{' or --library '.join(registry.libraries_of(self.robot))}"
            )
        return names


def train_skill(name: str, config: LibraryConfig, work: Path, progress: bool):
    """DDPG+HER on the skill's env (resuming an interrupted run in `work`) -> (agent, run dir)."""
    skill = registry.get(name)
    held = config.grasp_held_start_prob if skill.held_training_starts else 0.0
    epochs = registry.epochs_of(skill, config)
    previous = work_runs.latest(work, name, epochs)
    longer = previous is not None and work_runs.planned_epochs(previous) < epochs
    args = RunArgs(
        train=TrainConfig(
            task=name,
            epochs=epochs,
            seed=config.seed,
            replay_capacity=200_000,
            out=str(work),
            progress=progress,
        ),
        env=EnvConfig(held_start_prob=held),
        resume=str(previous) if previous else None,
        extend_to=epochs if longer else None,  # a shorter run trains on to `epochs`
    )
    run_dir, carry = train_and_keep(args)
    work_runs.record(run_dir, name)
    if logged_epochs(run_dir) < args.train.epochs:  # Ctrl-C or SIGTERM: it saved and said so
        raise KeyboardInterrupt
    return jax.tree.map(lambda x: x[0], carry.agent), run_dir


def skill_success(name: str, agent, episodes: int, seed: int) -> float:
    """Success at the last step of `episodes` fresh episodes from the skill's true start
    distribution with the frozen deterministic policy (native backend)."""
    env = library.skill_envs((name,))[0]
    train = TrainConfig(task=name, eval_episodes=episodes)
    learner = make_ddpg_her(env, train, DDPGConfig())
    evaluate = jax.jit(
        lambda a, k: rollout.run_episodes(env, learner.evaluate(a, None), k, episodes)[1].metrics[
            "success"
        ]
    )
    return float(jnp.mean(evaluate(agent, jax.random.PRNGKey(10_000 + seed))))


def collect_skill(
    name: str, agent, config: LibraryConfig, progress: bool, names: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """`config.samples` runs of skill `name` in chunks of `collect_envs` (one compiled
    program), from its own starts and the other skills' of `names` (`own_start_share`)."""
    envs = library.skill_envs(names)
    own = names.index(name)
    chunk = min(config.collect_envs, config.samples)
    counts = fit.start_counts(chunk, own, len(envs), config.own_start_share)
    collect = jax.jit(fit.make_collect(envs[own], envs, counts, DDPGConfig()))
    parts = []
    n_chunks = -(-config.samples // chunk)
    for i in tqdm(range(n_chunks), desc=f"collect {name}", disable=not progress, unit="chunk"):
        key = jax.random.fold_in(jax.random.PRNGKey(config.seed), 1000 * own + i)
        parts.append(jax.tree.map(np.asarray, collect(agent, key)))
    data = {k: np.concatenate([p[k] for p in parts])[: config.samples] for k in parts[0]}
    order = np.random.default_rng(config.seed + own).permutation(config.samples)
    return {k: v[order] for k, v in data.items()}


def fit_library(names, agents, data, config: LibraryConfig, progress: bool):
    """The vmapped fits over the skill axis -> (SkillLibrary, per-skill metrics, history)."""
    envs = library.skill_envs(names)
    K, N = len(names), config.samples
    n_val = max(1, int(N * config.holdout))
    stack = lambda key: np.stack([data[n][key] for n in names])  # (K, N, ...)
    s0, goal, s_T, success = stack("s0"), stack("goal"), stack("s_T"), stack("success")
    obs_dim = s0.shape[-1]
    x = np.concatenate([s0, goal], axis=-1)
    delta = s_T - np.asarray(library.anchor_point(envs[0].layout, config.anchor, s0, goal))
    train_w = np.ones((K, N), np.float32)
    train_w[:, N - n_val :] = 0.0
    in_stats = [fit.standardize(x[k], train_w[k], config.still_inputs) for k in range(K)]
    d_stats = [fit.standardize(delta[k], train_w[k] * success[k]) for k in range(K)]
    in_norm = library.Norm(*map(jnp.asarray, map(np.stack, zip(*in_stats, strict=True))))
    d_norm = library.Norm(*map(jnp.asarray, map(np.stack, zip(*d_stats, strict=True))))
    xn = (x - in_norm.mean[:, None]) / in_norm.std[:, None]
    dims = np.zeros((K, obs_dim), np.float32)
    for k, env in enumerate(envs):
        dims[k, list(env.state_dims)] = 1.0
    o, g = xn[..., :obs_dim], xn[..., obs_dim:]
    y_dyn = (delta - d_norm.mean[:, None]) / d_norm.std[:, None]

    def split(w_all, y):
        tr = {
            "o": o[:, : N - n_val],
            "g": g[:, : N - n_val],
            "y": y[:, : N - n_val],
            "w": w_all[:, : N - n_val],
            "dims": dims,
        }
        va = {
            "o": o[:, N - n_val :],
            "g": g[:, N - n_val :],
            "y": y[:, N - n_val :],
            "w": w_all[:, N - n_val :],
            "dims": dims,
        }
        return jax.tree.map(jnp.asarray, tr), jax.tree.map(jnp.asarray, va)

    keys = jax.random.split(jax.random.PRNGKey(config.seed + 7), K)
    dyn0, clf0 = fit.init_models(keys, config, obs_dim, goal.shape[-1])
    bar = tqdm(total=2 * config.fit_epochs, desc="fit models", disable=not progress)
    tick = lambda i, val: bar.update(1)
    dyn_tr, dyn_va = split(success.astype(np.float32), y_dyn)
    dyn, dyn_hist = fit.fit(
        dyn0,
        dyn_tr,
        dyn_va,
        fit.dynamics_loss(obs_dim, config.model_hidden),
        config.model_lr,
        config,
        keys,
        tick,
    )
    clf_tr, clf_va = split(np.ones((K, N), np.float32), success.astype(np.float32))
    clf, clf_hist = fit.fit(
        clf0,
        clf_tr,
        clf_va,
        fit.classifier_loss(config.classifier_hidden),
        config.classifier_lr,
        config,
        jax.vmap(lambda k: jax.random.fold_in(k, 1))(keys),
        tick,
    )
    bar.close()
    lib = _assemble(
        names, agents, dyn, clf, in_norm, d_norm, dims, x, s_T, success, N - n_val, config
    )
    history = {"dynamics": dyn_hist, "classifier": clf_hist}
    return (
        lib,
        evaluate_models(lib, x[:, N - n_val :], s_T[:, N - n_val :], success[:, N - n_val :]),
        history,
    )


def _assemble(names, agents, dyn, clf, in_norm, d_norm, dims, x, s_T, success, n_train, config):
    """SkillLibrary with memories of the training split's successes (padded to the largest)."""
    envs = library.skill_envs(names)
    K, obs_dim = len(names), s_T.shape[-1]
    ok = [np.flatnonzero(success[k, :n_train]) for k in range(K)]
    M = max(1, max(len(i) for i in ok))
    keys = np.zeros((K, M, x.shape[-1]), np.float32)
    nxt = np.zeros((K, M, obs_dim), np.float32)
    valid = np.zeros((K, M), bool)
    key_mask = np.zeros((K, x.shape[-1]), bool)
    for k, env in enumerate(envs):
        keys[k, : len(ok[k])], nxt[k, : len(ok[k])] = x[k, ok[k]], s_T[k, ok[k]]
        valid[k, : len(ok[k])] = True
        key_mask[k, list(env.memory_dims) + list(range(obs_dim, x.shape[-1]))] = True
    policy = jax.tree.map(lambda *p: jnp.stack(p), *agents)
    return library.SkillLibrary(
        policy=policy,
        dynamics=dyn,
        classifier=clf,
        input_norm=in_norm,
        delta_norm=d_norm,
        state_mask=jnp.asarray(dims > 0),
        memory_key_mask=jnp.asarray(key_mask),
        memory_keys=jnp.asarray(keys),
        memory_next=jnp.asarray(nxt),
        memory_valid=jnp.asarray(valid),
        names=tuple(names),
        ddpg_config=DDPGConfig(),
        config=config,
    )


def build(args: SkillsArgs, work: str | Path | None = None) -> Path:
    """Every phase -> the library directory. `work`: where the skills' training runs live
    (default beside the library); libraries sharing it share their trained skills."""
    out = check_writable_path(args.directory())
    if args.config.seed + 10_000 >= SEED_LIMIT:  # skill_success's keys: 10_000 + seed
        raise ValueError("invalid config value for 'seed': must be < 2**32 - 10000 (keys)")
    if out.exists():
        raise FileExistsError(
            f"{out} exists; a library is never overwritten (choose another --out, or delete it)"
        )
    library.remove_partials(out)
    made_by = library.provenance()  # the code as it was loaded, before a long build
    default_work = out.with_name(f".{out.name}.work")
    work = check_writable_path(default_work if work is None else work, "--work")
    names = args.names()
    args = dataclasses.replace(args, config=build_config(args.library, args.config))
    config, timings, success, agents, runs, data = args.config, {}, {}, [], {}, {}
    for name in names:
        t0 = time.time()
        agent, runs[name] = train_skill(name, config, work, args.progress)
        success[name] = skill_success(name, agent, config.skill_eval_episodes, config.seed)
        agents.append(agent)
        timings[f"train_{name}_s"] = round(time.time() - t0, 1)
        print(
            f"{name}: success {success[name]:.3f} on {config.skill_eval_episodes} fresh "
            f"episodes ({timings[f'train_{name}_s']} s)",
            file=sys.stderr,
        )
    t0 = time.time()
    for name, agent in zip(names, agents, strict=True):
        data[name] = collect_skill(name, agent, config, args.progress, names)
    timings["collect_s"] = round(time.time() - t0, 1)
    t0 = time.time()
    lib, metrics, history = fit_library(names, agents, data, config, args.progress)
    timings["fit_s"] = round(time.time() - t0, 1)
    manifest = {
        "skill_success": success,
        "skill_runs": {n: str(r) for n, r in runs.items()},
        "models": metrics,
        "timings_s": timings,
        "memory_size": int(lib.memory_keys.shape[1]),
        "samples": {
            n: {
                "total": int(len(d["success"])),
                "successes": int(d["success"].sum()),
                "success_by_start": _by_source(d, names),
            }
            for n, d in data.items()
        },
        "dims": {
            n: {
                "state_dims": list(e.state_dims),
                "memory_dims": list(e.memory_dims),
                "param_dim": e.param_dim,
            }
            for n, e in zip(names, lib.envs, strict=True)
        },
        "fit_history": history,
        "env_steps": {
            "train": {n: _trained_env_steps(r) for n, r in runs.items()},
            "collect": {n: int(d["steps"].sum()) for n, d in data.items()},
        },
        # every stretch of each skill's training run, reused from `work` or not (timings_s
        # holds this process's seconds only)
        "train_wall_s": {n: round(wall_seconds(read_metrics(r)), 1) for n, r in runs.items()},
    }
    return library.save(lib, out, manifest, made_by)


def _trained_env_steps(run_dir: Path) -> int:
    """Env steps a skill's training took (its last logged epoch's count; evaluation and the
    starts' placement not counted)."""
    return int(read_metrics(run_dir)[-1]["env_steps"])


def _by_source(d: dict[str, np.ndarray], names: tuple[str, ...]) -> dict[str, float]:
    return {
        names[i] + "_start": float(d["success"][d["source"] == i].mean())
        for i in np.unique(d["source"])
    }


def main(argv: list[str] | None = None) -> None:
    compile_cache.enable()
    use_float32()
    argv = plugins.take_imports(sys.argv[1:] if argv is None else argv)
    try:
        args = tyro.cli(SkillsArgs, args=argv, description=__doc__)
        if args.table:
            print(f"wrote {write_table(args.directory())}")
            return
        out = build(args, work=args.work)
        print(json.dumps(library.read_manifest(out)["models"], indent=1))
        print(f"library written to {out}")
    except (ValueError, FileExistsError, FileNotFoundError) as err:
        raise SystemExit(f"error: {err}") from None
    except KeyboardInterrupt:  # no library is written from a half-trained skill
        print(
            "interrupted: no library written; run the same command again to resume the "
            "skills' training where it stopped",
            file=sys.stderr,
        )
        raise SystemExit(INTERRUPTED) from None


if __name__ == "__main__":
    main()
