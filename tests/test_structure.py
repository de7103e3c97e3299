"""The package's shape: layers imported one way, no import circles, modules of a readable size;
the thesis's study (study/) apart from it."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "mjx_skills"
STUDY = ROOT / "study"
MAX_LINES = 400


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_main_guard(node: ast.AST) -> bool:
    return (
        isinstance(node, ast.If)
        and isinstance(node.test, ast.Compare)
        and isinstance(node.test.left, ast.Name)
        and node.test.left.id == "__name__"
    )


def _imports(path: Path, modules: set[str]) -> set[str]:
    """Package modules that `path` imports when it is imported (anywhere in it, functions
    included; not under `if __name__ == "__main__"`, which runs only as a script)."""
    tree = ast.parse(path.read_text())
    guarded = {id(n) for g in ast.walk(tree) if _is_main_guard(g) for n in ast.walk(g)}
    found = set()
    for node in ast.walk(tree):
        if id(node) in guarded:
            continue
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names = [f"{node.module}.{a.name}" for a in node.names] + [node.module]
        else:
            continue
        found |= {n for n in names if n in modules}
    return found - {_module_name(path)}


def test_no_import_circles():
    paths = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph = {m: _imports(p, set(paths)) for m, p in paths.items()}
    state: dict[str, int] = {}

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                cycle = path[path.index(n) :] + [n] if n in path else [m, n]
                raise AssertionError("import circle: " + " -> ".join(cycle))
            if n not in state:
                visit(n, [*path, n])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    # config is a leaf: its modules import only each other.
    config = {m for m in graph if m.split(".")[:2] == ["mjx_skills", "config"]}
    assert "mjx_skills.config" in config
    assert all(n in config for m in config for n in graph[m]), {m: graph[m] for m in config}


OURS = ("mjx_skills", "study", "tests", "benchmarks", "experiments", "examples")
"""The folders of this project's Python: the package, the study, the tests and the scripts."""


def _ours() -> list[Path]:
    return [p for folder in OURS for p in sorted((ROOT / folder).rglob("*.py"))]


def test_modules_stay_readable():
    """Every module of the package, the study, the tests and the scripts is under MAX_LINES
    lines."""
    long = {
        str(p.relative_to(ROOT)): n
        for p in _ours()
        if (n := len(p.read_text().splitlines())) > MAX_LINES
    }
    assert not long, f"modules over {MAX_LINES} lines: {long}"


def test_no_module_is_packed_into_its_line_count():
    """The package, study/, the tests and the scripts are as `ruff format` writes them (the
    lint checks that): no `# fmt: skip` keeps a module under the cap by packing lines."""
    marker = re.compile(r"#\s*fmt:\s*skip\s*$", re.MULTILINE)
    packed = [str(p.relative_to(ROOT)) for p in _ours() if marker.search(p.read_text())]
    assert not packed, packed


LAYERS = ("config", "core", "envs", "agents", "skills", "methods", "training", "sweeps", "analysis")
"""Low to high: a module imports only from its own layer and those below. `mjx_skills`
itself (the version) is below all; the command modules at the top level are above all."""


