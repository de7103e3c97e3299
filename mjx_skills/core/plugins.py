"""The user's own modules: tasks and robots registered from outside the package.

Every command takes `--import MODULE` (repeatable; a dotted module name importable from the
working directory, or a path to a .py file), and `MJX_SKILLS_IMPORT=mod1,mod2` does the
same from the environment. The modules are imported before the command reads its
arguments; a module registers its tasks and robots when imported
(`mjx_skills.envs.registry.register_task`, `register_robot`). The names are kept in the
environment variable, so the worker processes a sweep spawns import them too (a worker
loads them before its cell: `load_named`), as does `api.load`. An installed package may
instead declare its modules as entry points of group `mjx_skills.plugins`; every command
loads those first (`load_entry_points`).
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.metadata
import importlib.util
import os
import sys
from pathlib import Path

ENV = "MJX_SKILLS_IMPORT"
GROUP = "mjx_skills.plugins"
"""The entry-point group an installed package registers its modules under (`load_entry_points`)."""
FLAG = "--import"
HELP = "a module of yours (dotted name or .py path) that registers tasks or robots; repeatable"


def named() -> list[str]:
    """The modules MJX_SKILLS_IMPORT names, in order (spaces around the commas dropped)."""
    return [m.strip() for m in os.environ.get(ENV, "").split(",") if m.strip()]


def load(module: str, given: str = FLAG) -> None:
    """Import `module` (a dotted name importable from the working directory, or a path to a
    .py file) once. ValueError naming it and how it was `given` when it cannot be found."""
    if module.endswith(".py"):
        path = Path(module).expanduser().resolve()
        digest = hashlib.sha1(str(path).encode()).hexdigest()[:8]  # two task.py files differ
        name = f"mjx_skills_user_{path.stem}_{digest}"
        if name in sys.modules:
            return
        if not path.is_file():
            raise ValueError(f"{given} {module}: no such file")
        spec = importlib.util.spec_from_file_location(name, path)
        loaded = importlib.util.module_from_spec(spec)
        sys.modules[name] = loaded
        try:
            spec.loader.exec_module(loaded)
        except BaseException:
            del sys.modules[name]
            raise
        return
    if os.getcwd() not in sys.path and "" not in sys.path:  # a console script's sys.path
        sys.path.insert(0, os.getcwd())
    try:
        importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name and module.startswith(err.name):
            raise ValueError(
                f"{given} {module}: no module {err.name!r} importable from {Path.cwd()} "
                f"(or give the path of its .py file; {ENV} names modules too)"
            ) from None
        raise


def take_imports(argv: list[str], load_now: bool = True) -> list[str]:
    """`argv` without its `--import MODULE` / `--import=MODULE` pairs, whose modules are
    added to MJX_SKILLS_IMPORT (paths made absolute, for processes in other directories)
    and imported (later, by `load_named`, unless `load_now`). SystemExit with one line when
    a module is missing."""
    rest, modules = [], []
    args = iter(argv)
    for arg in args:
        if arg == FLAG:
            value = next(args, None)
            if value is None:
                raise SystemExit(f"error: {FLAG} needs a module name or a .py path")
            modules.append(value)
        elif arg.startswith(FLAG + "="):
            modules.append(arg.partition("=")[2])
        else:
            rest.append(arg)
    modules = [str(Path(m).expanduser().resolve()) if m.endswith(".py") else m for m in modules]
    if modules:
        os.environ[ENV] = ",".join(dict.fromkeys([*named(), *modules]))
    if load_now:
        load_named(modules)
    return rest


def load_all(flagged: list[str] = ()) -> None:
    """Load every installed package's `mjx_skills.plugins` entry points, then import every
    module MJX_SKILLS_IMPORT names. ValueError naming a missing module and how it was given
    (`flagged`: the ones from `--import`), or an entry point that fails to load."""
    load_entry_points()
    for module in named():
        load(module, FLAG if module in flagged else f"{ENV}:")


_LOADED_ENTRY_POINTS: set[str] = set()


def load_entry_points() -> None:
    """Load (once each) the entry points of group GROUP that installed packages declare, e.g.
    in a package's pyproject.toml

        [project.entry-points."mjx_skills.plugins"]
        my_skills = "my_package.skills"

    so that its tasks, robots and skills register with no --import (a value naming a
    function, "my_package.skills:register", is called). ValueError naming an entry point
    that fails to load."""
    for entry in importlib.metadata.entry_points(group=GROUP):
        if entry.value in _LOADED_ENTRY_POINTS:
            continue
        try:
            loaded = entry.load()
            if entry.attr:  # "package.module:register": a function that registers, called
                loaded()
        except Exception as err:
            raise ValueError(
                f"entry point {entry.name} = {entry.value!r} (group {GROUP}) failed to load: "
                f"{type(err).__name__}: {err}"
            ) from err
        _LOADED_ENTRY_POINTS.add(entry.value)


def load_named(flagged: list[str] = ()) -> None:
    """`load_all` for a command: SystemExit with one line if a module is missing."""
    try:
        load_all(flagged)
    except ValueError as err:
        raise SystemExit(f"error: {err}") from None
