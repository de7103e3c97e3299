"""The skill library rebuilt from a clean commit (issue #44): the committed library's manifest
says its tree was dirty when it was built, so it was built again, from a clean checkout into
a directory of its own, and its figures are set beside the committed ones here. The
committed library stays: the stored cells are keyed to it.

    git worktree add /tmp/clean <commit> && cd /tmp/clean
    python -m mjx_skills.build_library --out /tmp/rebuild
    cp /tmp/rebuild/manifest.json <checkout>/experiments/results/library_rebuild.json
"""

from __future__ import annotations

import json
from pathlib import Path

from study.sections import table

COMMITTED = Path("experiments/skill_library/manifest.json")
REBUILD = Path("experiments/results/library_rebuild.json")
FIGURES = (
    ("skill success", lambda m, n: m["skill_success"][n], "{:.3f}"),
    ("successful runs", lambda m, n: m["samples"][n]["successes"], "{:,}"),
    ("memory cm", lambda m, n: m["models"][n]["memory_error_cm"], "{:.2f}"),
    ("model cm", lambda m, n: m["models"][n]["model_error_cm"], "{:.2f}"),
    ("goal cm", lambda m, n: m["models"][n]["goal_error_cm"], "{:.2f}"),
    ("classifier AUC", lambda m, n: m["models"][n]["classifier_auc"], "{:.3f}"),
)
"""The manifest's figures compared: (label, reader(manifest, skill), format)."""


def differences(committed: dict, rebuild: dict) -> list[tuple[str, str, float, float]]:
    """(skill, figure, committed, rebuilt) for every figure of every skill that differs."""
    out = []
    for name in committed["skills"]:
        for label, read, _ in FIGURES:
            a, b = read(committed, name), read(rebuild, name)
            if a != b:
                out.append((name, label, a, b))
    return out


RUN_RECORDS = ("commit", "skill_runs", "timings_s", "definition", "digest")
"""Manifest fields that record a build (where, when, how long), not what it builds."""


def field_changes(committed: dict, rebuild: dict) -> list[str]:
    """What the rebuild's manifest records differently besides `RUN_RECORDS`: a field (or a
    field's entry) added, or changed from the committed value."""
    out = []
    for name in sorted(set(committed) | set(rebuild)):
        if name in RUN_RECORDS or committed.get(name) == rebuild.get(name):
            continue
        a, b = committed.get(name), rebuild.get(name)
        if isinstance(a, dict) and isinstance(b, dict):
            added = [f"`{name}.{k}` = {b[k]!r} (added)" for k in b if k not in a]
            changed = [f"`{name}.{k}`: {a[k]!r} -> {b.get(k)!r}" for k in a if a[k] != b.get(k)]
            out += added + changed
        else:
            out.append(f"`{name}`: {a!r} -> {b!r}")
    return out


def section(committed_path: Path = COMMITTED, rebuild_path: Path = REBUILD) -> list[str]:
    """The report's lines: both builds' commits, their figures side by side, whether the
    rebuild reproduced them and its arrays, and what else its manifest records
    differently."""
    if not (committed_path.exists() and rebuild_path.exists()):
        return ["No rebuild of the skill library is committed yet."]
    committed = json.loads(committed_path.read_text())
    rebuild = json.loads(rebuild_path.read_text())
    rows = [
        [name, label, fmt.format(read(committed, name)), fmt.format(read(rebuild, name))]
        for name in committed["skills"]
        for label, read, fmt in FIGURES
    ]
    diff = differences(committed, rebuild)
    figures = (
        f"all {len(rows)} figures below are identical"
        if not diff
        else f"{len(diff)} of {len(rows)} figures differ"
    )
    arrays = (
        "its arrays are bit for bit the committed library's (the same digest)"
        if committed["digest"] == rebuild["digest"]
        else "its arrays differ from the committed library's (another digest)"
    )
    changes = field_changes(committed, rebuild)
    recorded = (
        "Its manifest also records "
        + "; ".join(changes)
        + ": fields recorded since the committed library was built, which is why the "
        "definition digests differ."
        if changes
        else "The manifests record the same definition."
    )
    return [
        f"The committed library was built at `{committed['commit']}`; it was rebuilt from the "
        f"clean commit `{rebuild['commit']}` into a directory of its own (its manifest: "
        f"`{rebuild_path}`). In the rebuild {figures}, and {arrays}. {recorded}",
        "",
        *table(["skill", "figure", "committed", "rebuilt"], rows),
    ]
