"""The package's shape: layers imported one way, no import circles, modules of a readable size."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "mjx_skills"
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
    assert "mjx_skills.config" in graph and not graph["mjx_skills.config"]


def test_modules_stay_readable():
    long = {
        p.name: n
        for p in PACKAGE.rglob("*.py")
        if (n := len(p.read_text().splitlines())) > MAX_LINES
    }
    assert not long, f"modules over {MAX_LINES} lines: {long}"


LAYERS = ("config", "core", "envs", "agents", "skills", "methods", "training", "sweeps", "analysis")
"""Low to high: a module imports only from its own layer and those below. `mjx_skills`
itself (the version) is below all; the command modules at the top level are above all."""


def _layer(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1:
        return -1
    if parts[1] in LAYERS:
        return LAYERS.index(parts[1])
    return len(LAYERS)  # a command: train, build_library, sweep, evaluate, render


def test_layers_import_one_way():
    paths = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    assert {m.split(".")[1] for m in paths if m.count(".") >= 2} <= set(LAYERS), (
        "a subpackage without a layer"
    )
    upward = [f"{m} -> {n}" for m, p in sorted(paths.items()) for n in sorted(_imports(p, set(paths)))
              if _layer(n) > _layer(m)]  # fmt: skip
    assert not upward, "imports against the layers: " + ", ".join(upward)
    commands = {m for m in paths if _layer(m) == len(LAYERS)}
    assert commands == {f"mjx_skills.{c}" for c in ("train", "build_library", "sweep", "evaluate",
                                                     "render", "cli_args")}  # fmt: skip


def test_only_envs_know_the_observation_offsets():
    """Outside `envs/` the observation is read through the env's declared `ObsLayout`, so a
    task with another observation cannot be misread silently by the library or a method."""
    offenders = sorted(
        str(p.relative_to(PACKAGE))
        for p in PACKAGE.rglob("*.py")
        if p.parent.name != "envs" and "OBS_" in p.read_text()
    )
    assert not offenders, offenders
