"""What a run records of the skill library it searches with (RUN_DIR/library.json, a stored
cell's `library`): the library's commit and scenes' digest from its manifest, and for a
library of the user's its skills' definitions (`registry.fingerprint`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mjx_skills.skills.library import read_manifest
from mjx_skills.skills.registry import fingerprint


def library_provenance(config: dict[str, Any]) -> dict[str, Any] | None:
    """The commit and scenes' digest of the library a run config's method reads (None: it
    reads none), and for a library of the user's its skills' definitions
    (`registry.fingerprint`: their settings and a digest of their source)."""
    for group in config.get("options", {}).values():
        if "library_dir" in group:
            manifest = read_manifest(Path(group["library_dir"]))
            out = {"commit": manifest.get("commit"), "scenes": manifest.get("scenes")}
            skills = fingerprint(group["library"])  # a library of the user's skills
            return out if skills is None else {**out, "skills": skills}
    return None
