"""A library build's skill training runs in its work directory (`build_library --work`): which
one a build resumes. Each run records the digest of the skill env's source that trained it
(`registry.env_digest`); a build resumes the newest run of the skill's env as it is now, and
trains anew in a new run otherwise (an edited env, or a run that records none), keeping the
old one."""

from __future__ import annotations

import json
from pathlib import Path

from mjx_skills.skills import registry

SKILL_RECORD = "skill_env.json"
"""In a skill's training run: {"env": the digest of the env's source that trained it}."""


def latest(work: Path, name: str, epochs: int | None = None) -> Path | None:
    """The newest run of skill `name` in `work` trained by its env as it is now and, given
    `epochs`, set to train at most that many (a shorter one trains on to `epochs`; a longer
    one cannot be cut back), or None (said on stdout where runs exist but none qualifies)."""
    runs = sorted((work / name / "ddpg_her").glob("*/config.json")) if work.exists() else []
    digest = registry.env_digest(name)
    same = [run.parent for run in runs if _recorded(run.parent) == digest]
    if runs and not same:
        print(f"{name}: {runs[-1].parent} was trained by another or unrecorded env; training anew")
    fits = [run for run in same if epochs is None or planned_epochs(run) <= epochs]
    if same and not fits:
        print(
            f"{name}: {same[-1]} trains {planned_epochs(same[-1])} epochs, more than {epochs}; training anew"
        )
    return fits[-1] if fits else None


def planned_epochs(run_dir: Path) -> int:
    """The epochs a skill's training run is set to train (its config.json)."""
    return int(json.loads((run_dir / "config.json").read_text())["train"]["epochs"])


def record(run_dir: Path, name: str) -> None:
    """Record in `run_dir` that skill `name`'s env as it is now trained it."""
    (run_dir / SKILL_RECORD).write_text(json.dumps({"env": registry.env_digest(name)}))


def _recorded(run_dir: Path) -> str | None:
    path = run_dir / SKILL_RECORD
    return json.loads(path.read_text())["env"] if path.exists() else None
