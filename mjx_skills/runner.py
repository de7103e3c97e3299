"""The host loop: call the jitted epoch, log, draw progress, checkpoint, resume.

A run lives in OUT/<task>/<method>/<timestamp>/ with config.json, metrics.jsonl (one line
per epoch per seed), TensorBoard events and checkpoints/. A run directory is never reused:
`--resume RUN_DIR` continues that run where its last checkpoint left it.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from pathlib import Path
from typing import Annotated

import jax
import numpy as np
import tyro

from mjx_skills.checkpoint import Checkpoints
from mjx_skills.config import DDPGConfig, EnvConfig, TrainConfig
from mjx_skills.logging import MetricsWriter, progress_bar
from mjx_skills.train import build


@dataclasses.dataclass(frozen=True)
class Args:
    train: Annotated[TrainConfig, tyro.conf.OmitArgPrefixes]
    env: EnvConfig = EnvConfig()
    ddpg: DDPGConfig = DDPGConfig()
    resume: str | None = None
    """Continue the run in this directory from its last checkpoint (its config.json wins)."""


def new_run_dir(train: TrainConfig) -> Path:
    """OUT/<task>/<method>/<timestamp>[-N]: a fresh directory, never an existing one."""
    base = Path(train.out) / train.task / train.method / time.strftime("%Y%m%d-%H%M%S")
    run_dir, n = base, 1
    while True:
        try:
            run_dir.mkdir(parents=True, exist_ok=False)
            return run_dir
        except FileExistsError:
            n += 1
            run_dir = base.with_name(f"{base.name}-{n}")


def save_config(run_dir: Path, args: Args) -> None:
    (run_dir / "config.json").write_text(json.dumps(dataclasses.asdict(args), indent=2))


def load_config(run_dir: Path) -> Args:
    path = run_dir / "config.json"
    if not path.exists():
        raise FileNotFoundError(f"{run_dir} has no config.json: not a run directory")
    raw = json.loads(path.read_text())
    train = TrainConfig(**raw["train"])
    env = EnvConfig(**raw["env"])
    ddpg = DDPGConfig(**{**raw["ddpg"], "hidden": tuple(raw["ddpg"]["hidden"])})
    return Args(train=train, env=env, ddpg=ddpg, resume=str(run_dir))


def check_finite(metrics: dict[str, np.ndarray]) -> None:
    bad = [k for k, v in metrics.items() if not np.all(np.isfinite(v))]
    if bad:
        raise FloatingPointError(f"non-finite {', '.join(bad)}; the last good checkpoint is kept")


def train_run(args: Args, stop_after: int | None = None) -> Path:
    """Train (or resume) a run; returns its directory. `stop_after` ends the run after that
    epoch as Ctrl-C would (checkpoint saved), for tests and for training in pieces."""
    if args.resume:
        run_dir = Path(args.resume)
        args = load_config(run_dir)
    else:
        run_dir = new_run_dir(args.train)
        save_config(run_dir, args)
    cfg = args.train
    env, epoch_fn, carry = build(cfg, args.env, args.ddpg)
    checkpoints = Checkpoints(run_dir / "checkpoints")
    start = 0
    if args.resume and checkpoints.latest_epoch() is not None:
        start, carry = checkpoints.restore(carry)
    writer = MetricsWriter(run_dir, resume_from_epoch=start)
    steps_per_epoch = cfg.envs * cfg.cycles * env.episode_length
    bar = progress_bar(cfg.epochs, start, enabled=cfg.progress, desc=f"{cfg.task}/{cfg.method}")
    logged, t0 = start, time.time()
    try:
        for epoch in range(start + 1, cfg.epochs + 1):
            t_epoch = time.time()
            carry, metrics = epoch_fn(carry)
            metrics = jax.tree.map(np.asarray, metrics)
            check_finite(metrics)
            writer.write(epoch, metrics, episodes=epoch * cfg.envs * cfg.cycles,
                         env_steps=epoch * steps_per_epoch, wall_s=time.time() - t0)  # fmt: skip
            logged = epoch
            sps = steps_per_epoch * cfg.seeds / max(time.time() - t_epoch, 1e-9)
            bar.set_postfix(eval_success=f"{metrics['eval_success'].mean():.2f}",
                            env_steps=epoch * steps_per_epoch, steps_per_s=f"{sps:.0f}")  # fmt: skip
            bar.update(1)
            if epoch % cfg.checkpoint_every == 0 or epoch == cfg.epochs:
                checkpoints.save(epoch, carry)
            if stop_after is not None and epoch >= stop_after:
                raise KeyboardInterrupt
    except KeyboardInterrupt:
        # Save only a carry whose epoch has been logged, so a resume continues the log.
        if (
            logged > start
            and checkpoints.latest_epoch() != logged
            and _carry_epoch(carry) == logged
        ):
            checkpoints.save(logged, carry)
        if stop_after is None:
            print(
                f"\ninterrupted after epoch {logged}; resume with --resume {run_dir}",
                file=sys.stderr,
            )
    finally:
        bar.close()
        writer.close()
        checkpoints.close()
    return run_dir


def _carry_epoch(carry) -> int | None:
    """The carry's epoch counter, or None if Ctrl-C hit mid-epoch (its buffers were donated)."""
    try:
        return int(np.asarray(carry.epoch).ravel()[0])
    except RuntimeError:
        return None


def summary(run_dir: Path) -> str:
    lines = [json.loads(x) for x in (run_dir / "metrics.jsonl").read_text().splitlines()]
    if not lines:
        return f"{run_dir}: no epochs"
    last = max(x["epoch"] for x in lines)
    final = [x["eval_success"] for x in lines if x["epoch"] == last]
    mean = sum(final) / len(final)
    spread = math.sqrt(sum((f - mean) ** 2 for f in final) / len(final))
    return f"{run_dir}: epoch {last}, eval success {mean:.2f} +- {spread:.2f} over {len(final)} seed(s)"


ALIASES = {"--physics": "--env.physics"}
"""Short flags for the most used nested options."""


def _expand_alias(arg: str) -> str:
    flag, sep, value = arg.partition("=")
    return ALIASES.get(flag, flag) + sep + value


def main(argv: list[str] | None = None) -> None:
    argv = [_expand_alias(arg) for arg in (sys.argv[1:] if argv is None else argv)]
    try:
        args = tyro.cli(Args, args=argv, description=__doc__)
    except (ValueError, NotImplementedError) as err:
        raise SystemExit(f"error: {err}") from None
    try:
        run_dir = train_run(args)
    except (FloatingPointError, FileNotFoundError, ValueError) as err:
        # Diverged losses, a bad --resume directory or a checkpoint of another run.
        raise SystemExit(f"error: {err}") from None
    print(summary(run_dir))
