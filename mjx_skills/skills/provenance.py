"""Where a skill library comes from: the package version, the git commit and a digest of
the scenes it was built in, and why a library may not match this code (`stale_reasons`).
"""

from __future__ import annotations

import hashlib
import json
import logging
import re
import subprocess
from pathlib import Path
from typing import Any

from mjx_skills import __version__
from mjx_skills.core.files import tree_sha256
from mjx_skills.envs.baxter import XML_DIR

log = logging.getLogger(__name__)


def scene_files() -> list[Path]:
    """The MJCF files of the one-cube scenes (the skills' and the thesis's tasks') and the
    files they include: the physics the library was built for and is used in."""
    from mjx_skills.envs.registry import BAXTER

    todo, seen = {cls.scene for cls in BAXTER.values() if cls.n_objects == 1}, set()
    while todo:
        name = todo.pop()
        seen.add(name)
        todo |= set(re.findall(r'<include file="([^"]+)"', (XML_DIR / name).read_text())) - seen
    return sorted(XML_DIR / name for name in seen)


def scenes_digest() -> str:
    """SHA-256 (first 16 hex digits) of `scene_files()`: the skills were trained and their
    models fitted in these scenes, so a library built before one of them changed describes
    other physics. (Scenes added for other tasks, such as the two-cube ones, do not count.)"""
    digest = hashlib.sha256()
    for path in scene_files():
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def _git_commit() -> str:
    """The checkout's commit ('+dirty' when tracked files differ), or 'unknown'."""
    root = XML_DIR.parent
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return head + ("+dirty" if dirty.strip() else "")


def provenance() -> dict[str, str]:
    """What built a library: package version, git commit and the scenes' digest."""
    return {"version": __version__, "commit": _git_commit(), "scenes": scenes_digest()}


def stale_reasons(manifest: dict[str, Any]) -> list[str]:
    """Why a library may not match this code: another package version, or other scenes
    (or no record of either: built before they were recorded). Empty when it matches."""
    reasons = []
    if manifest.get("version") != __version__:
        reasons.append(f"built by version {manifest.get('version')}, this is {__version__}")
    if manifest.get("scenes") is None:
        reasons.append("built before the scenes' digest was recorded")
    elif manifest["scenes"] != scenes_digest():
        reasons.append("built in other scenes (xml/ has changed since)")
    return reasons


DEFINING = ("skills", "ddpg", "library", "memory_size")
"""The manifest's fields that say how the arrays are read and used (the anchor, the
networks' widths...): covered by its `definition` digest."""


def definition_sha256(manifest: dict[str, Any]) -> str:
    """SHA-256 of the manifest's `DEFINING` fields as canonical JSON."""
    defining = {k: manifest.get(k) for k in DEFINING}
    return hashlib.sha256(json.dumps(defining, sort_keys=True).encode()).hexdigest()


def check_definition(manifest: dict[str, Any], directory: Path) -> None:
    """ValueError naming `directory` when the manifest's `DEFINING` fields were edited since
    the build (its `definition` digest differs; none recorded: not checked)."""
    if "definition" in manifest and definition_sha256(manifest) != manifest["definition"]:
        raise ValueError(
            f"{directory}: manifest.json's {', '.join(DEFINING)} differ from those the "
            "library was built with (edited since); restore the file or build a library "
            "with the options wanted"
        )


def check_digest(lib: Any, manifest: dict[str, Any], directory: Path) -> None:
    """ValueError naming `directory` when the restored arrays are not the ones saved (their
    `tree_sha256` differs from the manifest's `digest`); a library saved before digests
    were recorded passes with a warning."""
    if "digest" not in manifest:
        why = "has no digest of its arrays (built before they were recorded)"
        log.warning("skill library %s %s: loaded unverified", directory, why)
    elif tree_sha256(lib) != manifest["digest"]:
        raise ValueError(
            f"{directory}: the library's arrays are damaged (their digest differs from the "
            "manifest's); restore the directory or rebuild it"
        )
