"""Where runs, checkpoints and libraries may be written: checked before any work starts.

Orbax (the checkpoints, the skill library's arrays) finishes a save by globbing its own
directory, so a path holding a glob class (`runs[v2]/`) or a backslash saves nothing it can
read back: the save only logs "Skipping merge of OCDBT checkpoints" and the trained run is
lost (tests/core/test_paths.py sweeps every character). Such paths are refused up front.
"""

from __future__ import annotations

import os
from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[2]
"""The directory that holds the package: in a source checkout, the one with experiments/."""

REFUSED = "[]\\"
"""Characters orbax reads as glob syntax in a path (spaces, non-ASCII, `%#?*` work)."""
REFUSED_RUNS = ("**",)
"""Runs of characters orbax's glob refuses in a path (etils: "Recursive `**` pattern not
supported"; a single `*` works)."""


def check_writable_path(path: str | Path, what: str = "--out") -> Path:
    """`path` made absolute (`~` expanded), or ValueError naming `what`: an empty path (which
    would mean the current directory, never what was meant) or the characters it may not
    hold. Callers write to the returned path, so a `~` never becomes a directory named `~`."""
    if not str(path).strip():
        raise ValueError(f"{what}: an empty path; give a directory")
    full = Path(path).expanduser().resolve()
    bad = sorted({c for c in str(full) if c in REFUSED}) + [
        r for r in REFUSED_RUNS if r in str(full)
    ]
    if bad:
        raise ValueError(
            f"{what} {full}: a path holding {' '.join(map(repr, bad))} cannot be used (orbax, "
            "which writes the checkpoints, reads these as glob patterns and loses the data); "
            "choose a directory without them"
        )
    return full


def directory(text: str) -> Path:
    """An argparse `type` for a directory flag: `~` expanded; an empty one is refused
    (ValueError, which argparse reports as an invalid value of the flag)."""
    if not text.strip():
        raise ValueError("an empty path")
    return Path(text).expanduser()


HOME = "MJX_SKILLS_HOME"
"""Environment variable: a directory (e.g. a checkout's root) where relative artifact paths
such as `experiments/skill_library` are looked up after the working directory."""


def roots() -> list[Path]:
    """Where a relative artifact path is looked up after the working directory, in order:
    $MJX_SKILLS_HOME (when set), then the checkout the package runs from (`CHECKOUT`)."""
    home = os.environ.get(HOME, "").strip()
    return [*([Path(home).expanduser()] if home else []), CHECKOUT]


def in_checkout(path: str | Path) -> Path:
    """`path` where it is absolute or exists from the working directory; else the first of
    `roots()` that holds the relative path: the committed skill libraries, which the options
    name relative to the checkout (`experiments/skill_library`), are then found from any
    working directory. Else `path` as given (its reader says it is missing)."""
    path = Path(path)
    if path.is_absolute() or path.exists():
        return path
    return next((root / path for root in roots() if (root / path).exists()), path)


def is_checkout() -> bool:
    """Whether the package runs from a source checkout (with its experiments/), not from an
    install without one."""
    return (CHECKOUT / "experiments").is_dir()