def _layer(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1:
        return -1
    if parts[1] in LAYERS:
        return LAYERS.index(parts[1])
    return len(LAYERS)  # a command: train, build_library, sweep, evaluate, render, plot


def test_layers_import_one_way():
    paths = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    assert {m.split(".")[1] for m in paths if m.count(".") >= 2} <= set(LAYERS), (
        "a subpackage without a layer"
    )
    upward = [
        f"{m} -> {n}"
        for m, p in sorted(paths.items())
        for n in sorted(_imports(p, set(paths)))
        if _layer(n) > _layer(m)
    ]
    assert not upward, "imports against the layers: " + ", ".join(upward)
    commands = {m for m in paths if _layer(m) == len(LAYERS)}
    assert commands == {
        f"mjx_skills.{c}"
        for c in (
            "train",
            "build_library",
            "sweep",
            "evaluate",
            "render",
            "plot",
            "cli_args",
            "api",
        )
    }


def test_the_package_does_not_import_the_study():
    """The study (study/) builds on the library, never the other way round."""
    imports = [
        f"{p.relative_to(ROOT)}: {name}"
        for p in PACKAGE.rglob("*.py")
        for node in ast.walk(ast.parse(p.read_text()))
        for name in (
            [a.name for a in node.names]
            if isinstance(node, ast.Import)
            else [node.module or ""]
            if isinstance(node, ast.ImportFrom)
            else []
        )
        if name.split(".")[0] == "study"
    ]
    assert not imports, imports


GENERIC = {"smoke": "a smoke test", "oracle": "an explorer that knows the answer"}
"""Experiment names that are plain words, allowed in the package in their plain sense."""


def _library_words() -> set[str]:
    """The library's own names: registered methods, their option groups and options (as
    `group_field`, e.g. `bc_weight`), tasks, and the package's module names."""
    import dataclasses

    from mjx_skills.envs.registry import ENVS
    from mjx_skills.methods import METHODS

    groups = {g: opt for spec in METHODS.values() for g, opt in spec.options.items()}
    options = {f"{g}_{f.name}" for g, opt in groups.items() for f in dataclasses.fields(opt)}
    modules = {p.stem for p in PACKAGE.rglob("*.py")}
    return {*METHODS, *groups, *options, *ENVS, *modules, *GENERIC}


def test_the_package_holds_no_study_names():
    """No experiment of experiments/*.toml is named in `mjx_skills/**/*.py` (code, strings,
    docstrings or comments): the study's experiments, their labels and prose live in study/,
    so that a new experiment adds a file without editing the library. An experiment whose
    name is also one of the library's own words is exempt: a registered method
    (`ddpg_her_sl_fast`), an option group or option (`fast`, `bc`, `bc_weight`), a task, a
    module of the package (`two_objects`), or a plain word (`GENERIC`: `smoke`, `oracle`).
    A name counts as a whole word: `fast` inside `ddpg_her_sl_fast` is not `fast`."""
    import re

    allowed = _library_words()
    stems = sorted(p.stem for p in (ROOT / "experiments").glob("*.toml"))
    assert len(stems) > 10 and "fig6_3" in stems  # the experiments are where they were
    names = [s for s in stems if s not in allowed]
    pattern = re.compile(r"(?<!\w)(" + "|".join(map(re.escape, names)) + r")(?!\w)")
    found = sorted(
        f"{p.relative_to(ROOT)}:{i}: {m.group(1)}"
        for p in PACKAGE.rglob("*.py")
        for i, line in enumerate(p.read_text().splitlines(), 1)
        for m in pattern.finditer(line)
    )
    assert not found, "study names in the package: " + ", ".join(found)


def test_only_envs_know_the_observation_offsets():
    """Outside `envs/` the observation is read through the env's declared `ObsLayout`, so a
    task with another observation cannot be misread silently by the library or a method."""
    offenders = sorted(
        str(p.relative_to(PACKAGE))
        for p in PACKAGE.rglob("*.py")
        if p.parent.name != "envs" and "OBS_" in p.read_text()
    )
    assert not offenders, offenders


def test_every_command_has_an_installed_script():
    """Each command module (`python -m mjx_skills.NAME`) is also a console script
    (`mjx-skills-NAME`) whose target is that module's `main`."""
    import importlib
    import tomllib

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    for command in ("train", "sweep", "build_library", "evaluate", "render"):
        target = scripts[f"mjx-skills-{command.replace('_', '-')}"]
        assert target == f"mjx_skills.{command}:main", target
        assert callable(importlib.import_module(f"mjx_skills.{command}").main)


def test_git_ignores_only_results_that_an_experiment_derives():
    """CI runs on a fresh clone: a file that git ignores is missing there. Under
    experiments/results/ git ignores only a training sweep's derived NAME.csv / NAME.jsonl
    (made by `make results` from the stored cells), so an ignored file there must name a
    training experiment; anything else a test or a report reads (a library sweep's table,
    whose libraries are not stored) must be committed."""
    import subprocess

    root = Path(__file__).resolve().parents[1]
    if not (root / ".git").exists():
        return  # an installed copy: nothing is ignored
    ignored = subprocess.run(
        [
            "git",
            "ls-files",
            "--others",
            "--ignored",
            "--exclude-standard",
            "--",
            "experiments/results",
        ],
        cwd=root,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    from mjx_skills.sweeps import experiment_file

    trained = {
        n for n in experiment_file.names() if experiment_file.raw(n).get("kind") != "library"
    }
    stray = [p for p in ignored if "/cells/" not in p and Path(p).stem not in trained]
    assert not stray, f"ignored by git but not derived from an experiment: {stray}"
    for kept in ("scripted.jsonl", "table5_1.csv", "table5_1_thesis.csv"):
        probe = subprocess.run(
            ["git", "check-ignore", "-q", f"experiments/results/{kept}"], cwd=root
        )
        assert probe.returncode == 1, f"experiments/results/{kept} must not be ignored"
