"""Command line of training: one subcommand per method, each with only its own options.

examples:
  python -m mjx_skills.train --task pick_move             # DDPG+HER+SL, the default method
  python -m mjx_skills.train ddpg_her --task transit --epochs 20 --seeds 2
  python -m mjx_skills.train ddpg_her_sl --preset thesis  # the thesis's formulation
  python -m mjx_skills.train --task fetch_pick_and_place --preset fetch  # the Fetch skills
  python -m mjx_skills.train --resume RUN_DIR             # the run's config.json decides
  python -m mjx_skills.train --resume RUN_DIR --epochs 60 # ... and train on to 60 epochs

Read before the method's options: --resume RUN_DIR [--epochs N] (nothing else with it),
--preset NAME (a method's option preset: default, thesis, fetch, fetch_push), --method NAME
(an earlier form of the subcommand) and --import MODULE (your module registering tasks or
robots: a dotted name or a .py path; repeatable).
"""

from __future__ import annotations

import dataclasses
import sys
from typing import Annotated

import tyro

from mjx_skills import methods
from mjx_skills.config import EnvConfig, TrainConfig
from mjx_skills.core import compile_cache, plugins
from mjx_skills.core.precision import use_float32
from mjx_skills.training.interrupt import INTERRUPTED
from mjx_skills.training.metrics_log import logged_epochs
from mjx_skills.training.runner import RunArgs, load_config, summary, train_run

DEFAULT_METHOD = "ddpg_her_sl"
"""The method run when none is named (here and by `make train`): of the thesis's methods
the one that reaches 0.9 on pick_move soonest in wall time on a CPU (DDPG+HER+SL+Fast gets
there in fewer epochs, each about four times as long: docs/results.md)."""

PRESET_METHODS = {"fetch": "ddpg_her_sl_fast", "fetch_push": "ddpg_her_sl_fast"}
"""The method a preset runs when none is named, where it is not `DEFAULT_METHOD`: on the
Fetch tasks DDPG+HER+SL+Fast, of the methods run there the soonest to 0.9 in env steps on
the fresh seeds (on FetchPush DDPG+HER+SL misses the level within its budget: docs/results.md,
the Fetch section)."""

ALIASES = {"--physics": "--env.physics"}
"""Short flags for the most used nested options."""


def _expand_alias(arg: str) -> str:
    flag, sep, value = arg.partition("=")
    return ALIASES.get(flag, flag) + sep + value


def _flag_value(argv: list[str], flag: str) -> tuple[str | None, list[str]]:
    """-> (value of `flag VALUE` or `flag=VALUE`, argv without it); SystemExit when the flag
    has no value or is given twice."""
    for i, arg in enumerate(argv):
        if arg == flag:
            if i + 1 >= len(argv):
                raise SystemExit(f"error: {flag} needs a value")
            value, rest = argv[i + 1], argv[:i] + argv[i + 2 :]
        elif arg.startswith(flag + "="):
            value, rest = arg.partition("=")[2], argv[:i] + argv[i + 1 :]
        else:
            continue
        if any(a == flag or a.startswith(flag + "=") for a in rest):
            raise SystemExit(f"error: {flag} given twice")
        if not value:
            raise SystemExit(f"error: {flag} needs a value")
        return value, rest
    return None, argv


def method_args_type(spec: methods.Method, preset: str = "default") -> type:
    """The CLI dataclass of one method: train options without prefix, --env.*, and one
    prefix per option group of the method (e.g. --ddpg.*), its defaults those of `preset`."""
    groups = methods.preset_options(spec.name, preset)
    train = Annotated[TrainConfig, tyro.conf.OmitArgPrefixes]
    fields = [
        ("train", train, dataclasses.field(default=methods.preset_train(spec.name, preset))),
        ("env", EnvConfig, dataclasses.field(default=EnvConfig())),
        *[
            (name, type(default), dataclasses.field(default=default))
            for name, default in groups.items()
        ],
    ]
    cls = dataclasses.make_dataclass(f"{spec.name}_args", fields, frozen=True)
    cls.__doc__ = f"{spec.description}\n\n{tasks_line()}"
    return cls


def tasks_line() -> str:
    """'tasks (--task): ...' with every registered task, for the help."""
    from mjx_skills.envs.registry import ENVS

    return f"tasks (--task): {', '.join(ENVS)}"


def description() -> str:
    """The help's text: this module's examples and the tasks."""
    return f"{__doc__.rstrip()}\n\n{tasks_line()}\n"


def parse(argv: list[str]) -> RunArgs:
    """argv -> RunArgs. Raises SystemExit with a one-line message on bad input."""
    argv = [_expand_alias(arg) for arg in argv]
    resume, rest = _flag_value(argv, "--resume")
    if resume is not None:
        epochs, rest = _flag_value(rest, "--epochs")
        if rest:
            raise SystemExit(
                f"error: --resume takes only --epochs N (its config.json decides the rest), "
                f"got {' '.join(rest)}"
            )
        if epochs is not None and not epochs.isdigit():
            raise SystemExit(f"error: --epochs needs a whole number, got {epochs!r}")
        return RunArgs(resume=resume, extend_to=None if epochs is None else int(epochs))
    preset, argv = _flag_value(argv, "--preset")
    name, argv = _flag_value(argv, "--method")
    if name is None and argv and not argv[0].startswith("-"):
        name, argv = argv[0], argv[1:]
    if name is None and not any(a in ("-h", "--help") for a in argv):
        # (plain --help lists every method)
        name = PRESET_METHODS.get(preset or "default", DEFAULT_METHOD)
    try:
        specs = {name: methods.get(name)} if name else methods.METHODS
        types = {n: method_args_type(spec, preset or "default") for n, spec in specs.items()}
    except (ValueError, NotImplementedError) as err:
        raise SystemExit(f"error: {err}") from None
    parsed = tyro.extras.subcommand_cli_from_dict(
        types,
        args=[*([name] if name else []), *argv],
        description=description(),
        prog="python -m mjx_skills.train",
    )
    chosen = next(n for n, t in types.items() if isinstance(parsed, t))
    options = {group: getattr(parsed, group) for group in specs[chosen].options}
    return RunArgs(train=parsed.train, method=chosen, env=parsed.env, options=options)


def main(argv: list[str] | None = None) -> None:
    compile_cache.enable()
    use_float32()
    argv = plugins.take_imports(sys.argv[1:] if argv is None else argv)
    try:
        args = parse(argv)
    except ValueError as err:  # an invalid config value, raised while tyro builds it
        raise SystemExit(f"error: {err}") from None
    try:
        run_dir = train_run(args)
    except (FloatingPointError, FileNotFoundError, ValueError, NotImplementedError) as err:
        # Diverged losses, a bad --resume directory or a checkpoint of another run.
        raise SystemExit(f"error: {err}") from None
    except KeyboardInterrupt:  # before the first epoch (building, compiling): nothing to lose
        print("interrupted before the first epoch", file=sys.stderr)
        raise SystemExit(INTERRUPTED) from None
    print(summary(run_dir))
    if logged_epochs(run_dir) < load_config(run_dir).train.epochs:
        raise SystemExit(INTERRUPTED)  # stopped by a signal: it said where it saved


if __name__ == "__main__":
    main()
