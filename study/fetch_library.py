"""The Fetch section's table of the skill library built on Fetch (`make skills ROBOT=fetch`):
Table 5.1's columns with the trivial goal predictor beside them, each skill's success, and
the env steps its build took."""

from __future__ import annotations

import json
from pathlib import Path

from mjx_skills.core.paths import CHECKOUT
from mjx_skills.skills.registry import default_dir, libraries_of
from study.sections import table

LIBRARY = CHECKOUT / default_dir("fetch") / "manifest.json"
"""The skill library built on Fetch (`make skills ROBOT=fetch`)."""


def manifests() -> dict[str, Path]:
    """Each registered library of Fetch's skills -> its manifest at its default directory
    (SL1_fetch: LIBRARY; the push library: `make skills ROBOT=fetch SKILL_LIBRARY=...`)."""
    return {
        name: CHECKOUT / default_dir("fetch", name) / "manifest.json"
        for name in libraries_of("fetch")
    }


def library_tables(
    used: list[tuple[str, Path]] = (), serves: dict[Path, list[str]] | None = None
) -> list[str]:
    """`library_table` for the first library of Fetch (saying so when it is not built) and
    for each other that is built, at its default directory or among `used` ((library,
    manifest path) that stored cells searched with), each once, with a blank line between.
    `serves`: resolved manifest path -> the tasks whose stored cells search with it."""
    serves = serves or {}
    first, *others = manifests().items()
    out = library_table(first[1], first[0], serves.get(first[1].resolve(), ()))
    shown = {first[1].resolve()}
    for name, path in [*others, *used]:
        if path.exists() and path.resolve() not in shown:
            shown.add(path.resolve())
            out += ["", *library_table(path, name, serves.get(path.resolve(), ()))]
    return out


def build_env_steps(manifest: dict) -> int:
    """Env steps a library's build took: its skills' training and data collection (0 for a
    manifest that does not record them)."""
    steps = manifest.get("env_steps", {})
    return sum(steps.get("train", {}).values()) + sum(steps.get("collect", {}).values())


def library_table(
    path: Path = LIBRARY, library: str = "SL1_fetch", serves: tuple[str, ...] = ()
) -> list[str]:
    """Table 5.1's columns for library `library` of Fetch at `path` (its manifest; no thesis
    figures: the thesis has no Fetch) with the trivial goal predictor beside them, each
    skill's success, and the env steps its build took: skill training and data collection.
    `serves`: the tasks whose stored cells search with it (said beside its cost)."""
    if not path.exists():
        return [f"No skill library {library} of Fetch is built yet (`make skills ROBOT=fetch`)."]
    m = json.loads(path.read_text())
    steps = m.get("env_steps", {})
    rows = []
    for name, e in m["models"].items():
        train, collect = steps.get("train", {}).get(name), steps.get("collect", {}).get(name)
        rows.append(
            [
                name,
                f"{m['skill_success'][name]:.3f}",
                f"{e['memory_error_cm']:.2f}",
                f"{e['model_error_cm']:.2f}",
                f"{e['goal_error_cm']:.2f}",
                f"{e['classifier_auc']:.3f}",
                f"{train:,}" if train is not None else "-",
                f"{collect:,}" if collect is not None else "-",
            ]
        )
    total = build_env_steps(m)
    header = ["skill", "success", "memory cm", "model cm", "goal cm", "classifier AUC"]
    return [
        f"The skill library {library} of Fetch (`{_shown(path.parent)}`, built at `{m['commit'][:7]}`): the "
        "skills' success on 200 fresh episodes of their own starts, and Table 5.1's held-out "
        'terminal errors with the trivial predictor ("the run ends at its goal", goal cm) '
        f"beside them; its build took {total:,} env steps (skill training and data "
        "collection; evaluation and the starts' placement not counted), a one-time cost "
        + (
            f"that the stored cells of {' and '.join(serves)} share."
            if serves
            else "that no stored cell searches with yet."
        ),
        "",
        *table([*header, "training env steps", "collection env steps"], rows),
    ]


def _shown(path: Path) -> Path:
    """`path` as the report prints it: from the checkout's root when it lies inside."""
    return path.relative_to(CHECKOUT) if path.is_relative_to(CHECKOUT) else path
